// Thin casters in the depth pass: casters flagged CasterInstance::thin are drawn through a
// geometry shader that widens each triangle by RendererOptions::thinCasterWidenTexels in the
// map's plane (csm_depth_thin.geom), so that a cable or an antenna thinner than a texel keeps a
// continuous shadow. This is the software route where VK_EXT_conservative_rasterization is not
// exposed (lavapipe); where it is (DeviceInfo::conservativeRasterizationEnabled), overestimating
// conservative rasterisation widens by about half a texel instead, without a geometry stage.
// Everything else is drawn as before, so non-thin casters' depth is bit-identical with the option
// on or off.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <string>

#include "csm/vulkan/shadow_renderer.hpp"

// The embedded SPIR-V (after <cstdint>: it declares uint32_t arrays).
#include <csm_shaders/csm_depth_thin.geom.spv.h>

namespace csm::vk {

namespace {

template <class T>
T vkInit(VkStructureType type) {
  T v{};
  v.sType = type;
  return v;
}

std::string fmt(const char* format, auto... args) {
  char buf[512];
  std::snprintf(buf, sizeof(buf), format, args...);
  return buf;
}

}  // namespace

Status ShadowRenderer::checkThinOptions(const RendererOptions& options) {
  if (!(options.thinCasterWidenTexels >= 0.0f && options.thinCasterWidenTexels <= 4.0f)) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("options.thinCasterWidenTexels = %g is invalid: allowed [0, 4] texels "
                      "(0 = off)",
                      double(options.thinCasterWidenTexels)));
  }
  return {};
}

void ShadowRenderer::destroyThinPipeline() noexcept {
  vkDestroyPipeline(device_.device, thinPipeline_, nullptr);
  thinPipeline_ = VK_NULL_HANDLE;
  vkDestroyPipeline(device_.device, thinLayeredPipeline_, nullptr);
  thinLayeredPipeline_ = VK_NULL_HANDLE;
  vkDestroyShaderModule(device_.device, thinGeometryModule_, nullptr);
  thinGeometryModule_ = VK_NULL_HANDLE;
  thinResolution_ = 0;
}

