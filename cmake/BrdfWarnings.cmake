# Warnings as an interface target: every project target links brdf_warnings, third-party code does not.
include_guard(GLOBAL)

add_library(brdf_warnings INTERFACE)
target_compile_options(brdf_warnings INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
    -Wcast-align -Woverloaded-virtual -Wnull-dereference -Wimplicit-fallthrough>)

option(BRDF_WERROR "Treat warnings as errors" OFF)
if(BRDF_WERROR)
  target_compile_options(brdf_warnings INTERFACE -Werror)
endif()

# Options every project target shares. Numerics must not be reassociated: the solvers rely on IEEE
# semantics, so there is no -ffast-math anywhere (Release keeps CMake's -O3).
add_library(brdf_options INTERFACE)
target_link_libraries(brdf_options INTERFACE brdf_warnings)
