// ShadowRenderer's pass: the uniform block, the barriers, the per-layer and layered depth passes
// over a caster list, and the callback form (the cached pass's own steps are in shadow_cache.cpp).
#include "csm/vulkan/shadow_renderer.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <string>

#include "shadow_renderer_impl.hpp"
#include "vk_util.hpp"

namespace csm::vk {

namespace {

glm::mat4 modelCameraRelative(const glm::dvec3& translationWs, const glm::mat3& linearWs,
                              const glm::dvec3& cameraWs) {
  glm::mat4 m(linearWs);
  m[3] = glm::vec4(glm::vec3(translationWs - cameraWs), 1.0f);
  return m;
}

// Model space -> the cascade's shadow clip space, composed in double about the snapped box
// centre: p_clip = S (B^T (R p + T - C)) + o. Nothing here depends on the camera, so a camera
// that moves less than a texel re-renders a bit-identical map, and one that moves further
// shifts it by whole texels (C moves on the world-anchored grid). A camera-relative composition
// would re-round every caster differently each frame and flip coverage of texels that a caster
// edge crosses within float noise of their centre: shimmer.
glm::mat4 modelToShadowClip(const Cascade& c, const glm::dmat3& basisWs,
                            const glm::dvec3& translationWs, const glm::mat3& linearWs) {
  const glm::dvec3 scale(1.0 / c.halfExtentLs.x, 1.0 / c.halfExtentLs.y,
                         1.0 / (c.depthFarLs - c.depthNearLs));
  const glm::dmat3 toLight = glm::transpose(basisWs);
  const glm::dmat3 linear = toLight * glm::dmat3(linearWs);
  const glm::dvec3 t = toLight * (translationWs - c.boxCenterWs) - glm::dvec3(0, 0, c.depthNearLs);
  return scaledAffine(linear, t, scale);
}

// Every instance of a caster list valid (validateCasters, unless the caller did) and every
// visible index in range.
Status checkCasterList(const CascadeFrame& frame, const CasterList& casters,
                       const CullResult* visible, bool instancesValidated) {
  const std::size_t instanceCount = casters.instances.size();
  if (!instancesValidated) {
    if (Status s = validateCasters(casters.meshes, casters.instances); !s.ok()) return s;
  }
  if (visible) {
    for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
      if (frame.cascades[c].empty) continue;
      for (std::size_t k = 0; k < visible->visible[c].size(); ++k) {
        if (visible->visible[c][k] >= instanceCount) {
          return Status(ErrorCode::kIndexOutOfRange,
                        fmt("visible[%u][%zu] = %u is out of range: allowed [0, %zu)", c, k,
                            visible->visible[c][k], instanceCount));
        }
      }
    }
  }
  return {};
}

}  // namespace

void CascadeDrawContext::setTransform(const glm::dvec3& translationWs,
                                      const glm::mat3& linearWs) const {
  glm::mat4 m(1.0f);
  if (frame != nullptr && anchored) {
    const glm::dmat3 toLight = glm::transpose(frame->lightBasisWs);
    m = scaledAffine(toLight * glm::dmat3(linearWs), toLight * translationWs - originLs,
                     clipPerMetre);
  } else if (frame != nullptr) {
    m = modelToShadowClip(frame->cascades[cascade], frame->lightBasisWs, translationWs, linearWs);
  }
  const DepthPushPerLayer push{m, cascade};
  vkCmdPushConstants(cmd, pipelineLayout, VK_SHADER_STAGE_VERTEX_BIT, 0, CSM_DEPTH_PUSH_SIZE,
                     &push);
}

// ---------------------------------------------------------------------------------------------
// The pass. Its resources: the depth image (all layers) written as a depth attachment through
// the per-layer views (or the array view when layered), the uniform buffer written by
// vkCmdUpdateBuffer; its barriers: consumers' reads -> transfer/attachment writes at the start,
// attachment/transfer writes -> consumers' reads (SHADER_READ_ONLY_OPTIMAL) at the end.

