// The sample world's lighting paths (see world_renderer.hpp): the lighting pipelines, built with
// the shadow view's specialization; forward (with or without the depth pre-pass) and deferred
// (G-buffer, then one full-view triangle).
#include "sample_world/world_renderer.hpp"

#include <csm_shaders/overlay_2d.frag.spv.h>
#include <csm_shaders/overlay_2d.vert.spv.h>
#include <csm_shaders/world.frag.spv.h>
#include <csm_shaders/world.vert.spv.h>
#include <csm_shaders/world_deferred.frag.spv.h>
#include <csm_shaders/world_deferred.vert.spv.h>
#include <csm_shaders/world_gbuffer.frag.spv.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "csm/gpu_layout.hpp"
#include "engine/debug.hpp"
#include "engine/errors.hpp"
#include "glue/camera.hpp"
#include "glue/shadow_host.hpp"
#include "glue/vk_util.hpp"
#include "world_renderer_internal.hpp"

namespace world {

namespace {

// An attachment of a rendering, stored at its end.
VkRenderingAttachmentInfo storedAttachment(VkImageView view, VkImageLayout layout,
                                           VkAttachmentLoadOp load, VkClearValue clear = {}) {
  VkRenderingAttachmentInfo a{};
  a.sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO;
  a.imageView = view;
  a.imageLayout = layout;
  a.loadOp = load;
  a.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  a.clearValue = clear;
  return a;
}

// Begins the rendering the shading and the overlay draw into: the frame's colour cleared to the
// sky, its depth (written by the pre-pass or the G-buffer pass) loaded and kept.
void beginShadingKeepingDepth(const engine::Frame& f) {
  VkClearValue sky{};
  sky.color = kSkyColor;
  const VkRenderingAttachmentInfo color = storedAttachment(
      f.colorView, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_ATTACHMENT_LOAD_OP_CLEAR, sky);
  const VkRenderingAttachmentInfo depth = storedAttachment(
      f.depthView, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_ATTACHMENT_LOAD_OP_LOAD);
  VkRenderingInfo info{};
  info.sType = VK_STRUCTURE_TYPE_RENDERING_INFO;
  info.renderArea = {{0, 0}, f.extent};
  info.layerCount = 1;
  info.colorAttachmentCount = 1;
  info.pColorAttachments = &color;
  info.pDepthAttachment = &depth;
  vkCmdBeginRendering(f.cmd, &info);
  engine::setViewportAndScissor(f.cmd, f.extent);
}

// The depth attachment of a pass that draws the visible world first: cleared to the far plane,
// stored.
VkRenderingAttachmentInfo clearedDepth(const engine::Frame& f) {
  VkClearValue far{};
  far.depthStencil = {1.0f, 0};
  return storedAttachment(f.depthView, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                          VK_ATTACHMENT_LOAD_OP_CLEAR, far);
}

// That pass's depth writes before the rendering that tests or keeps them (same layout).
void depthWritesBeforeShading(const engine::Frame& f) {
  engine::imageBarrier(
      f.cmd, f.depthImage, VK_IMAGE_ASPECT_DEPTH_BIT,
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
          VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
      VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
}

// The lighting pipelines' key: the view's specialization (kernel, blend, PCSS taps; below
// WorldRenderer::kLitAfterPrepass).
std::uint32_t specKey(const csm::vk::LightingSpecialization& spec) {
  return spec.value(CSM_SPEC_KERNEL) | spec.value(CSM_SPEC_BLEND) << 3 |
         spec.value(CSM_SPEC_PCSS_TAPS) << 4;
}

// The view's specialization on the fragment stage of a lighting pipeline.
void specialize(engine::GraphicsPipelineBuilder& b, const csm::vk::LightingSpecialization& spec) {
  for (const csm::SpecConstant& c : spec.constants()) {
    b.specialization(VK_SHADER_STAGE_FRAGMENT_BIT, c.id, c.value);
  }
}

}  // namespace

void WorldRenderer::buildLitPipeline() {
  const csm::vk::LightingSpecialization spec = shadow_->lightingSpecialization();
  const std::uint32_t specBits = specKey(spec);
  const std::uint32_t key = specBits | (settings_.depthPrepass ? kLitAfterPrepass : 0u);
  const VkVertexInputBindingDescription bindings[] = {
      engine::MeshStore::bindingDescription(),
      {1, sizeof(Instance), VK_VERTEX_INPUT_RATE_INSTANCE}};
  std::vector<VkVertexInputAttributeDescription> attrs(
      engine::MeshStore::attributeDescriptions().begin(),
      engine::MeshStore::attributeDescriptions().end());
  for (std::uint32_t k = 0; k < 4; ++k) {
    attrs.push_back({2 + k, 1, VK_FORMAT_R32G32B32A32_SFLOAT,
                     static_cast<std::uint32_t>(k * sizeof(glm::vec4))});
  }
  if (settings_.depthPrepass && !depthPrepass_.pipeline) {
    // The same vertex shader (gl_Position is precise) and vertex input as the lit pipeline, no
    // fragment shader and no colour attachment: the depths the lit pass tests EQUAL against.
    for (int cull = 0; cull < 2; ++cull) {
      engine::GraphicsPipelineBuilder d;
      d.vertexShader(worldVert_)
          .vertexInput(bindings, attrs)
          .depthFormat(depthFormat_)
          .depthTest(true, true, VK_COMPARE_OP_LESS)
          .cullMode(cull ? VK_CULL_MODE_BACK_BIT : VK_CULL_MODE_NONE)
          .descriptorSetLayout(frameLayout_.get());
      (cull ? depthPrepassCullBack_ : depthPrepass_) =
          d.build(*ctx_, cull ? "world.depthPrepass.cullBack" : "world.depthPrepass");
    }
  }
  if (settings_.deferred && !gbuffer_.pipeline) {
    // The lit pipeline's vertex shader and input with world_gbuffer.frag: depth LESS with writes.
    for (int cull = 0; cull < 2; ++cull) {
      engine::GraphicsPipelineBuilder g;
      g.vertexShader(worldVert_)
          .fragmentShader(gbufferFrag_)
          .vertexInput(bindings, attrs)
          .colorFormats(kGBufferFormats)
          .depthFormat(depthFormat_)
          .depthTest(true, true, VK_COMPARE_OP_LESS)
          .cullMode(cull ? VK_CULL_MODE_BACK_BIT : VK_CULL_MODE_NONE)
          .descriptorSetLayout(frameLayout_.get())
          .descriptorSetLayout(shadow_->lightingSetLayout());
      (cull ? gbufferCullBack_ : gbuffer_) =
          g.build(*ctx_, cull ? "world.gbuffer.cullBack" : "world.gbuffer");
    }
  }
  if (settings_.deferred && !deferredPipelines_.count(specBits)) {
    // One triangle over the view, no depth test, into the frame's colour (and depth: the overlay
    // draws in the same rendering).
    engine::GraphicsPipelineBuilder d;
    d.vertexShader(deferredVert_)
        .fragmentShader(deferredFrag_)
        .colorFormat(colorFormat_)
        .depthFormat(depthFormat_)
        .depthTest(false, false)
        .descriptorSetLayout(frameLayout_.get())
        .descriptorSetLayout(shadow_->lightingSetLayout())
        .descriptorSetLayout(gbufferLayout_.get());
    specialize(d, spec);
    deferredPipelines_[specBits] =
        d.build(*ctx_, std::string("world.deferred.") + kernelKey(settings_.shadow.kernel));
  }
  if (litPipelines_.count(key)) return;
  for (int cull = 0; cull < 2; ++cull) {
    engine::GraphicsPipelineBuilder b;
    b.vertexShader(worldVert_)
        .fragmentShader(worldFrag_)
        .vertexInput(bindings, attrs)
        .colorFormat(colorFormat_)
        .depthFormat(depthFormat_)
        .depthTest(true, !settings_.depthPrepass,
                   settings_.depthPrepass ? VK_COMPARE_OP_EQUAL : VK_COMPARE_OP_LESS)
        .descriptorSetLayout(frameLayout_.get())
        .descriptorSetLayout(shadow_->lightingSetLayout())
        .cullMode(cull ? VK_CULL_MODE_BACK_BIT : VK_CULL_MODE_NONE);
    specialize(b, spec);
    litPipelines_[key | (cull ? kLitCullBack : 0u)] = b.build(
        *ctx_, std::string("world.lit.") + kernelKey(settings_.shadow.kernel) +
                   (settings_.depthPrepass ? ".afterPrepass" : "") + (cull ? ".cullBack" : ""));
  }
}

const engine::GraphicsPipeline& WorldRenderer::litPipeline(bool prepass, bool cullBack) const {
  return litPipelines_.at(specKey(shadow_->lightingSpecialization()) |
                          (prepass ? kLitAfterPrepass : 0u) | (cullBack ? kLitCullBack : 0u));
}

void WorldRenderer::bindWorldGeometry(VkCommandBuffer cmd, Slot& slot) const {
  const VkBuffer buffers[2] = {meshes_->vertexBuffer(), slot.instances.handle()};
  const VkDeviceSize offsets[2] = {0, 0};
  vkCmdBindVertexBuffers(cmd, 0, 2, buffers, offsets);
  vkCmdBindIndexBuffer(cmd, meshes_->indexBuffer(), 0, VK_INDEX_TYPE_UINT32);
}

void WorldRenderer::drawBuckets(VkCommandBuffer cmd, const engine::GraphicsPipeline& both,
                                const engine::GraphicsPipeline& cullBack) const {
  // The two pipelines' layouts are identical, hence compatible: the bound sets stay valid.
  int bound = -1;
  for (const Bucket& b : buckets_) {
    if (int(b.cullBack) != bound) {
      bound = int(b.cullBack);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS,
                        b.cullBack ? cullBack.pipeline : both.pipeline);
    }
    const engine::MeshRange& r = assetRanges_[b.mesh][b.lod];
    vkCmdDrawIndexed(cmd, r.indexCount, b.count, r.firstIndex, r.vertexOffset, b.first);
  }
}

void WorldRenderer::recordDepthPrepass(const engine::Frame& f, Slot& slot,
                                       engine::GpuTimer& timer) {
  VkCommandBuffer cmd = f.cmd;
  // A rendering of its own: on a binning rasteriser (lavapipe) the work happens when a
  // rendering ends, so the "prepass" scope holds the pre-pass's rasterisation, not the lit pass's.
  timer.begin(cmd, "prepass");
  const VkRenderingAttachmentInfo depth = clearedDepth(f);
  VkRenderingInfo info{};
  info.sType = VK_STRUCTURE_TYPE_RENDERING_INFO;
  info.renderArea = {{0, 0}, f.extent};
  info.layerCount = 1;
  info.pDepthAttachment = &depth;
  vkCmdBeginRendering(cmd, &info);
  {
    engine::ScopedLabel label(cmd, "world depth pre-pass", {0.5f, 0.5f, 0.5f, 1.0f});
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, depthPrepass_.pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, depthPrepass_.layout, 0, 1,
                            &slot.frameSet, 0, nullptr);
    engine::setViewportAndScissor(cmd, f.extent);
    bindWorldGeometry(cmd, slot);
    drawBuckets(cmd, depthPrepass_, depthPrepassCullBack_);
  }
  vkCmdEndRendering(cmd);
  // The pre-pass's depth writes before the lit pass's depth tests (same layout).
  depthWritesBeforeShading(f);
  timer.end(cmd, "prepass");
}

