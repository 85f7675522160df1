// Dear ImGui on the engine's targets (see imgui_layer.hpp).
#include "imgui_layer.hpp"

#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_vulkan.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "engine/debug.hpp"
#include "engine/errors.hpp"

namespace {
void checkVk(VkResult r) {
  if (r != VK_SUCCESS) throw std::runtime_error("imgui vulkan backend: " + engine::vkResultName(r));
}

// The built-in font (ProggyClean, drawn for 13 px) baked once per size the panels use: text
// rasterised at its size stays sharp where a scaled atlas would blur.
constexpr float kFontSizes[] = {10.0f, 11.0f, 12.0f, 13.0f, 14.0f, 16.0f, 18.0f, 20.0f};
constexpr float kFontDesignPixels = 13.0f;
}  // namespace

ImGuiLayer::ImGuiLayer(engine::Context& ctx, VkFormat colorFormat, GLFWwindow* window)
    : ctx_(&ctx), window_(window) {
  VkDevice dev = ctx.device();
  // One colour attachment, loaded and kept in COLOR_ATTACHMENT_OPTIMAL (the layout the engine's
  // targets hand over and expect back).
  VkAttachmentDescription att{};
  att.format = colorFormat;
  att.samples = VK_SAMPLE_COUNT_1_BIT;
  att.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
  att.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  att.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  att.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  att.initialLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  att.finalLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  VkAttachmentReference ref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  VkSubpassDescription sub{};
  sub.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  sub.colorAttachmentCount = 1;
  sub.pColorAttachments = &ref;
  VkSubpassDependency deps[2]{};
  deps[0].srcSubpass = VK_SUBPASS_EXTERNAL;
  deps[0].dstSubpass = 0;
  deps[0].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  deps[0].dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  deps[0].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  deps[0].dstAccessMask =
      VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  deps[1].srcSubpass = 0;
  deps[1].dstSubpass = VK_SUBPASS_EXTERNAL;
  deps[1].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  deps[1].dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  deps[1].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  deps[1].dstAccessMask =
      VK_ACCESS_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  VkRenderPassCreateInfo rp{};
  rp.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
  rp.attachmentCount = 1;
  rp.pAttachments = &att;
  rp.subpassCount = 1;
  rp.pSubpasses = &sub;
  rp.dependencyCount = 2;
  rp.pDependencies = deps;
  ENGINE_VK_CHECK(vkCreateRenderPass(dev, &rp, nullptr, &renderPass_));
  engine::setDebugNameRaw(dev, VK_OBJECT_TYPE_RENDER_PASS,
                          reinterpret_cast<std::uint64_t>(renderPass_), "imgui.renderPass");

  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 4};
  VkDescriptorPoolCreateInfo pi{};
  pi.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  pi.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
  pi.maxSets = 4;
  pi.poolSizeCount = 1;
  pi.pPoolSizes = &size;
  ENGINE_VK_CHECK(vkCreateDescriptorPool(dev, &pi, nullptr, &pool_));
  engine::setDebugName(dev, pool_, "imgui.pool");

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::StyleColorsDark();
  ImGuiIO& io = ImGui::GetIO();
  io.IniFilename = nullptr;  // no imgui.ini left behind
  for (float px : kFontSizes) {
    ImFontConfig font;
    font.SizePixels = px;
    io.Fonts->AddFontDefault(&font);
  }
  if (window_) ImGui_ImplGlfw_InitForVulkan(window_, true);
  ImGui_ImplVulkan_InitInfo init{};
  init.Instance = ctx.instance();
  init.PhysicalDevice = ctx.physicalDevice();
  init.Device = dev;
  init.QueueFamily = ctx.queueFamily();
  init.Queue = ctx.queue();
  init.DescriptorPool = pool_;
  init.MinImageCount = 2;
  init.ImageCount = engine::kFramesInFlight + 1;
  init.MSAASamples = VK_SAMPLE_COUNT_1_BIT;
  init.CheckVkResultFn = checkVk;
  if (!ImGui_ImplVulkan_Init(&init, renderPass_))
    throw std::runtime_error("ImGui_ImplVulkan_Init failed");
  ctx.submitAndWait([](VkCommandBuffer cmd) { ImGui_ImplVulkan_CreateFontsTexture(cmd); });
  ImGui_ImplVulkan_DestroyFontUploadObjects();
}

