# SPDX-License-Identifier: MIT
# modrt_embed_shaders(<out_var> NAMESPACE <ns> SHADERS <file>...): a build step that writes a
# C++ source defining `extern const char* const k<Name>` in <ns> for every .glsl file (see
# EmbedShaders.cmake for the names), re-run when a shader changes; <out_var> receives the
# generated source's path, to add to a target. Shaders stay files; nothing is read at run time.
function(modrt_embed_shaders out_var)
  cmake_parse_arguments(E "" "NAMESPACE" "SHADERS" ${ARGN})
  string(REPLACE "::" "_" _stem "${E_NAMESPACE}")
  set(_source ${CMAKE_CURRENT_BINARY_DIR}/generated/${_stem}_shaders.cpp)
  add_custom_command(
    OUTPUT ${_source}
    COMMAND ${CMAKE_COMMAND} "-DOUTPUT=${_source}" "-DSHADERS=${E_SHADERS}" -DNAMESPACE=${E_NAMESPACE}
            -P ${PROJECT_SOURCE_DIR}/cmake/EmbedShaders.cmake
    DEPENDS ${E_SHADERS} ${PROJECT_SOURCE_DIR}/cmake/EmbedShaders.cmake
    COMMENT "Embedding ${E_NAMESPACE} shaders"
    VERBATIM)
  set(${out_var} ${_source} PARENT_SCOPE)
endfunction()
