# Warnings as an interface target: every project target links brdf_warnings, third-party code does not.
include_guard(GLOBAL)

add_library(brdf_warnings INTERFACE)
target_compile_options(brdf_warnings INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
    -Wcast-align -Woverloaded-virtual -Wnull-dereference -Wimplicit-fallthrough>
  # GCC's notes that the ABI for passing 32- and 64-byte vector arguments changed in GCC 4.6: the
  # lane kernels pass GCC vectors only between internal functions of one translation unit, never
  # across a library boundary, so no two compilers' code ever meets there.
  $<$<CXX_COMPILER_ID:GNU>:-Wno-psabi>)

option(BRDF_WERROR "Treat warnings as errors" OFF)
if(BRDF_WERROR)
  target_compile_options(brdf_warnings INTERFACE -Werror)
endif()

# Options every project target shares. Numerics must not be reassociated: the solvers rely on IEEE
# semantics, so there is no -ffast-math anywhere (Release keeps CMake's -O3). Nor contracted: GCC
# fuses a * b + c into one FMA wherever the target has it, in ISO C++ mode too, so the functions
# compiled for AVX2 or AVX-512 (target_clones) would round differently from the baseline build and
# from the OpenCL kernels (FP_CONTRACT OFF); -ffp-contract=off keeps every clone bit for bit the same.
# One file is the exception, on purpose: Mie's series kernels (src/brdf/mie/phase_function.cpp) fuse
# where the CPU has FMA, have no OpenCL twin, and the Mie disk cache keys its files by the kernel set.
add_library(brdf_options INTERFACE)
target_link_libraries(brdf_options INTERFACE brdf_warnings)
# -fno-math-errno: nothing reads errno after a math function, and with it GCC keeps a call to sqrt
# for the negative case, which stops loops with a square root from vectorising; the values are the
# same (IEEE square roots either way).
target_compile_options(brdf_options INTERFACE $<$<CXX_COMPILER_ID:GNU,Clang>:-ffp-contract=off -fno-math-errno>)