Status ShadowRenderer::Impl::checkFrame(const CascadeFrame& frame) const {
  if (image_ == VK_NULL_HANDLE) {
    return Status(ErrorCode::kWrongOrder, "recordShadowPass before a successful update()");
  }
  if (static_cast<std::uint32_t>(debugMode_) >= CSM_DEBUG_COUNT) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("setDebugMode: debugMode = %u is invalid: allowed [0, %d) (csm::DebugMode)",
                      static_cast<std::uint32_t>(debugMode_), CSM_DEBUG_COUNT));
  }
  if (frame.blendBand != settings_.blendBand) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("frame.blendBand = %g but update() was given settings.blendBand = %g: "
                      "compute the frame with the settings given to update()",
                      frame.blendBand, settings_.blendBand));
  }
  if (frame.normalOffsetTexels != settings_.normalOffsetTexels) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("frame.normalOffsetTexels = %g but update() was given "
                      "settings.normalOffsetTexels = %g: compute the frame with the settings "
                      "given to update()",
                      double(frame.normalOffsetTexels), double(settings_.normalOffsetTexels)));
  }
  if (frame.cascadeCount != settings_.cascadeCount || frame.resolution != settings_.resolution) {
    return Status(
        ErrorCode::kInvalidArgument,
        fmt("frame has %u cascades of %u texels but the renderer was updated with %u of "
            "%u: compute the frame with the settings given to update()",
            frame.cascadeCount, frame.resolution, settings_.cascadeCount, settings_.resolution));
  }
  return {};
}

// The start every recorded pass shares (cached or not): one more host frame, so what was
// retired framesInFlight records ago is no longer in use; the pass leaves every layer written
// and sampleable. Returns whether the image was still waiting for its one-time clear.
bool ShadowRenderer::Impl::countRecord() {
  ++records_;
  collectRetired(false);
  const bool wasPending = pendingClear_;
  pendingClear_ = false;
  uniformsCleared_ = true;
  return wasPending;
}

// Opens the pass's debug label and uploads uniforms_ between two barriers: earlier readers of
// the block finish before it is overwritten (write after read), then the pass's and the host's
// readers see the new block. `images` (the pass's first image transitions) join the first one.
void ShadowRenderer::Impl::recordPassStart(VkCommandBuffer cmd, const char* label,
                                           std::span<const VkImageMemoryBarrier2> images) {
  if (beginLabel_) {
    auto info = vkInit<VkDebugUtilsLabelEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT);
    info.pLabelName = label;
    info.color[0] = 0.3f;
    info.color[1] = 0.3f;
    info.color[2] = 0.8f;
    info.color[3] = 1.0f;
    beginLabel_(cmd, &info);
  }
  const VkPipelineStageFlags2 readers =
      options_.consumerStages | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT;
  auto toWrite = vkInit<VkBufferMemoryBarrier2>(VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2);
  toWrite.srcStageMask = readers;
  toWrite.srcAccessMask = VK_ACCESS_2_NONE;
  toWrite.dstStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  toWrite.dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  toWrite.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toWrite.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toWrite.buffer = uniformBuffer_;
  toWrite.size = VK_WHOLE_SIZE;
  auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.bufferMemoryBarrierCount = 1;
  dep.pBufferMemoryBarriers = &toWrite;
  dep.imageMemoryBarrierCount = static_cast<std::uint32_t>(images.size());
  dep.pImageMemoryBarriers = images.data();
  vkCmdPipelineBarrier2(cmd, &dep);

  vkCmdUpdateBuffer(cmd, uniformBuffer_, 0, sizeof(CsmUniforms), &uniforms_);

  VkBufferMemoryBarrier2 toRead = toWrite;
  toRead.srcStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  toRead.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  toRead.dstStageMask = readers;
  toRead.dstAccessMask = VK_ACCESS_2_UNIFORM_READ_BIT;
  auto dep2 = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep2.bufferMemoryBarrierCount = 1;
  dep2.pBufferMemoryBarriers = &toRead;
  vkCmdPipelineBarrier2(cmd, &dep2);
}

// The uniform block of `frame` as every pass packs it: the host's debug mode, the depth
// format's bits (the depth floor's quantum) and the moment sampler's anisotropy.
UniformOptions ShadowRenderer::Impl::uniformOptions() const noexcept {
  UniformOptions options;
  options.debugMode = debugMode_;
  options.depthBits = options_.depthFormat == VK_FORMAT_D16_UNORM ? 16u : 32u;
  options.msmQuantizedMoments = moments_.format == VK_FORMAT_R16G16B16A16_UNORM;
  options.momentAnisotropy = device_.maxSamplerAnisotropy;
  return options;
}

CsmUniforms ShadowRenderer::Impl::packFrameUniforms(const CascadeFrame& frame) const {
  return packUniforms(frame, settings_, uniformOptions());
}

void ShadowRenderer::Impl::recordBegin(VkCommandBuffer cmd, const CascadeFrame& frame) {
  countRecord();
  uniforms_ = packFrameUniforms(frame);
  recordDiscardingStart(cmd, "csm shadow pass");
}

