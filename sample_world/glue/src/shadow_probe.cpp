// The one GPU probe of csm.glsl (see glue/shadow_probe.hpp).
#include "glue/shadow_probe.hpp"

#include <csm_shaders/shadow_probe.comp.spv.h>

#include <algorithm>
#include <cmath>
#include <csm/gpu_layout.hpp>
#include <string>

#include "engine/context.hpp"
#include "engine/debug.hpp"
#include "engine/errors.hpp"
#include "glue/vk_util.hpp"

namespace glue {

namespace {

using detail::vkStruct;

// std430 element of shadow_probe.comp's Points buffer.
struct ProbePointGpu {
  glm::vec4 posCr;
  glm::vec4 normalWs;
};

}  // namespace

ShadowProbe::ShadowProbe(engine::Context& ctx, VkDescriptorSetLayout lightingSetLayout)
    : ctx_(&ctx) {
  VkDevice dev = ctx.device();
  const VkDescriptorSetLayoutBinding b[2] = {
      {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}};
  layout_ = engine::createDescriptorSetLayout(dev, b, "probe.layout");

  pool_ = detail::makeDescriptorPool(dev, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2, "probe.pool");
  set_ = detail::allocateDescriptorSet(dev, pool_, layout_.get(), "probe.set");

  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, 16};
  const VkDescriptorSetLayout sets[2] = {layout_.get(), lightingSetLayout};
  auto li = vkStruct<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  li.setLayoutCount = 2;
  li.pSetLayouts = sets;
  li.pushConstantRangeCount = 1;
  li.pPushConstantRanges = &range;
  VkPipelineLayout pl = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreatePipelineLayout(dev, &li, nullptr, &pl));
  engine::setDebugName(dev, pl, "probe.pipelineLayout");
  pipelineLayout_ = engine::DeviceHandle<VkPipelineLayout>(dev, pl, vkDestroyPipelineLayout);
}

ShadowProbe::~ShadowProbe() = default;

VkPipeline ShadowProbe::pipeline(csm::PcfKernel kernel, bool blend) {
  engine::DeviceHandle<VkPipeline>& p = pipelines_[{uint32_t(kernel), blend}];
  if (p) return p.get();
  VkDevice dev = ctx_->device();
  const auto module = engine::createShaderModule(dev, shadow_probe_comp_spv, "shadow_probe.comp");
  const uint32_t values[2] = {uint32_t(kernel), blend ? 1u : 0u};
  const VkSpecializationMapEntry entries[2] = {{CSM_SPEC_KERNEL, 0, 4}, {CSM_SPEC_BLEND, 4, 4}};
  VkSpecializationInfo spec{2, entries, sizeof(values), values};
  auto ci = vkStruct<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
  ci.stage = vkStruct<VkPipelineShaderStageCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
  ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  ci.stage.module = module;
  ci.stage.pName = "main";
  ci.stage.pSpecializationInfo = &spec;
  ci.layout = pipelineLayout_;
  VkPipeline pipeline = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreateComputePipelines(dev, VK_NULL_HANDLE, 1, &ci, nullptr, &pipeline));
  engine::setDebugName(
      dev, pipeline,
      std::string("probe.") + csm::kernelName(kernel) + (blend ? ".blend" : ".switch"));
  p = engine::DeviceHandle<VkPipeline>(dev, pipeline, vkDestroyPipeline);
  return p.get();
}

void ShadowProbe::setPoints(std::span<const ProbePoint> points) {
  const uint32_t count = uint32_t(points.size());
  if (count > capacity_) {
    ctx_->waitIdle();
    const uint32_t capacity = std::max(count, 1024u);
    points_ = engine::Buffer(*ctx_, VkDeviceSize(capacity) * sizeof(ProbePointGpu),
                             VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, engine::MemoryUsage::Upload,
                             "probe.points");
    results_ = engine::Buffer(*ctx_, VkDeviceSize(capacity) * 2 * sizeof(glm::vec4),
                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, engine::MemoryUsage::Readback,
                              "probe.results");
    detail::writeBufferDescriptor(ctx_->device(), set_, 0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                  points_.handle());
    detail::writeBufferDescriptor(ctx_->device(), set_, 1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                  results_.handle());
    capacity_ = capacity;
  }
  auto* gpu = static_cast<ProbePointGpu*>(points_.mapped());
  for (uint32_t i = 0; i < count; ++i) {
    // w: the screen pixel (x in posCr.w, y in normalWs.w).
    gpu[i].posCr = glm::vec4(points[i].posCr, points[i].pixel.x);
    gpu[i].normalWs = glm::vec4(points[i].normalWs, points[i].pixel.y);
  }
  count_ = count;
}

void ShadowProbe::record(VkCommandBuffer cmd, VkDescriptorSet lightingSet, csm::PcfKernel kernel,
                         bool blend) {
  const VkPipeline p = pipeline(kernel, blend);
  engine::ScopedLabel label(cmd, "shadow probe");
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p);
  const VkDescriptorSet sets[2] = {set_, lightingSet};
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelineLayout_, 0, 2, sets, 0,
                          nullptr);
  const uint32_t push[4] = {count_, 0, 0, 0};
  vkCmdPushConstants(cmd, pipelineLayout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), push);
  vkCmdDispatch(cmd, (count_ + 63) / 64, 1, 1);
  engine::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_WRITE_BIT,
                        VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

std::vector<ProbeResult> ShadowProbe::results() const {
  std::vector<ProbeResult> out(count_);
  if (count_ == 0) return out;
  const auto* r = static_cast<const glm::vec4*>(results_.mapped());
  for (uint32_t i = 0; i < count_; ++i) {
    const glm::vec4& a = r[2 * i];
    out[i].shadow = a.x;
    out[i].cascade = int(std::lround(a.y));
    out[i].blendCascade = int(std::lround(a.z));
    out[i].blendWeight = a.w;
    out[i].depthGapM = r[2 * i + 1].x;
    out[i].viewDepthM = r[2 * i + 1].y;
  }
  return out;
}

}  // namespace glue
