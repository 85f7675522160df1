#include "engine/window_target.hpp"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "engine/context.hpp"
#include "engine/debug.hpp"
#include "engine/errors.hpp"
#include "frame_start.hpp"
#include "vk_struct.hpp"

namespace engine {
namespace {

int gWindowCount = 0;  // GLFW is terminated when the last window closes (main thread only)

}  // namespace

void WindowTarget::prepareContext(ContextDesc& desc) {
  glfwSetErrorCallback(
      [](int code, const char* text) { std::fprintf(stderr, "GLFW error %d: %s\n", code, text); });
  if (!glfwInit())
    throw std::runtime_error("GLFW could not initialise (no display? set DISPLAY or use xvfb-run)");
  if (!glfwVulkanSupported()) throw NoDeviceError("GLFW found no Vulkan loader with a surface");
  uint32_t count = 0;
  const char** extensions = glfwGetRequiredInstanceExtensions(&count);
  if (!extensions) throw NoDeviceError("GLFW reports no Vulkan surface extensions");
  for (uint32_t i = 0; i < count; ++i) desc.instanceExtensions.emplace_back(extensions[i]);
  desc.presentation = true;
  desc.presentSupport = [](VkInstance instance, VkPhysicalDevice pd, uint32_t family) {
    return glfwGetPhysicalDevicePresentationSupport(instance, pd, family) == GLFW_TRUE;
  };
}

WindowTarget::WindowTarget(Context& ctx, const WindowDesc& desc)
    : ctx_(&ctx), desc_(desc), depthFormat_(desc.depthFormat), ring_(ctx, "engine.window") {
  if (!glfwInit()) throw std::runtime_error("GLFW could not initialise");
  ++gWindowCount;
  try {
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    glfwWindowHint(GLFW_RESIZABLE, GLFW_TRUE);
    window_ = glfwCreateWindow(desc.width, desc.height, desc.title.c_str(), nullptr, nullptr);
    if (!window_) throw std::runtime_error("glfwCreateWindow failed");
    glfwSetWindowUserPointer(window_, this);
    glfwSetFramebufferSizeCallback(window_, [](GLFWwindow* w, int, int) {
      static_cast<WindowTarget*>(glfwGetWindowUserPointer(w))->resized_ = true;
    });
    ENGINE_VK_CHECK(glfwCreateWindowSurface(ctx.instance(), window_, nullptr, &surface_));
    VkBool32 supported = VK_FALSE;
    ENGINE_VK_CHECK(vkGetPhysicalDeviceSurfaceSupportKHR(ctx.physicalDevice(), ctx.queueFamily(),
                                                         surface_, &supported));
    if (!supported) throw std::runtime_error("the engine's queue cannot present to this window");

    uint32_t count = 0;
    ENGINE_VK_CHECK(
        vkGetPhysicalDeviceSurfaceFormatsKHR(ctx.physicalDevice(), surface_, &count, nullptr));
    std::vector<VkSurfaceFormatKHR> formats(count);
    ENGINE_VK_CHECK(vkGetPhysicalDeviceSurfaceFormatsKHR(ctx.physicalDevice(), surface_, &count,
                                                         formats.data()));
    if (formats.empty()) throw std::runtime_error("the surface offers no formats");
    // UNORM like HeadlessTarget, so a shader's output means the same bytes in both targets.
    surfaceFormat_ = formats[0];
    for (const VkSurfaceFormatKHR& f : formats)
      if ((f.format == VK_FORMAT_B8G8R8A8_UNORM || f.format == VK_FORMAT_R8G8B8A8_UNORM) &&
          f.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR) {
        surfaceFormat_ = f;
        break;
      }
    createSwapchain();
  } catch (...) {
    destroySwapchain(false);
    if (surface_) vkDestroySurfaceKHR(ctx.instance(), surface_, nullptr);
    if (window_) glfwDestroyWindow(window_);
    if (--gWindowCount == 0) glfwTerminate();
    throw;
  }
}

WindowTarget::~WindowTarget() {
  vkDeviceWaitIdle(ctx_->device());  // non-throwing, unlike ring_.waitAll()
  destroySwapchain(false);
  vkDestroySurfaceKHR(ctx_->instance(), surface_, nullptr);
  glfwDestroyWindow(window_);
  if (--gWindowCount == 0) glfwTerminate();
}

void WindowTarget::destroySwapchain(bool keepHandle) {
  VkDevice device = ctx_->device();
  for (VkImageView v : views_) vkDestroyImageView(device, v, nullptr);
  for (VkSemaphore s : renderDone_) vkDestroySemaphore(device, s, nullptr);
  views_.clear();
  renderDone_.clear();
  images_.clear();
  depth_.reset();
  if (!keepHandle && swapchain_) {
    vkDestroySwapchainKHR(device, swapchain_, nullptr);
    swapchain_ = VK_NULL_HANDLE;
  }
}

void WindowTarget::createSwapchain() {
  ctx_->waitIdle();
  VkPhysicalDevice pd = ctx_->physicalDevice();
  VkDevice device = ctx_->device();
  VkSurfaceCapabilitiesKHR caps;
  ENGINE_VK_CHECK(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(pd, surface_, &caps));
  int w = 0, h = 0;
  glfwGetFramebufferSize(window_, &w, &h);
  VkExtent2D extent = caps.currentExtent;
  if (extent.width == UINT32_MAX) {
    extent.width =
        std::clamp(static_cast<uint32_t>(w), caps.minImageExtent.width, caps.maxImageExtent.width);
    extent.height = std::clamp(static_cast<uint32_t>(h), caps.minImageExtent.height,
                               caps.maxImageExtent.height);
  }
  // Old views, semaphores and depth go now (the device is idle); the old swapchain handle is
  // kept until the new one exists, as oldSwapchain.
  destroySwapchain(/*keepHandle=*/true);
  VkSwapchainKHR old = swapchain_;
  swapchain_ = VK_NULL_HANDLE;
  extent_ = extent;
  if (extent.width == 0 || extent.height == 0) {  // minimised: no swapchain until restored
    if (old) vkDestroySwapchainKHR(device, old, nullptr);
    return;
  }

  uint32_t modeCount = 0;
  ENGINE_VK_CHECK(vkGetPhysicalDeviceSurfacePresentModesKHR(pd, surface_, &modeCount, nullptr));
  std::vector<VkPresentModeKHR> modes(modeCount);
  ENGINE_VK_CHECK(
      vkGetPhysicalDeviceSurfacePresentModesKHR(pd, surface_, &modeCount, modes.data()));
  VkPresentModeKHR mode = VK_PRESENT_MODE_FIFO_KHR;  // always supported
  if (!desc_.vsync) {
    for (VkPresentModeKHR m : {VK_PRESENT_MODE_MAILBOX_KHR, VK_PRESENT_MODE_IMMEDIATE_KHR})
      if (std::find(modes.begin(), modes.end(), m) != modes.end()) {
        mode = m;
        break;
      }
  }
  VkCompositeAlphaFlagBitsKHR alpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
  for (VkCompositeAlphaFlagBitsKHR a :
       {VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR, VK_COMPOSITE_ALPHA_INHERIT_BIT_KHR,
        VK_COMPOSITE_ALPHA_PRE_MULTIPLIED_BIT_KHR, VK_COMPOSITE_ALPHA_POST_MULTIPLIED_BIT_KHR})
    if (caps.supportedCompositeAlpha & a) {
      alpha = a;
      break;
    }
  uint32_t imageCount = caps.minImageCount + 1;
  if (caps.maxImageCount > 0) imageCount = std::min(imageCount, caps.maxImageCount);

  auto info =
      detail::vkStruct<VkSwapchainCreateInfoKHR>(VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR);
  info.surface = surface_;
  info.minImageCount = imageCount;
  info.imageFormat = surfaceFormat_.format;
  info.imageColorSpace = surfaceFormat_.colorSpace;
  info.imageExtent = extent;
  info.imageArrayLayers = 1;
  info.imageUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT |
                    (caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
  info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.preTransform = caps.currentTransform;
  info.compositeAlpha = alpha;
  info.presentMode = mode;
  info.clipped = VK_TRUE;
  info.oldSwapchain = old;
  const VkResult r = vkCreateSwapchainKHR(device, &info, nullptr, &swapchain_);
  if (old) vkDestroySwapchainKHR(device, old, nullptr);
  ENGINE_VK_CHECK(r);
  ++generation_;
  const std::string prefix = "engine.window.swapchain" + std::to_string(generation_);
  setDebugName(device, swapchain_, prefix);

  uint32_t count = 0;
  ENGINE_VK_CHECK(vkGetSwapchainImagesKHR(device, swapchain_, &count, nullptr));
  images_.resize(count);
  ENGINE_VK_CHECK(vkGetSwapchainImagesKHR(device, swapchain_, &count, images_.data()));
  for (uint32_t i = 0; i < count; ++i) {
    const std::string name = prefix + ".image" + std::to_string(i);
    setDebugName(device, images_[i], name);
    auto viewInfo =
        detail::vkStruct<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
    viewInfo.image = images_[i];
    viewInfo.viewType = VK_IMAGE_VIEW_TYPE_2D;
    viewInfo.format = surfaceFormat_.format;
    viewInfo.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    VkImageView view = VK_NULL_HANDLE;
    ENGINE_VK_CHECK(vkCreateImageView(device, &viewInfo, nullptr, &view));
    views_.push_back(view);
    setDebugName(device, view, name + ".view");
    auto semInfo = detail::vkStruct<VkSemaphoreCreateInfo>(VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO);
    VkSemaphore sem = VK_NULL_HANDLE;
    ENGINE_VK_CHECK(vkCreateSemaphore(device, &semInfo, nullptr, &sem));
    renderDone_.push_back(sem);
    setDebugName(device, sem, name + ".render_done");
  }
  depth_ = Image(*ctx_,
                 ImageDesc{depthFormat_, extent, 1, 1,
                           // Sampled: a host's depth reduction reads it (receiver-driven splits).
                           VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                           VK_IMAGE_VIEW_TYPE_2D},
                 prefix + ".depth");
}

std::optional<Frame> WindowTarget::beginFrame() {
  if (inFrame_) throw std::logic_error("WindowTarget::beginFrame called twice without endFrame");
  int w = 0, h = 0;
  glfwGetFramebufferSize(window_, &w, &h);
  if (w == 0 || h == 0) return std::nullopt;  // minimised: skip until restored
  if (resized_ || swapchain_ == VK_NULL_HANDLE) {
    resized_ = false;
    createSwapchain();
    if (swapchain_ == VK_NULL_HANDLE) return std::nullopt;
  }
  cmd_ = ring_.begin();
  acquired_ = ring_.acquireSemaphore();
  const VkResult r = vkAcquireNextImageKHR(ctx_->device(), swapchain_, UINT64_MAX, acquired_,
                                           VK_NULL_HANDLE, &imageIndex_);
  if (r == VK_ERROR_OUT_OF_DATE_KHR) {
    createSwapchain();  // the semaphore was not signalled; the slot is reused next time
    return std::nullopt;
  }
  if (r == VK_SUBOPTIMAL_KHR)
    resized_ = true;  // present this frame, recreate after it
  else
    ENGINE_VK_CHECK(r);

  // The acquired image's contents are discarded; the acquire semaphore orders the presentation
  // engine's reads before the colour writes.
  const detail::FrameImages images{.colorImage = images_[imageIndex_],
                                   .colorView = views_[imageIndex_],
                                   .colorFormat = surfaceFormat_.format,
                                   .depth = &depth_,
                                   .depthFormat = depthFormat_,
                                   .extent = extent_};
  inFrame_ = true;
  return detail::startFrame(cmd_, ring_.slot(), frames_, images,
                            VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_NONE);
}

void WindowTarget::endFrame() {
  if (!inFrame_) throw std::logic_error("WindowTarget::endFrame without beginFrame");
  inFrame_ = false;
  imageBarrier(cmd_, images_[imageIndex_], VK_IMAGE_ASPECT_COLOR_BIT,
               VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
               VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
               VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR);
  VkSemaphore done = renderDone_[imageIndex_];
  ring_.submit(acquired_, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, done);
  ++frames_;

  auto present = detail::vkStruct<VkPresentInfoKHR>(VK_STRUCTURE_TYPE_PRESENT_INFO_KHR);
  present.waitSemaphoreCount = 1;
  present.pWaitSemaphores = &done;
  present.swapchainCount = 1;
  present.pSwapchains = &swapchain_;
  present.pImageIndices = &imageIndex_;
  const VkResult r = vkQueuePresentKHR(ctx_->queue(), &present);
  if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR || resized_) {
    resized_ = false;
    createSwapchain();
  } else {
    ENGINE_VK_CHECK(r);
  }
}

void WindowTarget::waitIdle() {
  ring_.waitAll();
}

bool WindowTarget::shouldClose() const {
  return glfwWindowShouldClose(window_) == GLFW_TRUE;
}

void WindowTarget::pollEvents() {
  glfwPollEvents();
}

}  // namespace engine
