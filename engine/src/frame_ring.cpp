#include <string>

#include "engine/context.hpp"
#include "engine/debug.hpp"
#include "engine/errors.hpp"
#include "engine/render_target.hpp"
#include "vk_struct.hpp"

namespace engine {

FrameRing::FrameRing(Context& ctx, std::string_view name) : ctx_(&ctx) {
  VkDevice device = ctx.device();
  try {
    for (uint32_t i = 0; i < kFramesInFlight; ++i) {
      Slot& s = slots_[i];
      const std::string prefix = std::string(name) + ".frame" + std::to_string(i);
      auto poolInfo =
          detail::vkStruct<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
      poolInfo.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
      poolInfo.queueFamilyIndex = ctx.queueFamily();
      ENGINE_VK_CHECK(vkCreateCommandPool(device, &poolInfo, nullptr, &s.pool));
      setDebugName(device, s.pool, prefix + ".pool");
      auto alloc = detail::vkStruct<VkCommandBufferAllocateInfo>(
          VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
      alloc.commandPool = s.pool;
      alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
      alloc.commandBufferCount = 1;
      ENGINE_VK_CHECK(vkAllocateCommandBuffers(device, &alloc, &s.cmd));
      setDebugName(device, s.cmd, prefix + ".cmd");
      auto fenceInfo = detail::vkStruct<VkFenceCreateInfo>(VK_STRUCTURE_TYPE_FENCE_CREATE_INFO);
      fenceInfo.flags = VK_FENCE_CREATE_SIGNALED_BIT;
      ENGINE_VK_CHECK(vkCreateFence(device, &fenceInfo, nullptr, &s.fence));
      setDebugName(device, s.fence, prefix + ".fence");
      auto semInfo =
          detail::vkStruct<VkSemaphoreCreateInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO);
      ENGINE_VK_CHECK(vkCreateSemaphore(device, &semInfo, nullptr, &s.acquired));
      setDebugName(device, s.acquired, prefix + ".acquired");
    }
  } catch (...) {
    destroy();
    throw;
  }
}

FrameRing::~FrameRing() {
  destroy();
}

void FrameRing::destroy() noexcept {
  VkDevice device = ctx_->device();
  for (Slot& s : slots_) {
    if (s.fence) vkWaitForFences(device, 1, &s.fence, VK_TRUE, UINT64_MAX);
    if (s.acquired) vkDestroySemaphore(device, s.acquired, nullptr);
    if (s.fence) vkDestroyFence(device, s.fence, nullptr);
    if (s.pool) vkDestroyCommandPool(device, s.pool, nullptr);  // frees s.cmd
    s = Slot{};
  }
}

VkCommandBuffer FrameRing::begin() {
  Slot& s = slots_[slot_];
  VkDevice device = ctx_->device();
  ENGINE_VK_CHECK(vkWaitForFences(device, 1, &s.fence, VK_TRUE, UINT64_MAX));
  ENGINE_VK_CHECK(vkResetCommandPool(device, s.pool, 0));
  auto info =
      detail::vkStruct<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
  info.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  ENGINE_VK_CHECK(vkBeginCommandBuffer(s.cmd, &info));
  return s.cmd;
}

void FrameRing::submit(VkSemaphore wait, VkPipelineStageFlags2 waitStage, VkSemaphore signal) {
  Slot& s = slots_[slot_];
  ENGINE_VK_CHECK(vkEndCommandBuffer(s.cmd));
  auto waitInfo = detail::vkStruct<VkSemaphoreSubmitInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO);
  waitInfo.semaphore = wait;
  waitInfo.stageMask = waitStage;
  auto signalInfo =
      detail::vkStruct<VkSemaphoreSubmitInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO);
  signalInfo.semaphore = signal;
  // Presentation waits for everything the frame did.
  signalInfo.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  auto cmdInfo =
      detail::vkStruct<VkCommandBufferSubmitInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO);
  cmdInfo.commandBuffer = s.cmd;
  auto submit = detail::vkStruct<VkSubmitInfo2>(VK_STRUCTURE_TYPE_SUBMIT_INFO_2);
  submit.waitSemaphoreInfoCount = wait ? 1 : 0;
  submit.pWaitSemaphoreInfos = wait ? &waitInfo : nullptr;
  submit.commandBufferInfoCount = 1;
  submit.pCommandBufferInfos = &cmdInfo;
  submit.signalSemaphoreInfoCount = signal ? 1 : 0;
  submit.pSignalSemaphoreInfos = signal ? &signalInfo : nullptr;
  // The fence is reset only now, so a frame begun and then abandoned (swapchain out of date)
  // leaves it signalled and the next begin() does not wait forever.
  ENGINE_VK_CHECK(vkResetFences(ctx_->device(), 1, &s.fence));
  ENGINE_VK_CHECK(vkQueueSubmit2(ctx_->queue(), 1, &submit, s.fence));
  slot_ = (slot_ + 1) % kFramesInFlight;
  ++submitted_;
}

void FrameRing::waitAll() {
  for (Slot& s : slots_)
    ENGINE_VK_CHECK(vkWaitForFences(ctx_->device(), 1, &s.fence, VK_TRUE, UINT64_MAX));
}

void setViewportAndScissor(VkCommandBuffer cmd, VkExtent2D extent) {
  const VkViewport viewport{0.0f, 0.0f, float(extent.width), float(extent.height), 0.0f, 1.0f};
  const VkRect2D scissor{{0, 0}, extent};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

void beginRendering(const Frame& frame, const VkClearColorValue& clearColor, float clearDepth) {
  auto color =
      detail::vkStruct<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
  color.imageView = frame.colorView;
  color.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  color.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  color.clearValue.color = clearColor;
  auto depth =
      detail::vkStruct<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
  depth.imageView = frame.depthView;
  depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depth.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  depth.clearValue.depthStencil = {clearDepth, 0};
  auto info = detail::vkStruct<VkRenderingInfo>(VK_STRUCTURE_TYPE_RENDERING_INFO);
  info.renderArea = {{0, 0}, frame.extent};
  info.layerCount = 1;
  info.colorAttachmentCount = 1;
  info.pColorAttachments = &color;
  info.pDepthAttachment = frame.depthView ? &depth : nullptr;
  vkCmdBeginRendering(frame.cmd, &info);
  setViewportAndScissor(frame.cmd, frame.extent);
}

}  // namespace engine
