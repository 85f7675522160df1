// Dear ImGui on the engine's render targets: the Vulkan backend (1.86, render-pass based) drawn
// in a render pass of its own that loads the frame's colour image, and optionally the GLFW
// backend for input. Headless use: no window, DisplaySize set by hand.
#pragma once

#include <vulkan/vulkan.h>

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

  /// Starts an ImGui frame for a target of `extent` (headless) or the window.
  void newFrame(VkExtent2D extent, double dtSeconds);
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
};
