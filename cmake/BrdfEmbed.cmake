# Embeds files (OpenCL kernels, refractive-index data, CIE tables) into the binary at build time, so
# the tools run without the source tree. brdf_embed_files(target FUNCTION name BASE dir FILES f...)
# generates a source defining `std::span<const brdf::EmbeddedFile> name()` (see core/embedded.h);
# paths are stored relative to BASE. The files are dependencies: editing one re-embeds it.
include_guard(GLOBAL)

set(BRDF_EMBED_SCRIPT ${CMAKE_CURRENT_LIST_DIR}/embed_files.cmake)

function(brdf_embed_files target)
  cmake_parse_arguments(ARG "" "FUNCTION;BASE" "FILES" ${ARGN})
  if(NOT ARG_FUNCTION OR NOT ARG_BASE OR NOT ARG_FILES)
    message(FATAL_ERROR "brdf_embed_files: FUNCTION, BASE and FILES are required")
  endif()
  set(out ${CMAKE_CURRENT_BINARY_DIR}/embedded_${ARG_FUNCTION}.cpp)
  set(list_file ${CMAKE_CURRENT_BINARY_DIR}/embedded_${ARG_FUNCTION}.files)
  set(abs_files)
  foreach(f IN LISTS ARG_FILES)
    get_filename_component(abs ${f} ABSOLUTE BASE_DIR ${ARG_BASE})
    list(APPEND abs_files ${abs})
  endforeach()
  file(WRITE ${list_file} "${abs_files}")
  add_custom_command(
    OUTPUT ${out}
    COMMAND ${CMAKE_COMMAND} -DOUT=${out} -DLIST_FILE=${list_file} -DBASE=${ARG_BASE}
            -DFUNCTION=${ARG_FUNCTION} -P ${BRDF_EMBED_SCRIPT}
    DEPENDS ${abs_files} ${BRDF_EMBED_SCRIPT} ${list_file}
    COMMENT "Embedding ${ARG_FUNCTION} (${target})"
    VERBATIM)
  target_sources(${target} PRIVATE ${out})
endfunction()
