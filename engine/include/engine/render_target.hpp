// Render targets: where a frame's colour and depth go. HeadlessTarget keeps them for readback,
// WindowTarget presents them. Both use FrameRing: 2 frames in flight, each with its own command
// pool, command buffer and fence.
#pragma once

#include <vulkan/vulkan.h>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace engine {

class Context;

/// Frames the CPU may record ahead of the GPU.
inline constexpr uint32_t kFramesInFlight = 2;

/// One frame handed to the renderer by RenderTarget::beginFrame.
/// On entry `cmd` is recording, the colour image is in COLOR_ATTACHMENT_OPTIMAL and the depth
/// image in DEPTH_ATTACHMENT_OPTIMAL, both with undefined content (clear them with load ops).
/// The renderer must leave both in these layouts when it calls endFrame.
struct Frame {
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  uint32_t slot = 0;    ///< frame-in-flight index in [0, kFramesInFlight)
  uint64_t number = 0;  ///< index of this frame since the target was created
  VkImage colorImage = VK_NULL_HANDLE;
  VkImageView colorView = VK_NULL_HANDLE;
  VkFormat colorFormat = VK_FORMAT_UNDEFINED;
  VkImage depthImage = VK_NULL_HANDLE;
  VkImageView depthView = VK_NULL_HANDLE;
  VkFormat depthFormat = VK_FORMAT_UNDEFINED;
  VkExtent2D extent{0, 0};
};

/// The interface every render target implements.
class RenderTarget {
 public:
  virtual ~RenderTarget() = default;
  /// Waits until the frame slot is free, begins its command buffer and prepares the images.
  /// Returns nullopt when no frame can be rendered now (a minimised window, or a swapchain that
  /// was just recreated): the caller skips this frame and tries again.
  virtual std::optional<Frame> beginFrame() = 0;
  /// Finishes the frame begun last: ends and submits its commands, then presents (window) or
  /// keeps the image for readback (headless).
  virtual void endFrame() = 0;
  /// Waits until every submitted frame has finished on the GPU.
  virtual void waitIdle() = 0;
  /// Current size of the colour and depth images.
  virtual VkExtent2D extent() const = 0;
  virtual VkFormat colorFormat() const = 0;
  virtual VkFormat depthFormat() const = 0;
};

/// Per-frame-in-flight command pools, command buffers, fences and acquire semaphores.
class FrameRing {
 public:
  /// Creates kFramesInFlight slots; objects are named "<name>.frame<i>.*".
  FrameRing(Context& ctx, std::string_view name);
  ~FrameRing();
  FrameRing(const FrameRing&) = delete;
  FrameRing& operator=(const FrameRing&) = delete;

  /// Waits for the current slot's previous submission, resets its pool and begins its command
  /// buffer (ONE_TIME_SUBMIT). Calling it again before submit() restarts the same slot.
  VkCommandBuffer begin();
  /// Ends the command buffer and submits it with the slot's fence, optionally waiting on `wait`
  /// at `waitStage` and signalling `signal`; then moves to the next slot.
  void submit(VkSemaphore wait = VK_NULL_HANDLE,
              VkPipelineStageFlags2 waitStage = VK_PIPELINE_STAGE_2_NONE,
              VkSemaphore signal = VK_NULL_HANDLE);
  /// Waits for the fences of all slots.
  void waitAll();
  /// The slot begin() records into.
  uint32_t slot() const { return slot_; }
  /// Frames submitted so far.
  uint64_t submitted() const { return submitted_; }
  /// The binary semaphore for swapchain acquisition of the current slot.
  VkSemaphore acquireSemaphore() const { return slots_[slot_].acquired; }

 private:
  struct Slot {
    VkCommandPool pool = VK_NULL_HANDLE;
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    VkSemaphore acquired = VK_NULL_HANDLE;
  };
  void destroy() noexcept;

  Context* ctx_;
  std::array<Slot, kFramesInFlight> slots_{};
  uint32_t slot_ = 0;
  uint64_t submitted_ = 0;
};

/// Begins dynamic rendering into the frame's colour (cleared to `clearColor`) and depth (cleared
/// to `clearDepth`), both stored, and sets a full-target viewport and scissor.
void beginRendering(const Frame& frame, const VkClearColorValue& clearColor,
                    float clearDepth = 1.0f);
/// Sets viewport (min depth 0, max depth 1) and scissor to the whole `extent`.
void setViewportAndScissor(VkCommandBuffer cmd, VkExtent2D extent);

}  // namespace engine