void WorldRenderer::recordLitPass(const engine::Frame& f, Slot& slot, engine::GpuTimer& timer,
                                  bool overlay) {
  VkCommandBuffer cmd = f.cmd;
  // ---- Lit pass ---------------------------------------------------------------------------------
  WorldFrameGpu gpu{};
  gpu.viewProjCr = camera_.viewProjectionCr();
  gpu.invViewProjCr = glm::mat4(glm::inverse(glm::dmat4(gpu.viewProjCr)));
  gpu.lightDirection = glm::vec4(glm::vec3(lightDirection(settings_)), 0.0f);
  gpu.lightColor = glm::vec4(1.0f, 0.96f, 0.88f, 1.0f);
  gpu.ambientColor = glm::vec4(glm::vec3(0.55f, 0.65f, 0.85f) * settings_.ambient * 1.6f, 1.0f);
  gpu.overlay = glm::uvec4(overlay && settings_.overlayTint ? 1u : 0u,
                           overlay && settings_.overlayChecker ? 1u : 0u, 0u, 0u);
  std::memcpy(slot.frameUniforms.mapped(), &gpu, sizeof(gpu));
  std::memcpy(slot.instances.mapped(), instances_.data(), instances_.size() * sizeof(Instance));

  if (settings_.deferred && f.depthView != VK_NULL_HANDLE) {
    recordGBufferPass(f, slot, timer);
    recordDeferredLighting(f, slot, timer);
    return;
  }
  const bool prepass = settings_.depthPrepass && f.depthView != VK_NULL_HANDLE;
  if (prepass) recordDepthPrepass(f, slot, timer);
  timer.begin(cmd, "lit");
  if (prepass) {
    beginShadingKeepingDepth(f);
  } else {
    engine::beginRendering(f, kSkyColor);
  }
  {
    engine::ScopedLabel label(cmd, "world lit pass", {0.9f, 0.8f, 0.3f, 1.0f});
    const engine::GraphicsPipeline& p = litPipeline(prepass, false);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.pipeline);
    const VkDescriptorSet sets[2] = {slot.frameSet, shadow_->lightingSet()};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.layout, 0, 2, sets, 0, nullptr);
    engine::setViewportAndScissor(cmd, f.extent);
    bindWorldGeometry(cmd, slot);
    drawBuckets(cmd, p, litPipeline(prepass, true));
  }
  timer.end(cmd, "lit");
}

