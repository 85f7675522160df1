// Cached cascades (RendererOptions::cache): static casters' depth kept per cascade across
// frames, only newly exposed / invalidated texels re-rendered, dynamic casters drawn every frame
// over a copy of it.
//
// Addressing. Texels are fixed in the world: a cascade's box starts at world texel index
// (boxX, boxY) of the light-space grid anchored at the world origin (the snapped box centre).
// World texel (i, j) lives at layer texel ((i - anchorX) mod R, (j - anchorY) mod R): toroidal,
// so a cascade that moves keeps every texel it still covers where it is and only the exposed
// rows/columns are drawn (scissored). The depth pass projects about the window's anchor (fixed
// while the window lives), and each block of R texels is drawn with the viewport shifted by a
// whole multiple of R, so a world texel is always rasterised with the same vertex positions,
// viewport and tile: whichever frame draws it, its depth is bit-identical.
//
// Depth window. The depth range is absolute in light space, quantised in quarters of the needed
// range and kept while it covers what the cascade needs (hysteresis), so stored depths stay
// valid as the camera moves; a new window (texel size, light direction, depth range, viewport
// range) re-renders the layer.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "csm/light_space.hpp"
#include "csm/vulkan/shadow_renderer.hpp"

namespace csm::vk {

namespace {

template <class T>
T vkInit(VkStructureType type, void* next = nullptr) {
  T value{};
  value.sType = type;
  value.pNext = next;
  return value;
}

std::string fmt(const char* format, auto... args) {
  char buf[512];
  std::snprintf(buf, sizeof(buf), format, args...);
  return buf;
}

struct DepthPush {
  glm::mat4 model;
  std::uint32_t cascadeOrMask;
};

/// A half-open rectangle of world texel indices.
struct TexelRect {
  std::int64_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  [[nodiscard]] bool empty() const noexcept { return x0 >= x1 || y0 >= y1; }
  [[nodiscard]] TexelRect intersect(const TexelRect& o) const noexcept {
    return {std::max(x0, o.x0), std::max(y0, o.y0), std::min(x1, o.x1), std::min(y1, o.y1)};
  }
  [[nodiscard]] std::uint64_t area() const noexcept {
    return empty() ? 0 : std::uint64_t(x1 - x0) * std::uint64_t(y1 - y0);
  }
};

std::int64_t floorDiv(std::int64_t a, std::int64_t b) noexcept {
  const std::int64_t q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

std::int64_t floorMod(std::int64_t a, std::int64_t b) noexcept {
  return a - floorDiv(a, b) * b;
}

/// The world texel rectangle a world box covers in a cascade (light-space grid about the
/// origin), widened by one texel each side (a caster covers a texel by its centre).
TexelRect boxTexels(const AabbWs& box, const glm::dmat3& basisT, double texel) noexcept {
  double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
  for (int k = 0; k < 8; ++k) {
    const glm::dvec3 p((k & 1) ? box.maxWs.x : box.minWs.x, (k & 2) ? box.maxWs.y : box.minWs.y,
                       (k & 4) ? box.maxWs.z : box.minWs.z);
    const glm::dvec3 q = basisT * p;
    for (int a = 0; a < 2; ++a) {
      lo[a] = std::min(lo[a], q[a]);
      hi[a] = std::max(hi[a], q[a]);
    }
  }
  auto toIndex = [&](double v) {
    return static_cast<std::int64_t>(std::clamp(std::floor(v / texel), -4e18, 4e18));
  };
  return {toIndex(lo[0]) - 1, toIndex(lo[1]) - 1, toIndex(hi[0]) + 2, toIndex(hi[1]) + 2};
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Windows

void ShadowRenderer::applyCacheWindows(CascadeFrame& frame) {
  if (!options_.cache || frame.resolution != resolution_) return;
  const std::int64_t res = resolution_;
  const glm::dmat3& basis = frame.lightBasisWs;
  const glm::dmat3 basisT = glm::transpose(basis);
  const float* bounds = properties_.limits.viewportBoundsRange;
  // Block m of the anchor-relative index space is drawn with the viewport at x = -m * R.
  auto blockOk = [&](std::int64_t u) {
    for (std::int64_t m : {floorDiv(u, res), floorDiv(u + res - 1, res)}) {
      const double x = -double(m) * double(res);
      if (x < double(bounds[0]) + 1.0 || x + double(res) > double(bounds[1]) - 1.0) return false;
    }
    return true;
  };
  for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
    Cascade& c = frame.cascades[i];
    if (c.empty) continue;
    CacheWindow& w = windows_[i];
    const double texel = c.texelSizeLs.x;
    const glm::dvec3 centerLs = basisT * c.boxCenterWs;
    const std::int64_t boxX = std::llround(centerLs.x / texel) - res / 2;
    const std::int64_t boxY = std::llround(centerLs.y / texel) - res / 2;
    const double needNear = centerLs.z + c.depthNearLs;
    const double needFar = centerLs.z + c.depthFarLs;
    const double needLen = needFar - needNear;
    const bool keep = w.valid && w.texel == texel && w.lightDirection == frame.lightDirectionWs &&
                      needNear >= w.zNear && needFar <= w.zFar &&
                      w.zFar - w.zNear <= 2.5 * needLen && blockOk(boxX - w.anchorX) &&
                      blockOk(boxY - w.anchorY);
    if (!keep) {
      w = CacheWindow{};
      w.valid = true;
      w.texel = texel;
      w.lightDirection = frame.lightDirectionWs;
      w.anchorX = boxX;
      w.anchorY = boxY;
      // World-anchored depth window: multiples of a quarter of the needed range, one quarter
      // of margin each side (the box centre's depth follows the camera).
      const double q = needLen * 0.25;
      w.zNear = std::floor(needNear / q) * q - q;
      w.zFar = std::ceil(needFar / q) * q + q;
    }
    c.depthNearLs = w.zNear - centerLs.z;
    c.depthFarLs = w.zFar - centerLs.z;
    c.viewProjCr = cameraRelativeViewProj(basis, frame.cameraPositionWs, c);
  }
}

Status ShadowRenderer::invalidate(const AabbWs& boxWs) {
  if (auto e = csm::validate(boxWs, "invalidate box")) {
    return Status(ErrorCode::kInvalidArgument, e->message());
  }
  if (options_.cache) invalidBoxes_.push_back(boxWs);
  return {};
}

void ShadowRenderer::invalidateAll() noexcept {
  for (CacheWindow& w : windows_) w.staticValid = false;
  invalidBoxes_.clear();
}

// ---------------------------------------------------------------------------------------------
// The static-depth image

Status ShadowRenderer::createStaticImage(const ShadowSettings& settings, VkFormat format) {
  VkDevice dev = device_.device;
  auto ci = vkInit<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
  ci.imageType = VK_IMAGE_TYPE_2D;
  ci.format = format;
  ci.extent = {settings.resolution, settings.resolution, 1};
  ci.mipLevels = 1;
  ci.arrayLayers = settings.cascadeCount;
  ci.samples = VK_SAMPLE_COUNT_1_BIT;
  ci.tiling = VK_IMAGE_TILING_OPTIMAL;
  ci.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  ci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  ci.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkResult r = vkCreateImage(dev, &ci, nullptr, &staticImage_);
  auto fail = [&](VkResult result, const char* what) {
    retireStaticImage();
    collectRetired(true);
    return Status(ErrorCode::kVulkan,
                  std::string(what) + " failed: VkResult " + std::to_string(result), result);
  };
  if (r != VK_SUCCESS) return fail(r, "vkCreateImage(csm static cache)");
  setName(std::uint64_t(staticImage_), VK_OBJECT_TYPE_IMAGE, "csm static depth cache");
  VkMemoryRequirements req{};
  vkGetImageMemoryRequirements(dev, staticImage_, &req);
  Status s = allocate(req, &staticMemory_, "csm static depth cache memory");
  if (!s.ok()) {
    retireStaticImage();
    collectRetired(true);
    return s;
  }
  cacheBytes_ = req.size;
  r = vkBindImageMemory(dev, staticImage_, staticMemory_, 0);
  if (r != VK_SUCCESS) return fail(r, "vkBindImageMemory(csm static cache)");
  auto vi = vkInit<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
  vi.image = staticImage_;
  vi.viewType = VK_IMAGE_VIEW_TYPE_2D;
  vi.format = format;
  for (std::uint32_t i = 0; i < settings.cascadeCount; ++i) {
    vi.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, i, 1};
    r = vkCreateImageView(dev, &vi, nullptr, &staticViews_[i]);
    if (r != VK_SUCCESS) return fail(r, "vkCreateImageView(csm static cache layer)");
    const std::string name = "csm static depth cache layer " + std::to_string(i);
    setName(std::uint64_t(staticViews_[i]), VK_OBJECT_TYPE_IMAGE_VIEW, name.c_str());
  }
  staticInitialised_ = false;
  return {};
}

void ShadowRenderer::retireStaticImage() noexcept {
  if (staticImage_ == VK_NULL_HANDLE && staticMemory_ == VK_NULL_HANDLE) return;
  Retired old;
  old.afterRecord = records_;
  old.image = staticImage_;
  old.memory = staticMemory_;
  std::copy(std::begin(staticViews_), std::end(staticViews_), old.views);
  retired_.push_back(old);
  staticImage_ = VK_NULL_HANDLE;
  staticMemory_ = VK_NULL_HANDLE;
  std::fill(std::begin(staticViews_), std::end(staticViews_), VK_NULL_HANDLE);
  cacheBytes_ = 0;
  staticInitialised_ = false;
}

// ---------------------------------------------------------------------------------------------
// The cached pass

Status ShadowRenderer::recordCachedPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                                        const CasterList& casters, const CullResult& visible) {
  const std::int64_t res = resolution_;
  const glm::dmat3& basis = frame.lightBasisWs;
  const glm::dmat3 basisT = glm::transpose(basis);
  // The frame must carry the windows (applyCacheWindows before culling).
  for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
    const Cascade& c = frame.cascades[i];
    if (c.empty) continue;
    const CacheWindow& w = windows_[i];
    const double centerZ = glm::dot(basis[2], c.boxCenterWs);
    const double tol = 1e-6 * std::max(1.0, std::abs(w.zFar - w.zNear));
    if (!w.valid || w.texel != c.texelSizeLs.x ||
        std::abs(centerZ + c.depthNearLs - w.zNear) > tol ||
        std::abs(centerZ + c.depthFarLs - w.zFar) > tol) {
      return Status(ErrorCode::kInvalidArgument,
                    fmt("frame.cascades[%u] has no cache window: call applyCacheWindows(frame) "
                        "before culling and recording (ShadowView does)",
                        i));
    }
  }