ImGuiLayer::~ImGuiLayer() {
  ctx_->waitIdle();
  ImGui_ImplVulkan_Shutdown();
  if (window_) ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  releaseFramebuffers();
  vkDestroyDescriptorPool(ctx_->device(), pool_, nullptr);
  vkDestroyRenderPass(ctx_->device(), renderPass_, nullptr);
}

void ImGuiLayer::releaseFramebuffers() {
  for (auto& [key, fb] : framebuffers_) vkDestroyFramebuffer(ctx_->device(), fb, nullptr);
  framebuffers_.clear();
}

float ImGuiLayer::fontPixels(std::uint32_t viewHeight) {
  return std::clamp(std::round(static_cast<float>(viewHeight) / 32.0f), 10.0f, 20.0f);
}

void ImGuiLayer::newFrame(VkExtent2D extent, double dt) {
  ImGui_ImplVulkan_NewFrame();
  ImGuiIO& io = ImGui::GetIO();
  // The largest baked size not above the view's (fonts are in kFontSizes order).
  const float px = fontPixels(extent.height);
  if (px != fontPixels_) {
    int pick = 0;
    for (int k = 0; k < io.Fonts->Fonts.Size; ++k) {
      if (kFontSizes[k] <= px) pick = k;
    }
    io.FontDefault = io.Fonts->Fonts[pick];
    ImGuiStyle& style = ImGui::GetStyle();
    style = ImGuiStyle();
    ImGui::StyleColorsDark(&style);
    style.ScaleAllSizes(kFontSizes[pick] / kFontDesignPixels);
    fontPixels_ = px;
  }
  if (window_) {
    ImGui_ImplGlfw_NewFrame();
  } else {
    io.DisplaySize = ImVec2(static_cast<float>(extent.width), static_cast<float>(extent.height));
    io.DeltaTime = static_cast<float>(dt > 0.0 ? dt : 1.0 / 60.0);
  }
  ImGui::NewFrame();
}

void ImGuiLayer::endFrame() {
  ImGui::Render();
  rendered_ = true;
}

void ImGuiLayer::record(const engine::Frame& frame) {
  ImDrawData* data = ImGui::GetDrawData();
  if (!data || data->CmdListsCount == 0) return;
  const std::uint64_t key2 = (std::uint64_t(frame.extent.width) << 32) | frame.extent.height;
  auto& fb = framebuffers_[{frame.colorView, key2}];
  if (fb == VK_NULL_HANDLE) {
    VkFramebufferCreateInfo fi{};
    fi.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
    fi.renderPass = renderPass_;
    fi.attachmentCount = 1;
    fi.pAttachments = &frame.colorView;
    fi.width = frame.extent.width;
    fi.height = frame.extent.height;
    fi.layers = 1;
    ENGINE_VK_CHECK(vkCreateFramebuffer(ctx_->device(), &fi, nullptr, &fb));
    engine::setDebugNameRaw(ctx_->device(), VK_OBJECT_TYPE_FRAMEBUFFER,
                            reinterpret_cast<std::uint64_t>(fb), "imgui.framebuffer");
  }
  engine::ScopedLabel label(frame.cmd, "imgui", {0.8f, 0.4f, 0.9f, 1.0f});
  VkRenderPassBeginInfo bi{};
  bi.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
  bi.renderPass = renderPass_;
  bi.framebuffer = fb;
  bi.renderArea = {{0, 0}, frame.extent};
  vkCmdBeginRenderPass(frame.cmd, &bi, VK_SUBPASS_CONTENTS_INLINE);
  ImGui_ImplVulkan_RenderDrawData(data, frame.cmd);
  vkCmdEndRenderPass(frame.cmd);
}