void WorldRenderer::recordGBufferPass(const engine::Frame& f, Slot& slot, engine::GpuTimer& timer) {
  VkCommandBuffer cmd = f.cmd;
  ensureGBuffer(slot, f.extent);
  // A rendering of its own (on lavapipe its rasterisation happens when it ends: the scope holds
  // it). The images' last reads (this slot's previous lighting pass) before the writes; their
  // contents are not kept.
  timer.begin(cmd, "gbuffer");
  const engine::Image* images[3] = {&slot.gAlbedo, &slot.gNormals, &slot.gViewDepth};
  std::array<VkRenderingAttachmentInfo, 3> colors{};
  for (std::size_t k = 0; k < 3; ++k) {
    engine::imageBarrier(
        cmd, images[k]->handle(), VK_IMAGE_ASPECT_COLOR_BIT,
        VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
        VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
        VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
    // Cleared to 0 (view depth 0: sky).
    colors[k] = storedAttachment(images[k]->view(), VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                                 VK_ATTACHMENT_LOAD_OP_CLEAR);
  }
  const VkRenderingAttachmentInfo depth = clearedDepth(f);
  VkRenderingInfo info{};
  info.sType = VK_STRUCTURE_TYPE_RENDERING_INFO;
  info.renderArea = {{0, 0}, f.extent};
  info.layerCount = 1;
  info.colorAttachmentCount = static_cast<std::uint32_t>(colors.size());
  info.pColorAttachments = colors.data();
  info.pDepthAttachment = &depth;
  vkCmdBeginRendering(cmd, &info);
  {
    engine::ScopedLabel label(cmd, "world g-buffer pass", {0.6f, 0.6f, 0.9f, 1.0f});
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, gbuffer_.pipeline);
    const VkDescriptorSet sets[2] = {slot.frameSet, shadow_->lightingSet()};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, gbuffer_.layout, 0, 2, sets, 0,
                            nullptr);
    engine::setViewportAndScissor(cmd, f.extent);
    bindWorldGeometry(cmd, slot);
    drawBuckets(cmd, gbuffer_, gbufferCullBack_);
  }
  vkCmdEndRendering(cmd);
  // The G-buffer's writes before the lighting pass reads it; the depth writes before the
  // rendering that keeps them (the overlay's, the depth-range reduction after it).
  for (const engine::Image* im : images) {
    engine::imageBarrier(
        cmd, im->handle(), VK_IMAGE_ASPECT_COLOR_BIT,
        VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
        VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
        VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  }
  depthWritesBeforeShading(f);
  timer.end(cmd, "gbuffer");
}

void WorldRenderer::recordDeferredLighting(const engine::Frame& f, Slot& slot,
                                           engine::GpuTimer& timer) {
  VkCommandBuffer cmd = f.cmd;
  timer.begin(cmd, "lit");
  // Colour cleared to the sky, the G-buffer pass's depth kept for the overlay and the reduction.
  beginShadingKeepingDepth(f);
  {
    engine::ScopedLabel label(cmd, "world deferred lighting", {0.9f, 0.8f, 0.3f, 1.0f});
    const engine::GraphicsPipeline& p =
        deferredPipelines_.at(specKey(shadow_->lightingSpecialization()));
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.pipeline);
    const VkDescriptorSet sets[3] = {slot.frameSet, shadow_->lightingSet(), slot.gbufferSet};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.layout, 0, 3, sets, 0, nullptr);
    vkCmdDraw(cmd, 3, 1, 0, 0);
  }
  timer.end(cmd, "lit");
}

}  // namespace world
