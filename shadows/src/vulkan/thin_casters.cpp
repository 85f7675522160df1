// Thin casters in the depth pass: casters flagged CasterInstance::thin are drawn through a
// geometry shader that widens each triangle in the map's plane (csm_depth_thin.geom) by
// RendererOptions::thinCasterWidenTexels, or to a full texel where the caster's width
// (CasterInstance::thinWidthM) is at least half a texel (csm::thinCasterWidenTexels), so that a
// cable or an antenna thinner than a texel keeps a continuous shadow. Where the device exposes
// VK_EXT_conservative_rasterization (DeviceInfo::conservativeRasterizationEnabled) and the widening
// is half a texel or more (or there is no geometry stage), overestimating conservative
// rasterisation widens instead, without a geometry stage: it covers about half a texel on its own.
// Everything else is drawn as before, so non-thin casters' depth is bit-identical with the option
// on or off.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <string>

#include "csm/thin_casters.hpp"
#include "csm/vulkan/shadow_renderer.hpp"
#include "shadow_renderer_impl.hpp"
#include "vk_util.hpp"

// The embedded SPIR-V (after <cstdint>: it declares uint32_t arrays).
#include <csm_shaders/csm_depth_thin.geom.spv.h>

namespace csm::vk {

Status ShadowRenderer::Impl::checkThinOptions(const RendererOptions& options) {
  if (!(options.thinCasterWidenTexels >= 0.0f && options.thinCasterWidenTexels <= 4.0f)) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("options.thinCasterWidenTexels = %g is invalid: allowed [0, 4] texels "
                      "(0 = off)",
                      double(options.thinCasterWidenTexels)));
  }
  return {};
}

void ShadowRenderer::Impl::destroyThinPipeline() noexcept {
  vkDestroyPipeline(device_.device, thinPipeline_, nullptr);
  thinPipeline_ = VK_NULL_HANDLE;
  vkDestroyPipeline(device_.device, thinLayeredPipeline_, nullptr);
  thinLayeredPipeline_ = VK_NULL_HANDLE;
  vkDestroyShaderModule(device_.device, thinGeometryModule_, nullptr);
  thinGeometryModule_ = VK_NULL_HANDLE;
  thinResolution_ = 0;
}

ShadowRenderer::Impl::ThinPlan ShadowRenderer::Impl::planThinPipeline(
    std::uint32_t resolution, const RendererOptions& options) const {
  const float widen = options.thinCasterWidenTexels;
  ThinPlan plan;
  // Overestimation widens by about half a texel on its own: under that, the geometry stage (where
  // there is one) widens by what was asked (shadows/docs/thin_casters.md).
  plan.conservative =
      device_.conservativeRasterizationEnabled && !(device_.geometryShaderEnabled && widen < 0.5f);
  plan.wanted = (plan.conservative || device_.geometryShaderEnabled) && widen > 0.0f;
  const bool same = thinPipeline_ != VK_NULL_HANDLE && thinResolution_ == resolution &&
                    thinWidenTexels_ == widen && thinFormat_ == options.depthFormat &&
                    thinConservative_ == plan.conservative;
  plan.keep = plan.wanted && same;
  plan.build = plan.wanted && !same;
  return plan;
}