  ++records_;
  collectRetired(false);
  const bool wasUndefined = pendingClear_;
  pendingClear_ = false;
  uniformsCleared_ = true;
  uniforms_ = packUniforms(frame, settings_, uniformOptions_);
  uniforms_.counts.w = 1u;  // toroidal addressing: csm.glsl adds each cascade's wrap offset
  std::array<TexelRect, kMaxCascades> boxes{};
  for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
    const Cascade& c = frame.cascades[i];
    if (c.empty) continue;
    const CacheWindow& w = windows_[i];
    const glm::dvec3 centerLs = basisT * c.boxCenterWs;
    const std::int64_t bx = std::llround(centerLs.x / w.texel) - res / 2;
    const std::int64_t by = std::llround(centerLs.y / w.texel) - res / 2;
    boxes[i] = {bx, by, bx + res, by + res};
    uniforms_.cascades[i].wrapInfo.x = float(floorMod(bx - w.anchorX, res));
    uniforms_.cascades[i].wrapInfo.y = float(floorMod(by - w.anchorY, res));
  }
  if (beginLabel_) {
    auto label = vkInit<VkDebugUtilsLabelEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT);
    label.pLabelName = "csm shadow pass (cached)";
    label.color[2] = 0.8f;
    label.color[3] = 1.0f;
    beginLabel_(cmd, &label);
  }

  // Start: the uniform block (write after the previous frame's reads); the static image
  // (DEPTH_ATTACHMENT_OPTIMAL between frames) after last frame's copies; a new sampled image.
  const VkPipelineStageFlags2 readers =
      options_.consumerStages | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT;
  const VkPipelineStageFlags2 depthStages =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  const VkAccessFlags2 depthAccess = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
                                     VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  {
    auto toWrite = vkInit<VkBufferMemoryBarrier2>(VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2);
    toWrite.srcStageMask = readers;
    toWrite.dstStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
    toWrite.dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    toWrite.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    toWrite.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    toWrite.buffer = uniformBuffer_;
    toWrite.size = VK_WHOLE_SIZE;
    VkImageMemoryBarrier2 img[2] = {
        vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2),
        vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2)};
    // A new image not yet cleared: every layer is written below (new windows) or not sampled.
    img[0].srcStageMask = options_.consumerStages;
    img[0].dstStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
    img[0].dstAccessMask = VK_ACCESS_2_NONE;
    img[0].oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    img[0].newLayout = sampledLayout();
    img[0].srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    img[0].dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    img[0].image = image_;
    img[0].subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, layerCount_};
    img[1] = img[0];
    img[1].srcStageMask = depthStages | VK_PIPELINE_STAGE_2_COPY_BIT;
    img[1].srcAccessMask = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    img[1].oldLayout =
        staticInitialised_ ? VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED;
    img[1].newLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    img[1].image = staticImage_;
    img[1].dstStageMask = depthStages;
    img[1].dstAccessMask = depthAccess;
    if (!staticInitialised_) {
      for (CacheWindow& w : windows_) w.staticValid = false;
    }
    staticInitialised_ = true;
    auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
    dep.bufferMemoryBarrierCount = 1;
    dep.pBufferMemoryBarriers = &toWrite;
    dep.imageMemoryBarrierCount = wasUndefined ? 2 : 1;
    dep.pImageMemoryBarriers = wasUndefined ? img : img + 1;
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

  // Light-space texel rectangles of the casters drawn this frame (computed once per cascade).
  const std::size_t instanceCount = casters.instances.size();
  std::vector<TexelRect> casterRects;
  const MeshDraw* bound = nullptr;

  // Draws caster `index` in cascade `cascade` about the window's anchor: model -> the window's
  // clip space, where layer pixel x = world texel index - anchorX (before the block shift).
  auto anchorTransform = [&](const CacheWindow& w, const CasterInstance& inst) {
    const double half = 0.5 * double(res) * w.texel;
    const glm::dvec3 anchorLs(double(w.anchorX) * w.texel + half,
                              double(w.anchorY) * w.texel + half, 0.0);
    const glm::dvec3 scale(1.0 / half, 1.0 / half, 1.0 / (w.zFar - w.zNear));
    const glm::dmat3 linear = basisT * glm::dmat3(inst.linearWs);
    // In light space about the anchor: subtract in double (both may be ~1e7 m).
    const glm::dvec3 t = basisT * inst.translationWs - anchorLs - glm::dvec3(0, 0, w.zNear);
    glm::mat4 m(0.0f);
    for (int col = 0; col < 3; ++col) {
      for (int row = 0; row < 3; ++row) {
        m[col][row] = static_cast<float>(linear[col][row] * scale[row]);
      }
    }
    for (int row = 0; row < 3; ++row) m[3][row] = static_cast<float>(t[row] * scale[row]);
    m[3][3] = 1.0f;
    return m;
  };

  // The layer rectangles (and their block shifts) of a world rectangle.
  struct LayerRect {
    TexelRect world;
    std::int64_t mx, my;
    VkRect2D scissor;
  };
  auto split = [&](const CacheWindow& w, const TexelRect& r, std::vector<LayerRect>& out) {
    out.clear();
    if (r.empty()) return;
    for (std::int64_t mx = floorDiv(r.x0 - w.anchorX, res);
         mx <= floorDiv(r.x1 - 1 - w.anchorX, res); ++mx) {
      for (std::int64_t my = floorDiv(r.y0 - w.anchorY, res);
           my <= floorDiv(r.y1 - 1 - w.anchorY, res); ++my) {
        const TexelRect block{w.anchorX + mx * res, w.anchorY + my * res,
                              w.anchorX + (mx + 1) * res, w.anchorY + (my + 1) * res};
        const TexelRect part = r.intersect(block);
        if (part.empty()) continue;
        LayerRect lr{part, mx, my, {}};
        lr.scissor.offset = {std::int32_t(part.x0 - block.x0), std::int32_t(part.y0 - block.y0)};
        lr.scissor.extent = {std::uint32_t(part.x1 - part.x0), std::uint32_t(part.y1 - part.y0)};
        out.push_back(lr);
      }
    }
  };

  auto beginPass = [&](VkImageView view, bool clear, const char* what, std::uint32_t cascade) {
    // Both images are DEPTH_ATTACHMENT_OPTIMAL while drawn (see the barriers around the copy).
    if (beginLabel_) {
      const std::string name = std::string("csm cascade ") + std::to_string(cascade) + " " + what;
      auto label = vkInit<VkDebugUtilsLabelEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT);
      label.pLabelName = name.c_str();
      beginLabel_(cmd, &label);
    }
    auto depth = vkInit<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
    depth.imageView = view;
    depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    depth.loadOp = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
    depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    depth.clearValue.depthStencil = {1.0f, 0};
    auto ri = vkInit<VkRenderingInfo>(VK_STRUCTURE_TYPE_RENDERING_INFO);
    ri.renderArea = {{0, 0}, {resolution_, resolution_}};
    ri.layerCount = 1;
    ri.pDepthAttachment = &depth;
    vkCmdBeginRendering(cmd, &ri);
    vkCmdSetDepthBias(cmd, settings_.depthBiasConstant, 0.0f, settings_.depthBiasSlope);
    vkCmdSetCullMode(cmd, options_.cullMode);
    vkCmdSetFrontFace(cmd, options_.frontFace);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelineLayout_, 0, 1, &depthSet_,
                            0, nullptr);
    bound = nullptr;
  };
  auto endPass = [&] {
    vkCmdEndRendering(cmd);
    if (endLabel_) endLabel_(cmd);
  };
  auto setRect = [&](const LayerRect& lr) {
    const VkViewport vp{
        -float(lr.mx * res), -float(lr.my * res), float(res), float(res), 0.0f, 1.0f};
    vkCmdSetViewport(cmd, 0, 1, &vp);
    vkCmdSetScissor(cmd, 0, 1, &lr.scissor);
  };
  // Draws the casters of `list` with dynamic == `dynamic` that overlap `lr`; returns triangles.
  auto drawRect = [&](std::uint32_t cascade, const CacheWindow& w,
                      const std::vector<std::uint32_t>& list, bool dynamic, const LayerRect& lr) {
    std::uint64_t triangles = 0;
    const std::uint32_t schedule = options_.cascadeLod[cascade];
    for (std::uint32_t idx : list) {
      const CasterInstance& inst = casters.instances[idx];
      if (inst.dynamic != dynamic) continue;
      if (casterRects[idx].intersect(lr.world).empty()) continue;
      // The LOD of the uncached pass: the schedule and the texel error budget.
      const MeshDraw& mesh = casters.meshes[inst.meshForLod(
          casterLod(inst, schedule, w.texel, options_.lodMaxErrorTexels))];
      if (mesh.indexCount == 0) continue;
      if (bound == nullptr || bound->vertexBuffer != mesh.vertexBuffer ||
          bound->vertexBufferOffset != mesh.vertexBufferOffset) {
        vkCmdBindVertexBuffers(cmd, 0, 1, &mesh.vertexBuffer, &mesh.vertexBufferOffset);
      }
      if (bound == nullptr || bound->indexBuffer != mesh.indexBuffer ||
          bound->indexBufferOffset != mesh.indexBufferOffset) {
        vkCmdBindIndexBuffer(cmd, mesh.indexBuffer, mesh.indexBufferOffset, layout_.indexType);
      }
      bound = &mesh;
      const DepthPush push{anchorTransform(w, inst), cascade};
      vkCmdPushConstants(cmd, pipelineLayout_, VK_SHADER_STAGE_VERTEX_BIT, 0, CSM_DEPTH_PUSH_SIZE,
                         &push);
      drawIndexedCaster(cmd, inst, mesh, 1);
      triangles += mesh.indexCount / 3;
    }
    return triangles;
  };

  std::vector<TexelRect> dirty;
  std::vector<LayerRect> layerRects;
  bool any = false;
  std::uint32_t copiedMask = 0;
  cacheStats_ = {};
  if (casterRects.size() < instanceCount) casterRects.resize(instanceCount);
  for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
    const Cascade& c = frame.cascades[i];
    if (c.empty) continue;
    CacheWindow& w = windows_[i];
    CascadeCacheStats& st = cacheStats_[i];
    const TexelRect box = boxes[i];
    const std::vector<std::uint32_t>& list = visible.visible[i];
    bool dynamicNow = false;
    for (std::uint32_t idx : list) {
      casterRects[idx] = boxTexels(casters.boundsWs[idx], basisT, w.texel);
      dynamicNow = dynamicNow || casters.instances[idx].dynamic;
    }

    // What of the static layer is stale: everything (new window), the newly exposed rows and
    // columns, and what lies under invalidated boxes.
    dirty.clear();
    const bool full = !w.staticValid;
    if (full) {
      dirty.push_back(box);
      st.newWindow = true;
    } else {
      const TexelRect old{w.boxX, w.boxY, w.boxX + res, w.boxY + res};
      if (box.x0 < old.x0) dirty.push_back({box.x0, box.y0, std::min(old.x0, box.x1), box.y1});
      if (box.x1 > old.x1) dirty.push_back({std::max(old.x1, box.x0), box.y0, box.x1, box.y1});
      const std::int64_t ox0 = std::max(box.x0, old.x0), ox1 = std::min(box.x1, old.x1);
      if (box.y0 < old.y0) dirty.push_back({ox0, box.y0, ox1, std::min(old.y0, box.y1)});
      if (box.y1 > old.y1) dirty.push_back({ox0, std::max(old.y1, box.y0), ox1, box.y1});
      for (const AabbWs& b : invalidBoxes_) {
        const TexelRect r = boxTexels(b, basisT, w.texel).intersect(box);
        if (!r.empty()) dirty.push_back(r);
      }
    }
    std::erase_if(dirty, [](const TexelRect& r) { return r.empty(); });
    const bool copy = !dirty.empty() || dynamicNow || w.dynamicLast;
    if (!copy) continue;  // the sampled layer already holds this frame's depth
    if (cascadeHook_) cascadeHook_(cmd, i);
    any = true;

    if (!dirty.empty()) {
      beginPass(staticViews_[i], full, "static", i);
      for (const TexelRect& r : dirty) {
        split(w, r, layerRects);
        for (const LayerRect& lr : layerRects) {
          setRect(lr);
          if (!full) {
            VkClearAttachment ca{VK_IMAGE_ASPECT_DEPTH_BIT, 0, {}};
            ca.clearValue.depthStencil = {1.0f, 0};
            const VkClearRect cr{lr.scissor, 0, 1};
            vkCmdClearAttachments(cmd, 1, &ca, 1, &cr);
          }
          st.staticTexels += lr.world.area();
          st.staticTriangles += drawRect(i, w, list, false, lr);
        }
      }
      endPass();
    }
    w.staticValid = true;
    w.boxX = box.x0;
    w.boxY = box.y0;

    // Static layer -> sampled layer, then the dynamic casters over it.
    VkImageMemoryBarrier2 b[2] = {
        vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2),
        vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2)};
    b[0].srcStageMask = depthStages;
    b[0].srcAccessMask = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    b[0].dstStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
    b[0].dstAccessMask = VK_ACCESS_2_TRANSFER_READ_BIT;
    b[0].oldLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    b[0].newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    b[0].srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b[0].dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b[0].image = staticImage_;
    b[0].subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, i, 1};
    // The sampled layer: last frame's readers finish before the copy overwrites it.
    b[1] = b[0];
    b[1].image = image_;
    b[1].srcStageMask = options_.consumerStages;
    b[1].srcAccessMask = VK_ACCESS_2_NONE;
    b[1].dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    b[1].oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;  // overwritten whole by the copy
    b[1].newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
    dep.imageMemoryBarrierCount = 2;
    dep.pImageMemoryBarriers = b;
    vkCmdPipelineBarrier2(cmd, &dep);
    VkImageCopy region{};
    region.srcSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, i, 1};
    region.dstSubresource = region.srcSubresource;
    region.extent = {resolution_, resolution_, 1};
    vkCmdCopyImage(cmd, staticImage_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, image_,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    st.copied = true;
    // Then: the sampled layer to the attachment (dynamic casters) and, at the end, to the
    // sampled layout; the static layer back to the attachment layout for the next frame.
    b[1].srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
    b[1].srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    b[1].dstStageMask = depthStages;
    b[1].dstAccessMask = depthAccess;
    b[1].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    b[1].newLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    b[0].srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
    b[0].srcAccessMask = VK_ACCESS_2_NONE;
    b[0].dstStageMask = depthStages;
    b[0].dstAccessMask = depthAccess;
    b[0].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    b[0].newLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    vkCmdPipelineBarrier2(cmd, &dep);
    copiedMask |= 1u << i;
    if (dynamicNow) {
      beginPass(layerViews_[i], false, "dynamic", i);
      split(w, box, layerRects);
      for (const LayerRect& lr : layerRects) {
        setRect(lr);
        st.dynamicTriangles += drawRect(i, w, list, true, lr);
      }
      endPass();
    }
    w.dynamicLast = dynamicNow;
  }
  invalidBoxes_.clear();
  if (cascadeHook_ && any) cascadeHook_(cmd, kCascadeHookEnd);

  // Layers written this frame -> the sampled layout; the others stayed sampleable.
  std::vector<VkImageMemoryBarrier2> toSampled;
  for (std::uint32_t i = 0; i < layerCount_; ++i) {
    if ((copiedMask & (1u << i)) == 0) continue;
    auto b = vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2);
    b.srcStageMask = depthStages;
    b.srcAccessMask = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    b.dstStageMask = options_.consumerStages;
    b.dstAccessMask = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
    b.oldLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    b.newLayout = sampledLayout();
    b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = image_;
    b.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, i, 1};
    toSampled.push_back(b);
  }
  auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.imageMemoryBarrierCount = static_cast<std::uint32_t>(toSampled.size());
  dep.pImageMemoryBarriers = toSampled.data();
  if (!toSampled.empty()) vkCmdPipelineBarrier2(cmd, &dep);
  if (endLabel_) endLabel_(cmd);
  return {};
}

}  // namespace csm::vk
