# Installation and the CMake package: find_package(modrt) + target_link_libraries(app modrt::core).
# Included at the end of the root CMakeLists.txt, so every target already exists here.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(MODRT_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/modrt"
    CACHE STRING "Where the modrt CMake package files are installed (relative to the prefix)")
mark_as_advanced(MODRT_INSTALL_CMAKEDIR)

# Libraries (exported as modrt::core, modrt::cpu, modrt::platform, modrt::gles, modrt::precompute) and their public headers.
set(_modrt_export_targets modrt_core)
if(TARGET modrt_cpu)
  list(APPEND _modrt_export_targets modrt_cpu)
  install(DIRECTORY "${PROJECT_SOURCE_DIR}/cpu_neon/include/modrt" DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}")
endif()
set(MODRT_PACKAGE_HAS_GLES OFF)
set(MODRT_PACKAGE_HAS_EGL OFF)
if(TARGET modrt_gles)
  list(APPEND _modrt_export_targets modrt_platform modrt_gles)
  set(MODRT_PACKAGE_HAS_GLES ON)
  get_target_property(_modrt_platform_links modrt_platform INTERFACE_LINK_LIBRARIES)
  if("OpenGL::EGL" IN_LIST _modrt_platform_links)
    set(MODRT_PACKAGE_HAS_EGL ON)
  endif()
  install(DIRECTORY "${PROJECT_SOURCE_DIR}/platform/include/modrt" "${PROJECT_SOURCE_DIR}/gles/include/modrt"
          DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}")
endif()
set(MODRT_PACKAGE_HAS_RUNTIME OFF)
if(TARGET modrt_runtime_shared)
  list(APPEND _modrt_export_targets modrt_runtime modrt_runtime_shared)
  set(MODRT_PACKAGE_HAS_RUNTIME ON)
  get_target_property(_modrt_runtime_links modrt_runtime INTERFACE_LINK_LIBRARIES)
  if("OpenGL::EGL" IN_LIST _modrt_runtime_links)
    set(MODRT_PACKAGE_HAS_EGL ON)
  endif()
  install(DIRECTORY "${PROJECT_SOURCE_DIR}/runtime/include/modrt" DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}")
  install(FILES "${PROJECT_BINARY_DIR}/modrt-runtime.pc" DESTINATION "${CMAKE_INSTALL_LIBDIR}/pkgconfig")
endif()
set(MODRT_PACKAGE_HAS_PRECOMPUTE OFF)
if(TARGET modrt_precompute)
  list(APPEND _modrt_export_targets modrt_precompute)
  set(MODRT_PACKAGE_HAS_PRECOMPUTE ON)
endif()

install(TARGETS ${_modrt_export_targets}
  EXPORT modrtTargets
  ARCHIVE DESTINATION "${CMAKE_INSTALL_LIBDIR}"
  LIBRARY DESTINATION "${CMAKE_INSTALL_LIBDIR}"
  RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}"
  INCLUDES DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}")

install(DIRECTORY "${PROJECT_SOURCE_DIR}/core/include/modrt"
        DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}")
if(MODRT_PACKAGE_HAS_PRECOMPUTE AND IS_DIRECTORY "${PROJECT_SOURCE_DIR}/precompute/include/modrt")
  install(DIRECTORY "${PROJECT_SOURCE_DIR}/precompute/include/modrt"
          DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}")
endif()

# Command-line programs, when they were built.
foreach(_modrt_program IN ITEMS modrt-bake modrt-relight modrt-level)
  if(TARGET ${_modrt_program})
    install(TARGETS ${_modrt_program} RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}")
  endif()
endforeach()

# Package files.
install(EXPORT modrtTargets
  NAMESPACE modrt::
  FILE modrtTargets.cmake
  DESTINATION "${MODRT_INSTALL_CMAKEDIR}")

configure_package_config_file(
  "${CMAKE_CURRENT_LIST_DIR}/modrtConfig.cmake.in"
  "${PROJECT_BINARY_DIR}/modrtConfig.cmake"
  INSTALL_DESTINATION "${MODRT_INSTALL_CMAKEDIR}")
write_basic_package_version_file(
  "${PROJECT_BINARY_DIR}/modrtConfigVersion.cmake"
  VERSION "${PROJECT_VERSION}"
  COMPATIBILITY SameMajorVersion)
install(FILES
  "${PROJECT_BINARY_DIR}/modrtConfig.cmake"
  "${PROJECT_BINARY_DIR}/modrtConfigVersion.cmake"
  DESTINATION "${MODRT_INSTALL_CMAKEDIR}")

unset(_modrt_export_targets)
unset(_modrt_program)
