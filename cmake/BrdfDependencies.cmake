# Every dependency comes from a Debian package. When one is missing, say which package provides it
# instead of letting CMake print a generic "could not find" wall.
include_guard(GLOBAL)

set(BRDF_INSTALL_HINT "run tools/dev/install-deps.sh (apt-get) and configure again")

macro(brdf_require_package name debian_package)
  find_package(${name} ${ARGN} QUIET)
  if(NOT ${name}_FOUND)
    message(FATAL_ERROR
      "brdf-service needs ${name} (Debian package: ${debian_package}). ${BRDF_INSTALL_HINT}.")
  endif()
endmacro()

brdf_require_package(OpenCL "ocl-icd-opencl-dev opencl-headers pocl-opencl-icd")
if(NOT EXISTS /usr/include/CL/opencl.hpp)
  find_path(BRDF_OPENCL_HPP CL/opencl.hpp)
  if(NOT BRDF_OPENCL_HPP)
    message(FATAL_ERROR "brdf-service needs CL/opencl.hpp (Debian package: opencl-clhpp-headers). ${BRDF_INSTALL_HINT}.")
  endif()
endif()
brdf_require_package(nlohmann_json "nlohmann-json3-dev")
brdf_require_package(CLI11 "libcli11-dev")
brdf_require_package(OpenEXR "libopenexr-dev")
brdf_require_package(PNG "libpng-dev")
# libdeflate compresses the OpenEXR tables' ZIP blocks (formats/exr/zip_writer.h): about twice
# zlib's speed, which OpenEXR 3.1 uses.
find_package(PkgConfig QUIET)
if(PkgConfig_FOUND)
  pkg_check_modules(libdeflate QUIET IMPORTED_TARGET libdeflate)
endif()
if(NOT TARGET PkgConfig::libdeflate)
  message(FATAL_ERROR "brdf-service needs libdeflate (Debian package: libdeflate-dev). ${BRDF_INSTALL_HINT}.")
endif()
find_package(Threads REQUIRED)
# Dense linear algebra: OpenBLAS (runtime CPU dispatch, so one portable build uses AVX2/AVX-512 where
# the machine has them) for BLAS and LAPACK, with the LAPACKE C interface (liblapacke-dev's header;
# OpenBLAS carries the symbols).
set(BLA_VENDOR OpenBLAS)
brdf_require_package(BLAS "libopenblas-dev")
find_path(BRDF_LAPACKE_INCLUDE lapacke.h)
find_library(BRDF_LAPACKE_LIBRARY lapacke)
find_path(BRDF_CBLAS_INCLUDE cblas.h PATH_SUFFIXES x86_64-linux-gnu aarch64-linux-gnu openblas)
if(NOT BRDF_LAPACKE_INCLUDE OR NOT BRDF_CBLAS_INCLUDE OR NOT BRDF_LAPACKE_LIBRARY)
  message(FATAL_ERROR "brdf-service needs cblas.h and lapacke.h (Debian packages: libopenblas-dev liblapacke-dev). ${BRDF_INSTALL_HINT}.")
endif()

if(BRDF_BUILD_TESTS)
  brdf_require_package(GTest "googletest libgtest-dev")
  # The tests read our images and tables back with an independent reader, OpenImageIO (brdftool
  # itself does not link it: it loads some 260 libraries, 0.3 s at every start).
  brdf_require_package(OpenImageIO "libopenimageio-dev")
  # Debian's OpenImageIO target lists /usr/include/opencv4 among its include folders, which exists only
  # with libopencv-dev installed, and CMake refuses to generate with a missing one: keep those that exist.
  get_target_property(brdf_oiio_includes OpenImageIO::OpenImageIO INTERFACE_INCLUDE_DIRECTORIES)
  set(brdf_oiio_existing)
  foreach(dir IN LISTS brdf_oiio_includes)
    if(EXISTS "${dir}")
      list(APPEND brdf_oiio_existing "${dir}")
    endif()
  endforeach()
  set_property(TARGET OpenImageIO::OpenImageIO PROPERTY INTERFACE_INCLUDE_DIRECTORIES ${brdf_oiio_existing})

  # The formats tests run an independent numpy reader of the Fourier BSDF files.
  brdf_require_package(Python3 "python3 python3-numpy" COMPONENTS Interpreter)
endif()
if(BRDF_BUILD_BENCH)
  brdf_require_package(benchmark "libbenchmark-dev")
endif()
