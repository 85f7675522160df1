// The lit pass that samples the shadows (see glue/lit_pass.hpp).
#include "glue/lit_pass.hpp"

#include <csm_shaders/lit.frag.spv.h>
#include <csm_shaders/lit.vert.spv.h>

#include <csm/gpu_layout.hpp>
#include <stdexcept>

#include "engine/context.hpp"
#include "engine/debug.hpp"
#include "engine/errors.hpp"
#include "engine/gpu_timer.hpp"
#include "engine/render_target.hpp"
#include "glue/vk_util.hpp"

namespace glue {

using namespace engine;

namespace {

using detail::vkStruct;

// std140 block LitFrame of lit.vert / lit.frag.
struct LitFrameGpu {
  glm::mat4 viewProjCr;
  glm::vec4 lightDirection;
  glm::vec4 lightColor;
  glm::vec4 ambientColor;
  glm::vec4 params;
};
static_assert(sizeof(LitFrameGpu) == 128);

// Push constants LitPush of lit.vert / lit.frag (128 bytes).
struct LitPush {
  glm::mat4 modelCr;
  glm::vec4 normalToWs[3];
  glm::vec4 color;
};
static_assert(sizeof(LitPush) == 128);

}  // namespace

LitPass::LitPass(Context& ctx, const LitPassDesc& desc) : ctx_(&ctx) {
  if (desc.shadowSetLayout == VK_NULL_HANDLE) {
    throw std::invalid_argument("LitPassDesc::shadowSetLayout is required");
  }
  VkDevice dev = ctx.device();
  const VkDescriptorSetLayoutBinding binding{
      0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1,
      VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
  frameLayout_ = createDescriptorSetLayout(dev, std::span(&binding, 1), "lit.frameLayout");

  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1};
  auto poolInfo =
      vkStruct<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  poolInfo.maxSets = 1;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreateDescriptorPool(dev, &poolInfo, nullptr, &pool));
  pool_ = DeviceHandle<VkDescriptorPool>(dev, pool, vkDestroyDescriptorPool);
  setDebugName(dev, pool, "lit.pool");
  VkDescriptorSetLayout layout = frameLayout_.get();
  auto alloc =
      vkStruct<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  alloc.descriptorPool = pool;
  alloc.descriptorSetCount = 1;
  alloc.pSetLayouts = &layout;
  ENGINE_VK_CHECK(vkAllocateDescriptorSets(dev, &alloc, &frameSet_));
  setDebugName(dev, frameSet_, "lit.frameSet");

  frameBuffer_ = Buffer(ctx, sizeof(LitFrameGpu),
                        VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                        MemoryUsage::DeviceLocal, "lit.frameUniforms");
  VkDescriptorBufferInfo bufferInfo{frameBuffer_.handle(), 0, sizeof(LitFrameGpu)};
  auto write = vkStruct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
  write.dstSet = frameSet_;
  write.dstBinding = 0;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  write.pBufferInfo = &bufferInfo;
  vkUpdateDescriptorSets(dev, 1, &write, 0, nullptr);

  const auto vert = createShaderModule(dev, lit_vert_spv, "lit.vert");
  const auto frag = createShaderModule(dev, lit_frag_spv, "lit.frag");
  const VkVertexInputBindingDescription vertexBinding = MeshStore::bindingDescription();
  GraphicsPipelineBuilder builder;
  builder.vertexShader(vert)
      .fragmentShader(frag)
      .vertexInput(std::span(&vertexBinding, 1), MeshStore::attributeDescriptions())
      .colorFormat(desc.colorFormat)
      .depthFormat(desc.depthFormat)
      .depthTest(true, true, VK_COMPARE_OP_LESS)
      .pushConstants(VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, sizeof(LitPush))
      .descriptorSetLayout(frameLayout_.get())
      .descriptorSetLayout(desc.shadowSetLayout);
  for (const auto& [id, value] : desc.specialization) {
    builder.specialization(VK_SHADER_STAGE_FRAGMENT_BIT, id, value);
  }
  pipeline_ = builder.build(ctx, "lit");
}

LitPass::~LitPass() = default;