// The start of a pass that renders every layer whole: earlier samplers of the map finish before
// it is discarded and rendered again; then the uniform block (uniforms_).
void ShadowRenderer::Impl::recordDiscardingStart(VkCommandBuffer cmd, const char* label) {
  auto toAttachment = vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2);
  toAttachment.srcStageMask = options_.consumerStages;
  toAttachment.srcAccessMask = VK_ACCESS_2_NONE;
  toAttachment.dstStageMask =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  toAttachment.dstAccessMask = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
                               VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  toAttachment.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;  // the previous frame's depth is not kept
  toAttachment.newLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  toAttachment.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toAttachment.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toAttachment.image = image_;
  toAttachment.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, layerCount_};
  recordPassStart(cmd, label, {&toAttachment, 1});
}

void ShadowRenderer::Impl::recordEnd(VkCommandBuffer cmd) {
  auto toSampled = vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2);
  toSampled.srcStageMask =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  toSampled.srcAccessMask = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  toSampled.dstStageMask = options_.consumerStages;
  toSampled.dstAccessMask = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  toSampled.oldLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  toSampled.newLayout = sampledLayout();
  toSampled.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toSampled.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toSampled.image = image_;
  toSampled.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, layerCount_};
  auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &toSampled;
  vkCmdPipelineBarrier2(cmd, &dep);
  recordMomentResolve(cmd);
  if (endLabel_) endLabel_(cmd);
}

// Begins dynamic rendering of the depth pass into `view` (`layers` layers, cleared to depth 1
// or loaded; DEPTH_ATTACHMENT_OPTIMAL) under a debug label, with the pass's dynamic state,
// `pipeline` and the depth set bound. Viewport and scissor are the caller's.
void ShadowRenderer::Impl::beginDepthRendering(VkCommandBuffer cmd, VkImageView view,
                                               std::uint32_t layers, bool clear,
                                               const std::string& label, VkPipeline pipeline) {
  if (beginLabel_) {
    auto info = vkInit<VkDebugUtilsLabelEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT);
    info.pLabelName = label.c_str();
    beginLabel_(cmd, &info);
  }
  auto depth = vkInit<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
  depth.imageView = view;
  depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depth.loadOp = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
  depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  depth.clearValue.depthStencil = {1.0f, 0};
  auto ri = vkInit<VkRenderingInfo>(VK_STRUCTURE_TYPE_RENDERING_INFO);
  ri.renderArea = {{0, 0}, {resolution_, resolution_}};
  ri.layerCount = layers;
  ri.pDepthAttachment = &depth;
  vkCmdBeginRendering(cmd, &ri);
  vkCmdSetDepthBias(cmd, settings_.depthBiasConstant, 0.0f, settings_.depthBiasSlope);
  vkCmdSetCullMode(cmd, options_.cullMode);
  vkCmdSetFrontFace(cmd, options_.frontFace);
  drawCull_ = options_.cullMode;
  drawFront_ = options_.frontFace;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelineLayout_, 0, 1, &depthSet_,
                          0, nullptr);
}

// Closed casters: cull the faces turned away from the light (RendererOptions::
// cullClosedCasters). Light space is right-handed with +z along the light's travel, and its x, y
// go to the framebuffer's x, y unflipped, so a face whose outward normal points at the light
// (-z) has a positive area in Vulkan's sense: counter-clockwise is front. A mirroring transform
// turns the winding. Sets the state only where it changes within the rendering.
void ShadowRenderer::Impl::setCasterCull(VkCommandBuffer cmd, const CasterInstance& instance) {
  VkCullModeFlags cull = options_.cullMode;
  VkFrontFace front = options_.frontFace;
  if (cull == VK_CULL_MODE_NONE && settings_.diagnostics.cullClosedCasters && instance.closed &&
      !instance.thin) {
    const float det = glm::determinant(instance.linearWs);
    if (det != 0.0f) {
      cull = VK_CULL_MODE_BACK_BIT;
      front = det > 0.0f ? VK_FRONT_FACE_COUNTER_CLOCKWISE : VK_FRONT_FACE_CLOCKWISE;
    }
  }
  if (cull != drawCull_) {
    vkCmdSetCullMode(cmd, cull);
    drawCull_ = cull;
  }
  if (front != drawFront_) {
    vkCmdSetFrontFace(cmd, front);
    drawFront_ = front;
  }
}

