# brdf_add_gtest(name SOURCES ... LIBS ... LABELS ... [TIMEOUT s])
# One executable per test folder, one CTest entry per TEST() through gtest_discover_tests. The test
# support library knows the source and build trees and points PoCL's kernel cache into the build
# tree (tests/support), so test binaries also run outside ctest and never write to $HOME.
# With BRDF_SANITIZE set, every test gets LSAN_OPTIONS with the suppressions in tools/dev/lsan.supp.
include_guard(GLOBAL)
include(GoogleTest)

function(brdf_add_gtest name)
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} brdf_test_support brdf_test_main brdf_options brdf_serial_blas)
  set(_environment)
  if(BRDF_SANITIZE)
    # OpenCL (ICD loader, PoCL, LLVM) keeps state until exit that LeakSanitizer reports; those
    # stacks are suppressed (tools/dev/lsan.supp), ours are not. One variable only: a list here
    # would be split by gtest_discover_tests. UBSan stops at the first finding by itself
    # (-fno-sanitize-recover, cmake/BrdfSanitizers.cmake).
    set(_environment ENVIRONMENT
      "LSAN_OPTIONS=suppressions=${CMAKE_SOURCE_DIR}/tools/dev/lsan.supp:print_suppressions=0")
  endif()
  gtest_discover_tests(${name}
    DISCOVERY_MODE PRE_TEST
    DISCOVERY_TIMEOUT 60
    PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT} ${_environment})
endfunction()