void LitPass::prepare(VkCommandBuffer cmd, const LitFrame& frame) {
  cameraPositionWs_ = frame.cameraPositionWs;
  LitFrameGpu gpu{};
  gpu.viewProjCr = frame.viewProjCr;
  gpu.lightDirection = glm::vec4(frame.lightDirectionWs, 0.0f);
  gpu.lightColor = glm::vec4(frame.lightColor, 1.0f);
  gpu.ambientColor = glm::vec4(frame.ambientColor, 1.0f);
  gpu.params = glm::vec4(frame.specularStrength, frame.shininess, 0.0f, 0.0f);
  const VkPipelineStageFlags2 readers =
      VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  // Earlier frames' reads finish before the overwrite; the write is visible to this frame's.
  auto barrier = vkStruct<VkBufferMemoryBarrier2>(VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2);
  barrier.srcStageMask = readers;
  barrier.srcAccessMask = VK_ACCESS_2_NONE;
  barrier.dstStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  barrier.dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  barrier.buffer = frameBuffer_.handle();
  barrier.size = VK_WHOLE_SIZE;
  auto dep = vkStruct<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.bufferMemoryBarrierCount = 1;
  dep.pBufferMemoryBarriers = &barrier;
  vkCmdPipelineBarrier2(cmd, &dep);
  vkCmdUpdateBuffer(cmd, frameBuffer_.handle(), 0, sizeof(gpu), &gpu);
  barrier.srcStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  barrier.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  barrier.dstStageMask = readers;
  barrier.dstAccessMask = VK_ACCESS_2_UNIFORM_READ_BIT;
  vkCmdPipelineBarrier2(cmd, &dep);
}

void LitPass::draw(VkCommandBuffer cmd, const MeshStore& meshes, VkDescriptorSet shadowSet,
                   std::span<const LitDraw> draws, VkExtent2D extent) const {
  ScopedLabel label(cmd, "lit pass", {0.9f, 0.8f, 0.3f, 1.0f});
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.pipeline);
  const VkDescriptorSet sets[2] = {frameSet_, shadowSet};
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.layout, 0, 2, sets, 0,
                          nullptr);
  setViewportAndScissor(cmd, extent);
  meshes.bind(cmd);
  for (const LitDraw& d : draws) {
    LitPush push{};
    push.modelCr = glm::mat4(d.linearWs);
    push.modelCr[3] = glm::vec4(glm::vec3(d.translationWs - cameraPositionWs_), 1.0f);
    const glm::mat3 normalMatrix = glm::transpose(glm::inverse(d.linearWs));
    for (int i = 0; i < 3; ++i) push.normalToWs[i] = glm::vec4(normalMatrix[i], 0.0f);
    push.color = d.color;
    vkCmdPushConstants(cmd, pipeline_.layout,
                       VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push),
                       &push);
    vkCmdDrawIndexed(cmd, d.mesh.indexCount, 1, d.mesh.firstIndex, d.mesh.vertexOffset, 0);
  }
}

std::unique_ptr<LitPass> makeLitPass(engine::Context& ctx, VkFormat colorFormat,
                                     VkFormat depthFormat, VkDescriptorSetLayout lightingSetLayout,
                                     csm::PcfKernel kernel, bool blend, uint32_t pcssTaps) {
  LitPassDesc desc;
  desc.colorFormat = colorFormat;
  desc.depthFormat = depthFormat;
  desc.shadowSetLayout = lightingSetLayout;
  desc.specialization = {{CSM_SPEC_KERNEL, uint32_t(kernel)}, {CSM_SPEC_BLEND, blend ? 1u : 0u}};
  if (pcssTaps != 0) desc.specialization.push_back({CSM_SPEC_PCSS_TAPS, pcssTaps});
  return std::make_unique<LitPass>(ctx, desc);
}

void recordTimedLitPass(LitPass& lit, engine::GpuTimer& timer, const engine::Frame& frame,
                        const LitFrame& litFrame, const engine::MeshStore& meshes,
                        VkDescriptorSet lightingSet, std::span<const LitDraw> draws) {
  lit.prepare(frame.cmd, litFrame);
  timer.begin(frame.cmd, "lit");
  engine::beginRendering(frame, VkClearColorValue{{0.1f, 0.1f, 0.15f, 1.0f}});
  lit.draw(frame.cmd, meshes, lightingSet, draws, frame.extent);
  vkCmdEndRendering(frame.cmd);
  timer.end(frame.cmd, "lit");
}

}  // namespace glue