void ShadowRenderer::Impl::beginLayer(VkCommandBuffer cmd, std::uint32_t cascade, bool layered) {
  beginDepthRendering(
      cmd, layered ? arrayView_ : layerViews_[cascade], layered ? layerCount_ : 1, true,
      layered ? std::string("csm cascades (layered)") : "csm cascade " + std::to_string(cascade),
      layered ? layeredPipeline_ : pipeline_);
  const VkViewport viewport{0.0f, 0.0f, float(resolution_), float(resolution_), 0.0f, 1.0f};
  const VkRect2D scissor{{0, 0}, {resolution_, resolution_}};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

void ShadowRenderer::Impl::endLayer(VkCommandBuffer cmd) {
  vkCmdEndRendering(cmd);
  if (endLabel_) endLabel_(cmd);
}

Status ShadowRenderer::Impl::recordShadowPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                                              const CasterList& casters,
                                              const CullResult* visible) {
  return recordCasterListPass(cmd, frame, casters, visible, false);
}

Status ShadowRenderer::Impl::recordValidatedPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                                                 const CasterList& casters,
                                                 const CullResult* visible) {
  return recordCasterListPass(cmd, frame, casters, visible, true);
}

Status ShadowRenderer::Impl::recordCasterListPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                                                  const CasterList& casters,
                                                  const CullResult* visible,
                                                  bool instancesValidated) {
  Status s = checkFrame(frame);
  if (!s.ok()) return s;
  if (cmd == VK_NULL_HANDLE) return Status(ErrorCode::kInvalidArgument, "cmd is VK_NULL_HANDLE");
  s = checkCasterList(frame, casters, visible, instancesValidated);
  if (!s.ok()) return s;
  const std::size_t instanceCount = casters.instances.size();
  if (options_.cache) {
    if (visible == nullptr) {
      return Status(ErrorCode::kInvalidArgument,
                    "options.cache = true needs the cull lists (visible) of the frame");
    }
    if (casters.boundsWs.size() != instanceCount) {
      return Status(ErrorCode::kInvalidArgument,
                    fmt("options.cache = true needs casters.boundsWs for every instance: %zu "
                        "bounds for %zu instances",
                        casters.boundsWs.size(), instanceCount));
    }
  } else if (!casters.boundsWs.empty() && casters.boundsWs.size() != instanceCount) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("casters.boundsWs has %zu bounds for %zu instances: give one per instance "
                      "or none",
                      casters.boundsWs.size(), instanceCount));
  }
  if (windowed()) return recordCachedPass(cmd, frame, casters, visible);
  recordBegin(cmd, frame);
  // The mesh cascade c draws instance i with: its LOD by the schedule and the texel error budget.
  auto lodMesh = [&](std::size_t i, std::uint32_t c) {
    const CasterInstance& inst = casters.instances[i];
    const Cascade& cascade = frame.cascades[c];
    return inst.meshForLod(casterLod(inst, options_.cascadeLod[c],
                                     glm::min(cascade.texelSizeLs.x, cascade.texelSizeLs.y),
                                     options_.lodMaxErrorTexels));
  };
  const glm::dvec3 cam = frame.cameraPositionWs;
  const MeshDraw* bound = nullptr;
  // Draws instance `index` with mesh `meshIndex`: per-layer into cascade `cascades` (an index),
  // layered instanced into the cascades of the mask `cascades`, `copies` of them.
  auto drawCaster = [&](std::uint32_t index, std::uint32_t meshIndex, std::uint32_t cascades,
                        std::uint32_t copies) {
    const CasterInstance& inst = casters.instances[index];
    const MeshDraw& mesh = casters.meshes[meshIndex];
    if (mesh.indexCount == 0) return;
    bindMeshBuffers(cmd, mesh, bound, layout_.indexType);
    // Per-layer: the exact, camera-independent transform. Layered: one draw serves several
    // cascades, so the shader applies each cascade's camera-relative matrix.
    if (resolvedMode_ == RenderMode::kLayered) {
      const DepthPushLayered push{modelCameraRelative(inst.translationWs, inst.linearWs, cam),
                                  cascades};
      vkCmdPushConstants(cmd, pipelineLayout_, VK_SHADER_STAGE_VERTEX_BIT, 0, CSM_DEPTH_PUSH_SIZE,
                         &push);
    } else {
      const DepthPushPerLayer push{modelToShadowClip(frame.cascades[cascades], frame.lightBasisWs,
                                                     inst.translationWs, inst.linearWs),
                                   cascades};
      vkCmdPushConstants(cmd, pipelineLayout_, VK_SHADER_STAGE_VERTEX_BIT, 0, CSM_DEPTH_PUSH_SIZE,
                         &push);
    }
    LayerTexels texels{};
    if (resolvedMode_ == RenderMode::kLayered) {
      for (std::uint32_t c = 0; c < frame.cascadeCount; ++c)
        texels[c] = frame.cascades[c].texelSizeM();
    } else {
      texels[0] = frame.cascades[cascades].texelSizeM();
    }
    drawIndexedCaster(cmd, inst, mesh, copies, texels);
  };

  std::uint32_t nonEmpty = 0;
  for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
    if (!frame.cascades[c].empty) nonEmpty |= 1u << c;
  }
  if (resolvedMode_ == RenderMode::kLayered && nonEmpty != 0) {
    // One pass; each caster once, instanced into the cascades it was culled into.
    casterMasks_.assign(instanceCount, 0u);
    for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
      if ((nonEmpty & (1u << c)) == 0) continue;
      if (visible) {
        for (std::uint32_t i : visible->visible[c]) casterMasks_[i] |= 1u << c;
      } else {
        for (std::size_t i = 0; i < instanceCount; ++i) casterMasks_[i] |= 1u << c;
      }
    }
    if (cascadeHook_) cascadeHook_(cmd, static_cast<std::uint32_t>(std::countr_zero(nonEmpty)));
    beginLayer(cmd, 0, true);
    for (std::size_t i = 0; i < instanceCount; ++i) {
      std::uint32_t mask = casterMasks_[i];
      // One instanced draw per distinct LOD mesh among the cascades the caster is culled into.
      while (mask != 0) {
        const std::uint32_t first = static_cast<std::uint32_t>(std::countr_zero(mask));
        const std::uint32_t m = lodMesh(i, first);
        std::uint32_t same = 0;
        for (std::uint32_t c = first; c < frame.cascadeCount; ++c) {
          if ((mask & (1u << c)) != 0 && lodMesh(i, c) == m) {
            same |= 1u << c;
          }
        }
        drawCaster(static_cast<std::uint32_t>(i), m, same,
                   static_cast<std::uint32_t>(std::popcount(same)));
        mask &= ~same;
      }
    }
    endLayer(cmd);
  } else {
    for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
      if ((nonEmpty & (1u << c)) == 0) continue;
      if (cascadeHook_) cascadeHook_(cmd, c);
      beginLayer(cmd, c, false);
      bound = nullptr;
      if (visible) {
        for (std::uint32_t i : visible->visible[c]) drawCaster(i, lodMesh(i, c), c, 1);
      } else {
        for (std::size_t i = 0; i < instanceCount; ++i) {
          drawCaster(static_cast<std::uint32_t>(i), lodMesh(i, c), c, 1);
        }
      }
      endLayer(cmd);
    }
  }
  if (cascadeHook_ && nonEmpty != 0) cascadeHook_(cmd, kCascadeHookEnd);
  recordEnd(cmd);
  return {};
}

