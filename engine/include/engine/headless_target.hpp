// An offscreen render target: RGBA8 colour + D32 depth images, read back to the CPU or to PNG.
#pragma once

#include <string>

#include "engine/image_io.hpp"
#include "engine/memory.hpp"
#include "engine/render_target.hpp"

namespace engine {

/// Size and formats of a HeadlessTarget.
struct HeadlessDesc {
  VkExtent2D extent{640, 360};
  VkFormat depthFormat = VK_FORMAT_D32_SFLOAT;
};

/// Renders into its own colour (R8G8B8A8_UNORM) and depth images. After endFrame the colour
/// image is kept in TRANSFER_SRC_OPTIMAL for readback; the next beginFrame discards it.
class HeadlessTarget final : public RenderTarget {
 public:
  /// Creates the images and the frame ring.
  HeadlessTarget(Context& ctx, const HeadlessDesc& desc = {});
  ~HeadlessTarget() override;

  std::optional<Frame> beginFrame() override;
  void endFrame() override;
  void waitIdle() override;
  VkExtent2D extent() const override { return color_.extent(); }
  VkFormat colorFormat() const override { return color_.format(); }
  VkFormat depthFormat() const override { return depth_.format(); }

  /// Waits for the last frame and copies its colour image to the CPU (RGBA8, rows top to bottom).
  /// Throws std::logic_error when no frame has been rendered.
  CpuImage readback();
  /// readback() written as a PNG file; throws std::runtime_error when writing fails.
  void savePng(const std::string& path);
  /// The depth image (DEPTH_ATTACHMENT_OPTIMAL between frames), e.g. for tests.
  const Image& depthImage() const { return depth_; }

 private:
  Context* ctx_;
  Image color_;
  Image depth_;
  FrameRing ring_;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  uint64_t frames_ = 0;
  bool inFrame_ = false;
};

}  // namespace engine
