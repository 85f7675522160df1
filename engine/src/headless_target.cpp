#include "engine/headless_target.hpp"

#include <cstring>
#include <stdexcept>

#include "engine/context.hpp"
#include "frame_start.hpp"

namespace engine {

HeadlessTarget::HeadlessTarget(Context& ctx, const HeadlessDesc& desc)
    : ctx_(&ctx),
      color_(ctx,
             ImageDesc{VK_FORMAT_R8G8B8A8_UNORM, desc.extent, 1, 1,
                       VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
                           VK_IMAGE_USAGE_SAMPLED_BIT,
                       VK_IMAGE_VIEW_TYPE_2D},
             "engine.headless.color"),
      depth_(ctx,
             ImageDesc{desc.depthFormat, desc.extent, 1, 1,
                       VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT |
                           VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                       VK_IMAGE_VIEW_TYPE_2D},
             "engine.headless.depth"),
      ring_(ctx, "engine.headless") {}

HeadlessTarget::~HeadlessTarget() {
  // Best effort and non-throwing: a lost device must not turn destruction into terminate().
  vkDeviceWaitIdle(ctx_->device());
}

std::optional<Frame> HeadlessTarget::beginFrame() {
  if (inFrame_) throw std::logic_error("HeadlessTarget::beginFrame called twice without endFrame");
  cmd_ = ring_.begin();
  // The previous frame's contents are discarded (UNDEFINED); the barrier orders this frame's
  // writes after the previous frame's attachment writes and any readback copy.
  const detail::FrameImages images{.colorImage = color_.handle(),
                                   .colorView = color_.view(),
                                   .colorFormat = color_.format(),
                                   .depth = &depth_,
                                   .depthFormat = depth_.format(),
                                   .extent = color_.extent()};
  inFrame_ = true;
  return detail::startFrame(
      cmd_, ring_.slot(), frames_, images,
      VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_2_COPY_BIT,
      VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
}

void HeadlessTarget::endFrame() {
  if (!inFrame_) throw std::logic_error("HeadlessTarget::endFrame without beginFrame");
  imageBarrier(cmd_, color_.handle(), VK_IMAGE_ASPECT_COLOR_BIT,
               VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
               VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
               VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
               VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
  ring_.submit();
  inFrame_ = false;
  ++frames_;
}

void HeadlessTarget::waitIdle() {
  ring_.waitAll();
}

CpuImage HeadlessTarget::readback() {
  if (frames_ == 0) throw std::logic_error("HeadlessTarget::readback before any frame");
  if (inFrame_) throw std::logic_error("HeadlessTarget::readback inside a frame");
  ring_.waitAll();
  const std::vector<std::byte> bytes =
      readbackImage(*ctx_, color_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
  CpuImage image;
  image.width = color_.extent().width;
  image.height = color_.extent().height;
  image.rgba.resize(bytes.size());
  std::memcpy(image.rgba.data(), bytes.data(), bytes.size());
  return image;
}

void HeadlessTarget::savePng(const std::string& path) {
  if (!writePng(path, readback())) throw std::runtime_error("could not write PNG " + path);
}

}  // namespace engine