Status ShadowRenderer::Impl::buildThinPipelines(std::uint32_t resolution,
                                                const RendererOptions& options, bool conservative,
                                                Retired& out) {
  const float widen = options.thinCasterWidenTexels;
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
  // The resolution; the widening comes per draw (ThinPush).
  const float spec[1] = {float(resolution)};
  const VkSpecializationMapEntry entries[1] = {{1, 0, 4}};
  const VkSpecializationInfo specInfo{1, entries, sizeof(spec), spec};
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
  // The rest as the per-layer depth pipeline (buildPipelines).
  DepthPipelineDesc desc;
  desc.stages = stages;
  desc.stageCount = conservative ? 1 : 2;
  desc.vertexLayout = layout_;
  desc.depthClamp = device_.depthClampEnabled;
  desc.layout = pipelineLayout_;
  desc.depthFormat = options.depthFormat;
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
    desc.rasterizationNext = &conservativeState;
  }
  // Per-layer (csm_depth.vert), and layered (csm_depth_layered.vert, its layer forwarded by the
  // geometry stage) where the device has shaderOutputLayer.
  for (int layered = 0; layered < 2; ++layered) {
    if (layered == 1 && layeredModule_ == VK_NULL_HANDLE) break;
    stages[0].module = layered ? layeredModule_ : vertexModule_;
    VkPipeline& pipeline = out.pipelines[layered];
    const VkResult r = createDepthPipeline(device_.device, device_.pipelineCache, desc, &pipeline);
    if (r != VK_SUCCESS) {
      destroyNow(out);
      return Status(ErrorCode::kVulkan,
                    fmt("vkCreateGraphicsPipelines(csm depth, thin casters%s) failed: %d",
                        layered ? ", layered" : "", int(r)),
                    r);
    }
    setName(std::uint64_t(pipeline), VK_OBJECT_TYPE_PIPELINE,
            layered ? "csm depth pipeline (thin, layered)" : "csm depth pipeline (thin)");
  }
  return {};
}

void ShadowRenderer::Impl::installThinPipelines(const ThinPlan& plan, Retired& built,
                                                std::uint32_t resolution,
                                                const RendererOptions& options) noexcept {
  if (plan.keep) return;
  if (thinPipeline_ != VK_NULL_HANDLE) {  // in use by recorded frames: retire them
    Retired old;
    old.afterRecord = records_;
    old.pipelines[0] = thinPipeline_;
    old.pipelines[1] = thinLayeredPipeline_;
    retired_.push_back(old);
    thinPipeline_ = VK_NULL_HANDLE;
    thinLayeredPipeline_ = VK_NULL_HANDLE;
  }
  if (!plan.build) return;
  thinPipeline_ = built.pipelines[0];
  thinLayeredPipeline_ = built.pipelines[1];
  thinResolution_ = resolution;
  thinWidenTexels_ = options.thinCasterWidenTexels;
  thinFormat_ = options.depthFormat;
  thinConservative_ = plan.conservative;
  built = Retired{};
}

float ShadowRenderer::Impl::thinMarginTexels() const noexcept {
  if (thinPipeline_ == VK_NULL_HANDLE) return 0.0f;
  // The geometry stage's rim reaches texel centres within the widening of the triangle, at most
  // thinCasterMaxWidenTexels (a caster's width can raise it to a quarter texel); overestimation
  // covers any texel the widened triangle touches (half a diagonal more).
  return thinConservative_ ? thinWidenTexels_ + 0.5f : thinCasterMaxWidenTexels(thinWidenTexels_);
}

void ShadowRenderer::Impl::drawIndexedCaster(VkCommandBuffer cmd, const CasterInstance& instance,
                                             const MeshDraw& mesh, std::uint32_t copies,
                                             const LayerTexels& layerTexelM) {
  // The cached pass draws per layer (the cache refuses kLayered), so the render mode says which
  // pipeline is bound and which widens.
  const bool layered = resolvedMode_ == RenderMode::kLayered;
  const VkPipeline thin = layered ? thinLayeredPipeline_ : thinPipeline_;
  const bool widen = instance.thin && thin != VK_NULL_HANDLE;
  setCasterCull(cmd, instance);
  if (widen) vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, thin);
  if (widen && !thinConservative_) {
    // Each layer's widening for this caster's width (csm::thinCasterWidenTexels).
    ThinPush push{};
    for (std::uint32_t l = 0; l < CSM_MAX_CASCADES; ++l) {
      push.widenTexels[l] =
          thinCasterWidenTexels(thinWidenTexels_, instance.thinWidthM, layerTexelM[l]);
    }
    vkCmdPushConstants(cmd, pipelineLayout_, VK_SHADER_STAGE_GEOMETRY_BIT, CSM_THIN_PUSH_OFFSET,
                       CSM_THIN_PUSH_SIZE, &push);
  }
  vkCmdDrawIndexed(cmd, mesh.indexCount, copies, mesh.firstIndex, mesh.vertexOffset, 0);
  if (widen) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layered ? layeredPipeline_ : pipeline_);
  }
}

}  // namespace csm::vk