CascadeDrawContext ShadowRenderer::Impl::drawContext(VkCommandBuffer cmd, const CascadeFrame& frame,
                                                     std::uint32_t cascade,
                                                     const CullResult* visible) const {
  CascadeDrawContext ctx;
  ctx.cmd = cmd;
  ctx.cascade = cascade;
  ctx.visible = visible ? &visible->visible[cascade] : nullptr;
  ctx.pipelineLayout = pipelineLayout_;
  ctx.cameraPositionWs = frame.cameraPositionWs;
  ctx.frame = &frame;
  return ctx;
}

Status ShadowRenderer::Impl::recordShadowPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                                              const CascadeDrawCallback& draw,
                                              const CullResult* visible) {
  Status s = checkFrame(frame);
  if (!s.ok()) return s;
  if (cmd == VK_NULL_HANDLE) return Status(ErrorCode::kInvalidArgument, "cmd is VK_NULL_HANDLE");
  if (!draw) return Status(ErrorCode::kInvalidArgument, "draw callback is empty");
  if (options_.cache) {
    return Status(ErrorCode::kInvalidArgument,
                  "options.cache = true: use the caster-list form of recordShadowPass (the "
                  "cache draws scissored regions with the casters' bounds)");
  }
  if (windowed()) return recordWindowedCallbackPass(cmd, frame, draw, visible);
  recordBegin(cmd, frame);
  bool any = false;
  for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
    if (frame.cascades[c].empty) continue;
    if (cascadeHook_) cascadeHook_(cmd, c);
    any = true;
    beginLayer(cmd, c, false);
    draw(drawContext(cmd, frame, c, visible));
    endLayer(cmd);
  }
  if (cascadeHook_ && any) cascadeHook_(cmd, kCascadeHookEnd);
  recordEnd(cmd);
  return {};
}

}  // namespace csm::vk
