// A GLFW window with a Vulkan surface and swapchain. Handles resize, minimise (0x0 framebuffer:
// frames are skipped) and VK_ERROR_OUT_OF_DATE_KHR / VK_SUBOPTIMAL_KHR by recreating the
// swapchain.
#pragma once

#include <string>
#include <vector>

#include "engine/memory.hpp"
#include "engine/render_target.hpp"

struct GLFWwindow;

namespace engine {

struct ContextDesc;

/// How to open a WindowTarget.
struct WindowDesc {
  std::string title = "csm";
  int width = 1280;
  int height = 720;
  bool vsync = true;  ///< FIFO when true, else MAILBOX or IMMEDIATE when available
  VkFormat depthFormat = VK_FORMAT_D32_SFLOAT;
};

/// Presents frames to a GLFW window. The Context must have been created from a ContextDesc
/// passed through WindowTarget::prepareContext.
class WindowTarget final : public RenderTarget {
 public:
  /// Initialises GLFW and adds the surface extensions, presentation and the present-support
  /// test to `desc`. Throws std::runtime_error when GLFW cannot start (no display) or has no
  /// Vulkan support.
  static void prepareContext(ContextDesc& desc);

  /// Opens the window and creates surface, swapchain and depth image.
  WindowTarget(Context& ctx, const WindowDesc& desc);
  ~WindowTarget() override;

  std::optional<Frame> beginFrame() override;
  void endFrame() override;
  void waitIdle() override;
  VkExtent2D extent() const override { return extent_; }
  VkFormat colorFormat() const override { return surfaceFormat_.format; }
  VkFormat depthFormat() const override { return depthFormat_; }

  /// The GLFW window (for input and window management).
  GLFWwindow* window() const { return window_; }
  /// Whether the user asked to close the window.
  bool shouldClose() const;
  /// Processes window events (glfwPollEvents).
  void pollEvents();
  /// Number of times the swapchain was (re)created, for tests.
  uint32_t swapchainGeneration() const { return generation_; }

 private:
  void createSwapchain();
  void destroySwapchain(bool keepHandle);

  Context* ctx_;
  WindowDesc desc_;
  GLFWwindow* window_ = nullptr;
  VkSurfaceKHR surface_ = VK_NULL_HANDLE;
  VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
  VkSurfaceFormatKHR surfaceFormat_{};
  VkFormat depthFormat_;
  VkExtent2D extent_{0, 0};
  std::vector<VkImage> images_;
  std::vector<VkImageView> views_;
  std::vector<VkSemaphore> renderDone_;  // one per swapchain image
  Image depth_;
  FrameRing ring_;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  VkSemaphore acquired_ = VK_NULL_HANDLE;
  uint32_t imageIndex_ = 0;
  uint64_t frames_ = 0;
  uint32_t generation_ = 0;
  bool inFrame_ = false;
  bool resized_ = false;
};

}  // namespace engine
