// Dear ImGui on the engine's render targets: the Vulkan backend (1.86, render-pass based) drawn
// in a render pass of its own that loads the frame's colour image, and optionally the GLFW
// backend for input. Headless use: no window, DisplaySize set by hand.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <map>
#include <utility>

#include "engine/context.hpp"
#include "engine/render_target.hpp"

struct GLFWwindow;

class ImGuiLayer {
 public:
  /// `window` may be null (headless).
  ImGuiLayer(engine::Context& ctx, VkFormat colorFormat, GLFWwindow* window);
  ~ImGuiLayer();
  ImGuiLayer(const ImGuiLayer&) = delete;
  ImGuiLayer& operator=(const ImGuiLayer&) = delete;

  /// Starts an ImGui frame for a target of `extent` (headless) or the window, its text sized for
  /// the view (fontPixels) and the style's spacing scaled with it.
  void newFrame(VkExtent2D extent, double dtSeconds);
  /// The text height (pixels) of the panels over a view `viewHeight` pixels high: about 1/32 of
  /// it (11 px at 360, 20 px at 720), at least 10 px (the built-in font blurs below) and at most
  /// 20 px.
  static float fontPixels(std::uint32_t viewHeight);
  /// Ends the ImGui frame (ImGui::Render); call once per newFrame even if nothing is drawn.
  void endFrame();
  /// Records the draw data of the last endFrame() onto the frame's colour image.
  void record(const engine::Frame& frame);
  /// Forgets the framebuffers (call after the swapchain was recreated, GPU idle).
  void releaseFramebuffers();

 private:
  engine::Context* ctx_;
  GLFWwindow* window_;
  VkRenderPass renderPass_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  std::map<std::pair<VkImageView, std::uint64_t>, VkFramebuffer> framebuffers_;
  bool rendered_ = false;
  float fontPixels_ = 0.0f;  // the size newFrame chose last (the style is scaled for it)
};
