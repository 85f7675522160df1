# csm::vulkan: the renderer. Links csm::core and Vulkan; the depth-pass SPIR-V is embedded, so
# it needs no files at run time.
find_package(Vulkan REQUIRED)

# The GPU layout of the uniform block is pure (GLM only) and belongs to the core.
target_sources(csm_core PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src/core/gpu_layout.cpp
                                ${CMAKE_CURRENT_SOURCE_DIR}/src/core/names.cpp
                                ${CMAKE_CURRENT_SOURCE_DIR}/src/core/presets.cpp)

csm_compile_shaders(csm_depth_shaders SOURCE_DIR ${CMAKE_CURRENT_SOURCE_DIR}/shaders
                    csm_depth.vert csm_depth_layered.vert csm_depth_thin.geom
                    csm_cache_restore.vert csm_cache_restore.frag)

# The depth-range reduction (receiver-driven splits) is compiled for SPIR-V 1.5 (Vulkan 1.2):
# glslang's SPIR-V 1.6 output of a compute shader uses LocalSizeId, which needs maintenance4.
set(_csm_range_hdr ${CSM_SHADER_OUT}/csm_shaders/csm_depth_range.comp.spv.h)
add_custom_command(OUTPUT ${_csm_range_hdr}
  COMMAND ${GLSLANG_VALIDATOR} --quiet --target-env vulkan1.2 -I${CSM_MODULE_SHADER_DIR}
          -I${CSM_SHARED_INCLUDE_DIR} --vn csm_depth_range_comp_spv -o ${_csm_range_hdr}
          ${CSM_MODULE_SHADER_DIR}/csm_depth_range.comp
  DEPENDS ${CSM_MODULE_SHADER_DIR}/csm_depth_range.comp
          ${CSM_SHARED_INCLUDE_DIR}/csm/shared_constants.h
  COMMENT "glslang csm_depth_range.comp" VERBATIM)
# The prefiltered filters' resolve (depth -> moments, separable blur), the same target env, once
# per moment format: RGBA32F; RG32F (vsm's two moments, where the device stores that format);
# RGBA16_UNORM (msm's moments quantised, RendererOptions::msmMomentBits = 64).
set(_csm_moments_hdrs)
foreach(_variant IN ITEMS "moments;" "moments_rg;-DCSM_MOMENTS_RG" "moments_q16;-DCSM_MOMENTS_Q16")
  list(GET _variant 0 _name)
  list(GET _variant 1 _define)
  set(_hdr ${CSM_SHADER_OUT}/csm_shaders/csm_${_name}.comp.spv.h)
  add_custom_command(OUTPUT ${_hdr}
    COMMAND ${GLSLANG_VALIDATOR} --quiet --target-env vulkan1.2 ${_define}
            -I${CSM_MODULE_SHADER_DIR} -I${CSM_SHARED_INCLUDE_DIR} --vn csm_${_name}_comp_spv
            -o ${_hdr} ${CSM_MODULE_SHADER_DIR}/csm_moments.comp
    DEPENDS ${CSM_MODULE_SHADER_DIR}/csm_moments.comp ${CSM_MODULE_SHADER_DIR}/csm.glsl
            ${CSM_SHARED_INCLUDE_DIR}/csm/shared_constants.h
            ${CSM_SHARED_INCLUDE_DIR}/csm/gpu_shared.h
    COMMENT "glslang csm_moments.comp (${_name})" VERBATIM)
  list(APPEND _csm_moments_hdrs ${_hdr})
endforeach()
add_custom_target(csm_depth_range_shader DEPENDS ${_csm_range_hdr} ${_csm_moments_hdrs})

add_library(csm_vulkan STATIC
  ${CMAKE_CURRENT_SOURCE_DIR}/src/vulkan/shadow_renderer.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/vulkan/shadow_renderer_pass.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/vulkan/shadow_renderer_update.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/vulkan/shadow_view.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/vulkan/depth_range.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/vulkan/shadow_cache.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/vulkan/thin_casters.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/vulkan/vk_util.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/vulkan/moments.cpp)
add_library(csm::vulkan ALIAS csm_vulkan)
target_link_libraries(csm_vulkan PUBLIC csm::core Vulkan::Vulkan)
# The embedded shaders are a build-time dependency only (no link or install interface).
add_dependencies(csm_vulkan csm_depth_shaders csm_depth_range_shader)
target_include_directories(csm_vulkan PRIVATE ${CSM_SHADER_OUT})
set_target_properties(csm_vulkan PROPERTIES POSITION_INDEPENDENT_CODE ON)
csm_target_warnings(csm_vulkan)
