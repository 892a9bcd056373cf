# Renderers read what `brdftool compute` writes (issue 17): the seed material
# (examples/seed-tio2-white.json) computed once as NAME.fourier.bsdf and NAME.rgl.bsdf with the
# model's BRDF at 600 random directions (fixture renderer_formats), then
#  - fourier_reader_model: the independent Python reader (pbrt-v3's interpolation) against the model,
#    median <= 0.2 %, worst <= 2 % below 85 degrees;
#  - rgl_mitsuba_model: Mitsuba 3's `measured` (scalar_rgb) on the RGB companion NAME.rgb.rgl.bsdf
#    against the model, median <= 1 %, 95th percentile <= 5 %, and its sampling of our file against
#    the model's albedo;
#  - rgl_mitsuba_spectral: the same in scalar_spectral on the spectral NAME.rgl.bsdf against
#    `brdftool eval --spectral` at 300 directions, every solved wavelength (the setup checks that
#    `brdftool info` lists the wavelengths eval solves);
#  - rgl_mitsuba_sphere: a Mitsuba 3 rendering of a sphere against `brdftool render` of the spec.
# The Mitsuba tests install mitsuba with pip beside the test when missing (exit 77, skipped, when
# that is impossible). Labels format and slow: the model's evaluation takes a minute or two.
find_package(Python3 COMPONENTS Interpreter QUIET)
if(Python3_Interpreter_FOUND)
  set(_rf_dir ${CMAKE_CURRENT_BINARY_DIR}/renderer_formats)
  set(_rf_script ${CMAKE_SOURCE_DIR}/tests/formats/renderer_formats.py)
  set(_rf_spec ${CMAKE_SOURCE_DIR}/examples/seed-tio2-white.json)
  add_test(NAME renderer_formats_setup
    COMMAND ${Python3_EXECUTABLE} ${_rf_script} setup --brdftool $<TARGET_FILE:brdftool>
      --spec ${_rf_spec} --work-dir ${_rf_dir})
  add_test(NAME fourier_reader_model
    COMMAND ${Python3_EXECUTABLE} ${CMAKE_SOURCE_DIR}/tests/formats/fourier_reader.py
      ${_rf_dir}/out/seed-tio2-white.fourier.bsdf --model ${_rf_dir}/model.csv
      --max-theta-deg 85 --median 0.002 --worst 0.02)
  add_test(NAME rgl_mitsuba_model
    COMMAND ${Python3_EXECUTABLE} ${CMAKE_SOURCE_DIR}/tests/reference/formats/mitsuba_measured_check.py
      ${_rf_dir}/rgl_case.json --work-dir ${_rf_dir} --median 0.01 --p95 0.05)
  add_test(NAME rgl_mitsuba_spectral
    COMMAND ${Python3_EXECUTABLE} ${CMAKE_SOURCE_DIR}/tests/reference/formats/mitsuba_measured_check.py
      ${_rf_dir}/rgl_spectral_case.json --work-dir ${_rf_dir} --median 0.01 --p95 0.05)
  add_test(NAME rgl_mitsuba_sphere
    COMMAND ${Python3_EXECUTABLE} ${_rf_script} render --brdftool $<TARGET_FILE:brdftool>
      --spec ${_rf_spec} --work-dir ${_rf_dir})
  set_tests_properties(renderer_formats_setup PROPERTIES FIXTURES_SETUP renderer_formats
    LABELS "format;slow" TIMEOUT 900)
  set_tests_properties(fourier_reader_model rgl_mitsuba_model rgl_mitsuba_spectral rgl_mitsuba_sphere PROPERTIES
    FIXTURES_REQUIRED renderer_formats LABELS "format;slow" TIMEOUT 900 SKIP_RETURN_CODE 77)
  # The Mitsuba tests share the pip target folder in the work dir.
  set_tests_properties(rgl_mitsuba_model rgl_mitsuba_spectral rgl_mitsuba_sphere PROPERTIES RESOURCE_LOCK renderer_formats_pip)
else()
  message(STATUS "python3 not found: the renderer format tests (renderer_formats_*) are not registered")
endif()