Status ShadowRenderer::updateThinPipeline(std::uint32_t resolution,
                                          const RendererOptions& options) {
  const float widen = options.thinCasterWidenTexels;
  const bool conservative = device_.conservativeRasterizationEnabled;
  const bool wanted = (conservative || device_.geometryShaderEnabled) && widen > 0.0f;
  const bool same = thinPipeline_ != VK_NULL_HANDLE && thinResolution_ == resolution &&
                    thinWidenTexels_ == widen && thinFormat_ == options.depthFormat;
  if (wanted && same) return {};
  if (thinPipeline_ != VK_NULL_HANDLE) {  // in use by recorded frames: retire them
    Retired old;
    old.afterRecord = records_;
    old.pipelines[0] = thinPipeline_;
    old.pipelines[1] = thinLayeredPipeline_;
    retired_.push_back(old);
    thinPipeline_ = VK_NULL_HANDLE;
    thinLayeredPipeline_ = VK_NULL_HANDLE;
  }
  if (!wanted) return {};
  if (!conservative && thinGeometryModule_ == VK_NULL_HANDLE) {
    auto ci = vkInit<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
    ci.codeSize = sizeof(csm_depth_thin_geom_spv);
    ci.pCode = csm_depth_thin_geom_spv;
    const VkResult r = vkCreateShaderModule(device_.device, &ci, nullptr, &thinGeometryModule_);
    if (r != VK_SUCCESS) {
      return Status(ErrorCode::kVulkan,
                    fmt("vkCreateShaderModule(csm_depth_thin.geom) failed: %d", int(r)), r);
    }
    setName(std::uint64_t(thinGeometryModule_), VK_OBJECT_TYPE_SHADER_MODULE,
            "csm_depth_thin.geom");
  }
  const float spec[2] = {widen, float(resolution)};
  const VkSpecializationMapEntry entries[2] = {{0, 0, 4}, {1, 4, 4}};
  const VkSpecializationInfo specInfo{2, entries, sizeof(spec), spec};
  VkPipelineShaderStageCreateInfo stages[2];
  stages[0] =
      vkInit<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = vertexModule_;
  stages[0].pName = "main";
  stages[1] = stages[0];
  stages[1].stage = VK_SHADER_STAGE_GEOMETRY_BIT;
  stages[1].module = thinGeometryModule_;
  stages[1].pSpecializationInfo = &specInfo;
  // The rest as the per-layer depth pipeline (createPipelines).
  VkVertexInputBindingDescription binding{0, layout_.stride, VK_VERTEX_INPUT_RATE_VERTEX};
  VkVertexInputAttributeDescription attr{0, 0, layout_.positionFormat, layout_.positionOffset};
  auto vin = vkInit<VkPipelineVertexInputStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO);
  vin.vertexBindingDescriptionCount = 1;
  vin.pVertexBindingDescriptions = &binding;
  vin.vertexAttributeDescriptionCount = 1;
  vin.pVertexAttributeDescriptions = &attr;
  auto ia = vkInit<VkPipelineInputAssemblyStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO);
  ia.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  auto vp = vkInit<VkPipelineViewportStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO);
  vp.viewportCount = 1;
  vp.scissorCount = 1;
  auto rs = vkInit<VkPipelineRasterizationStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO);
  rs.depthClampEnable = device_.depthClampEnabled ? VK_TRUE : VK_FALSE;
  rs.polygonMode = VK_POLYGON_MODE_FILL;
  rs.depthBiasEnable = VK_TRUE;
  rs.lineWidth = 1.0f;
  // Where the device has it: overestimating conservative rasterisation covers every texel a
  // triangle touches, which against centre sampling widens it by half a texel (up to half the
  // texel's diagonal), plus the extra overestimation asked for beyond that. This path is only
  // exercised on devices that expose the extension (lavapipe does not; not tested here).
  auto conservativeState = vkInit<VkPipelineRasterizationConservativeStateCreateInfoEXT>(
      VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_CONSERVATIVE_STATE_CREATE_INFO_EXT);
  if (conservative) {
    auto props = vkInit<VkPhysicalDeviceConservativeRasterizationPropertiesEXT>(
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_CONSERVATIVE_RASTERIZATION_PROPERTIES_EXT);
    auto props2 =
        vkInit<VkPhysicalDeviceProperties2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2);
    props2.pNext = &props;
    vkGetPhysicalDeviceProperties2(device_.physicalDevice, &props2);
    conservativeState.conservativeRasterizationMode =
        VK_CONSERVATIVE_RASTERIZATION_MODE_OVERESTIMATE_EXT;
    conservativeState.extraPrimitiveOverestimationSize =
        std::clamp(widen - 0.5f, 0.0f, props.maxExtraPrimitiveOverestimationSize);
    rs.pNext = &conservativeState;
  }
  auto ms = vkInit<VkPipelineMultisampleStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO);
  ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  auto ds = vkInit<VkPipelineDepthStencilStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO);
  ds.depthTestEnable = VK_TRUE;
  ds.depthWriteEnable = VK_TRUE;
  ds.depthCompareOp = VK_COMPARE_OP_LESS_OR_EQUAL;
  auto cb = vkInit<VkPipelineColorBlendStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO);
  const VkDynamicState dyn[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR,
                                VK_DYNAMIC_STATE_DEPTH_BIAS, VK_DYNAMIC_STATE_CULL_MODE,
                                VK_DYNAMIC_STATE_FRONT_FACE};
  auto dy = vkInit<VkPipelineDynamicStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO);
  dy.dynamicStateCount = static_cast<std::uint32_t>(std::size(dyn));
  dy.pDynamicStates = dyn;
  auto rendering =
      vkInit<VkPipelineRenderingCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO);
  rendering.depthAttachmentFormat = options.depthFormat;
  auto ci = vkInit<VkGraphicsPipelineCreateInfo>(VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO);
  ci.pNext = &rendering;
  ci.stageCount = conservative ? 1 : 2;
  ci.pStages = stages;
  ci.pVertexInputState = &vin;
  ci.pInputAssemblyState = &ia;
  ci.pViewportState = &vp;
  ci.pRasterizationState = &rs;
  ci.pMultisampleState = &ms;
  ci.pDepthStencilState = &ds;
  ci.pColorBlendState = &cb;
  ci.pDynamicState = &dy;
  ci.layout = pipelineLayout_;
  // Per-layer (csm_depth.vert), and layered (csm_depth_layered.vert, its layer forwarded by the
  // geometry stage) where the device has shaderOutputLayer.
  for (int layered = 0; layered < 2; ++layered) {
    if (layered == 1 && layeredModule_ == VK_NULL_HANDLE) break;
    stages[0].module = layered ? layeredModule_ : vertexModule_;
    VkPipeline& out = layered ? thinLayeredPipeline_ : thinPipeline_;
    const VkResult r =
        vkCreateGraphicsPipelines(device_.device, device_.pipelineCache, 1, &ci, nullptr, &out);
    if (r != VK_SUCCESS) {
      out = VK_NULL_HANDLE;
      if (layered) {
        vkDestroyPipeline(device_.device, thinPipeline_, nullptr);
        thinPipeline_ = VK_NULL_HANDLE;
      }
      return Status(ErrorCode::kVulkan,
                    fmt("vkCreateGraphicsPipelines(csm depth, thin casters%s) failed: %d",
                        layered ? ", layered" : "", int(r)),
                    r);
    }
    setName(std::uint64_t(out), VK_OBJECT_TYPE_PIPELINE,
            layered ? "csm depth pipeline (thin, layered)" : "csm depth pipeline (thin)");
  }
  thinResolution_ = resolution;
  thinWidenTexels_ = widen;
  thinFormat_ = options.depthFormat;
  return {};
}

void ShadowRenderer::drawIndexedCaster(VkCommandBuffer cmd, const CasterInstance& instance,
                                       const MeshDraw& mesh, std::uint32_t copies) const {
  // The cached pass draws per layer (the cache refuses kLayered), so the render mode says which
  // pipeline is bound and which widens.
  const bool layered = resolvedMode_ == RenderMode::kLayered;
  const VkPipeline thin = layered ? thinLayeredPipeline_ : thinPipeline_;
  const bool widen = instance.thin && thin != VK_NULL_HANDLE;
  if (widen) vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, thin);
  vkCmdDrawIndexed(cmd, mesh.indexCount, copies, mesh.firstIndex, mesh.vertexOffset, 0);
  if (widen) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layered ? layeredPipeline_ : pipeline_);
  }
}

}  // namespace csm::vk
