# SPDX-License-Identifier: MIT
# Installation and the CMake package: find_package(modrt) + target_link_libraries(app modrt::core).
# Included at the end of the root CMakeLists.txt, so every target already exists here.
#
# Three install components (cmake --install <build> --component <name>; all three by default):
#   runtime     the GLM-only libraries (modrt::core, cpu, platform, gles), the C API library
#               (modrt::runtime, modrt::runtime_static), their headers, pkg-config and the
#               package files: an app's whole dependency, nothing of Embree, Eigen or TBB;
#   precompute  modrt::precompute and its headers (modrtPrecomputeTargets.cmake), which need
#               Embree 3, Eigen 3 and oneTBB: find_package(modrt COMPONENTS precompute);
#   programs    modrt-bake, modrt-relight, modrt-level, modrt-demo, modrt-embed-host.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(MODRT_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/modrt"
    CACHE STRING "Where the modrt CMake package files are installed (relative to the prefix)")
mark_as_advanced(MODRT_INSTALL_CMAKEDIR)

# Libraries (exported as modrt::core, modrt::cpu, modrt::platform, modrt::gles, modrt::precompute) and their public headers.
set(_modrt_export_targets modrt_core)
if(TARGET modrt_cpu)
  list(APPEND _modrt_export_targets modrt_cpu)
  install(DIRECTORY "${PROJECT_SOURCE_DIR}/cpu_neon/include/modrt" DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}"
          COMPONENT runtime)
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
          DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}" COMPONENT runtime)
endif()
set(MODRT_PACKAGE_HAS_RUNTIME OFF)
if(TARGET modrt_runtime_shared)
  list(APPEND _modrt_export_targets modrt_runtime modrt_runtime_shared)
  set(MODRT_PACKAGE_HAS_RUNTIME ON)
  get_target_property(_modrt_runtime_links modrt_runtime INTERFACE_LINK_LIBRARIES)
  if("OpenGL::EGL" IN_LIST _modrt_runtime_links)
    set(MODRT_PACKAGE_HAS_EGL ON)
  endif()
  install(DIRECTORY "${PROJECT_SOURCE_DIR}/runtime/include/modrt" DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}"
          COMPONENT runtime)
  install(FILES "${PROJECT_BINARY_DIR}/modrt-runtime.pc" DESTINATION "${CMAKE_INSTALL_LIBDIR}/pkgconfig"
          COMPONENT runtime)
endif()
install(TARGETS ${_modrt_export_targets}
  EXPORT modrtTargets
  ARCHIVE DESTINATION "${CMAKE_INSTALL_LIBDIR}" COMPONENT runtime
  LIBRARY DESTINATION "${CMAKE_INSTALL_LIBDIR}" COMPONENT runtime
  RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}" COMPONENT runtime
  INCLUDES DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}")
install(DIRECTORY "${PROJECT_SOURCE_DIR}/core/include/modrt"
        DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}" COMPONENT runtime)
install(EXPORT modrtTargets
  NAMESPACE modrt::
  FILE modrtTargets.cmake
  DESTINATION "${MODRT_INSTALL_CMAKEDIR}"
  COMPONENT runtime)

# The precompute library in its own export set, so that the runtime's package files name no
# precompute dependency (its targets file refers to modrt::core of modrtTargets.cmake).
set(MODRT_PACKAGE_HAS_PRECOMPUTE OFF)
if(TARGET modrt_precompute)
  set(MODRT_PACKAGE_HAS_PRECOMPUTE ON)
  install(TARGETS modrt_precompute
    EXPORT modrtPrecomputeTargets
    ARCHIVE DESTINATION "${CMAKE_INSTALL_LIBDIR}" COMPONENT precompute
    INCLUDES DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}")
  if(IS_DIRECTORY "${PROJECT_SOURCE_DIR}/precompute/include/modrt")
    install(DIRECTORY "${PROJECT_SOURCE_DIR}/precompute/include/modrt"
            DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}" COMPONENT precompute)
  endif()
  install(EXPORT modrtPrecomputeTargets
    NAMESPACE modrt::
    FILE modrtPrecomputeTargets.cmake
    DESTINATION "${MODRT_INSTALL_CMAKEDIR}"
    COMPONENT precompute)
endif()

# Command-line programs, when they were built. modrt-embed-host links the shared runtime,
# found next to it in the prefix.
foreach(_modrt_program IN ITEMS modrt-bake modrt-relight modrt-level modrt-demo modrt-embed-host)
  if(TARGET ${_modrt_program})
    install(TARGETS ${_modrt_program} RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}" COMPONENT programs)
  endif()
endforeach()
# The programs' image I/O module (OpenImageIO, dlopen'ed on first use: demo/image_io), where
# they look for it: <libdir>/modrt.
if(TARGET modrt_image_io AND TARGET modrt-demo)
  install(TARGETS modrt_image_io LIBRARY DESTINATION "${CMAKE_INSTALL_LIBDIR}/modrt" COMPONENT programs)
endif()
if(TARGET modrt-embed-host)
  file(RELATIVE_PATH _modrt_bin_to_lib "/prefix/${CMAKE_INSTALL_BINDIR}" "/prefix/${CMAKE_INSTALL_LIBDIR}")
  set_target_properties(modrt-embed-host PROPERTIES INSTALL_RPATH "$ORIGIN/${_modrt_bin_to_lib}")
endif()

# Package files.

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
  DESTINATION "${MODRT_INSTALL_CMAKEDIR}"
  COMPONENT runtime)

unset(_modrt_export_targets)
unset(_modrt_program)
unset(_modrt_bin_to_lib)
