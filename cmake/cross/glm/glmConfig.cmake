# SPDX-License-Identifier: MIT
# GLM for cross builds. GLM is header-only and architecture-independent, but Debian's package
# config puts /usr/include on the include path, which must not reach a cross compiler (the
# host's C headers would shadow the target's). This exposes the glm headers alone, through a
# directory holding only a link to them.
set(_modrt_glm_include "${CMAKE_BINARY_DIR}/cross-include")
if(NOT EXISTS "${_modrt_glm_include}/glm")
  file(MAKE_DIRECTORY "${_modrt_glm_include}")
  file(CREATE_LINK /usr/include/glm "${_modrt_glm_include}/glm" SYMBOLIC)
endif()
if(NOT TARGET glm::glm)
  add_library(glm::glm INTERFACE IMPORTED)
  set_target_properties(glm::glm PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_modrt_glm_include}")
endif()
set(glm_FOUND TRUE)
