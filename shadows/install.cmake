# Packaging: `cmake --install` puts the module where another engine finds it with
#   find_package(csm CONFIG REQUIRED)
#   target_link_libraries(app PRIVATE csm::shadows)
# and its lighting shaders #include "csm.glsl" with -I for each of ${CSM_SHADER_INCLUDE_DIRS}.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

# csm::shadows: the whole module (math + renderer), the one target a host links.
add_library(csm_shadows INTERFACE)
add_library(csm::shadows ALIAS csm_shadows)
target_link_libraries(csm_shadows INTERFACE csm_core csm_vulkan)
# The directories a host's GLSL compiler needs (-I each) to #include "csm.glsl" are in
# ${CSM_SHADER_INCLUDE_DIRS} (cmake/csm_build.cmake): in the source tree the shaders and the
# shared constants live apart; installed, they sit in one directory.

set_target_properties(csm_core PROPERTIES EXPORT_NAME core)
set_target_properties(csm_vulkan PROPERTIES EXPORT_NAME vulkan)
set_target_properties(csm_shadows PROPERTIES EXPORT_NAME shadows)

install(TARGETS csm_core csm_vulkan csm_shadows EXPORT csmTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/csm
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/include/csm/version.hpp
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/csm)
install(FILES ${CMAKE_CURRENT_SOURCE_DIR}/README.md ${CMAKE_CURRENT_SOURCE_DIR}/CHANGELOG.md
        DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/csm)

# GLSL: csm.glsl and the depth pass as sources, with the shared constants beside them so that
# `-I ${CSM_SHADER_INCLUDE_DIR}` resolves every include; the depth pass also as SPIR-V.
set(csm_shader_dest ${CMAKE_INSTALL_DATADIR}/csm/shaders)
install(FILES ${CMAKE_CURRENT_SOURCE_DIR}/shaders/csm.glsl
              ${CMAKE_CURRENT_SOURCE_DIR}/shaders/csm_depth.vert
              ${CMAKE_CURRENT_SOURCE_DIR}/shaders/csm_depth_layered.vert
              ${CMAKE_CURRENT_SOURCE_DIR}/shaders/csm_depth_thin.geom
        DESTINATION ${csm_shader_dest})
install(FILES ${CMAKE_CURRENT_SOURCE_DIR}/include/csm/shared_constants.h
              ${CMAKE_CURRENT_SOURCE_DIR}/include/csm/gpu_shared.h
        DESTINATION ${csm_shader_dest}/csm)
install(FILES ${CSM_SHADER_OUT}/csm_shaders/csm_depth.vert.spv
              ${CSM_SHADER_OUT}/csm_shaders/csm_depth_layered.vert.spv
              ${CSM_SHADER_OUT}/csm_shaders/csm_depth_thin.geom.spv
        DESTINATION ${csm_shader_dest}/spirv)

set(csm_cmake_dest ${CMAKE_INSTALL_LIBDIR}/cmake/csm)
install(EXPORT csmTargets NAMESPACE csm:: DESTINATION ${csm_cmake_dest})
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/csmConfig.cmake.in [=[
@PACKAGE_INIT@
include(CMakeFindDependencyMacro)
find_dependency(glm)
find_dependency(Vulkan)
include("${CMAKE_CURRENT_LIST_DIR}/csmTargets.cmake")
set_and_check(CSM_SHADER_INCLUDE_DIR "@PACKAGE_csm_shader_dest@")
set(CSM_SHADER_INCLUDE_DIRS "${CSM_SHADER_INCLUDE_DIR}")
set(CSM_SPIRV_DIR "${CSM_SHADER_INCLUDE_DIR}/spirv")
check_required_components(csm)
]=])
configure_package_config_file(${CMAKE_CURRENT_BINARY_DIR}/csmConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/csmConfig.cmake
  INSTALL_DESTINATION ${csm_cmake_dest}
  PATH_VARS csm_shader_dest)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/csmConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/csmConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/csmConfigVersion.cmake
        DESTINATION ${csm_cmake_dest})
