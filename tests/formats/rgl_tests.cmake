# Tests of formats/rgl (RGL tensor BSDF files), included from tests/formats/CMakeLists.txt.
add_library(brdf_rgl_test_brdfs STATIC
  ${CMAKE_CURRENT_LIST_DIR}/rgl_test_brdfs.cpp
  ${CMAKE_CURRENT_LIST_DIR}/rgl_test_files.cpp)
target_link_libraries(brdf_rgl_test_brdfs PUBLIC brdf_formats PRIVATE brdf_options)

brdf_add_gtest(test_formats_rgl
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/rgl_tensor_file_test.cpp
          ${CMAKE_CURRENT_LIST_DIR}/rgl_bsdf_test.cpp
          ${CMAKE_CURRENT_LIST_DIR}/rgl_build_test.cpp
  LIBS brdf_formats brdf_rgl_test_brdfs brdf_format_test_util nlohmann_json::nlohmann_json
  LABELS format)

# Writes the RGL files and JSON cases the Mitsuba check reads, and prints our accuracy per case.
add_executable(rgl_mitsuba_cases ${CMAKE_CURRENT_LIST_DIR}/rgl_mitsuba_cases.cpp)
target_link_libraries(rgl_mitsuba_cases PRIVATE brdf_rgl_test_brdfs nlohmann_json::nlohmann_json
  brdf_options)

# Mitsuba 3.9's `measured` plugin loads our files and agrees with the models and with our evaluator
# (tests/reference/formats/mitsuba_measured_check.py). Installs mitsuba with pip beside the test
# when it is missing; skipped (exit 77) when that is impossible (no network).
find_package(Python3 COMPONENTS Interpreter QUIET)
if(Python3_Interpreter_FOUND)
  add_test(NAME rgl_mitsuba_measured
    COMMAND ${Python3_EXECUTABLE}
      ${CMAKE_SOURCE_DIR}/tests/reference/formats/mitsuba_measured_check.py
      --generator $<TARGET_FILE:rgl_mitsuba_cases>
      --work-dir ${CMAKE_CURRENT_BINARY_DIR}/rgl_mitsuba)
  set_tests_properties(rgl_mitsuba_measured PROPERTIES LABELS format TIMEOUT 900
    SKIP_RETURN_CODE 77)
else()
  message(STATUS "python3 not found: the Mitsuba check of RGL files (rgl_mitsuba_measured) is not registered")
endif()

# Regenerates the fuzz_rgl seed corpus: cmake --build BUILD --target rgl_make_fuzz_seeds, then
# BUILD/bin/rgl_make_fuzz_seeds tests/data/fuzz/rgl.
add_executable(rgl_make_fuzz_seeds EXCLUDE_FROM_ALL ${CMAKE_CURRENT_LIST_DIR}/rgl_make_fuzz_seeds.cpp)
target_link_libraries(rgl_make_fuzz_seeds PRIVATE brdf_rgl_test_brdfs brdf_options)
