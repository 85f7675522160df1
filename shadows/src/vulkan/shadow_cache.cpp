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
#include "vk_util.hpp"

namespace csm::vk {

namespace {

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

/// The stages and accesses of a depth attachment (the depth pass's reads and writes).
constexpr VkPipelineStageFlags2 kDepthStages =
    VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
constexpr VkAccessFlags2 kDepthAccess =
    VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;

// Model -> a cached window's clip space (`Window`: ShadowRenderer::CacheWindow, a private type
// deduced here), drawn about the window's anchor: layer pixel x = world texel index - anchorX
// (before the block shift).
template <class Window>
glm::mat4 anchorTransform(const Window& w, std::int64_t res, const glm::dmat3& basisT,
                          const CasterInstance& inst) {
  const double half = 0.5 * double(res) * w.texel;
  const glm::dvec3 anchorLs(double(w.anchorX) * w.texel + half, double(w.anchorY) * w.texel + half,
                            0.0);
  const glm::dvec3 scale(1.0 / half, 1.0 / half, 1.0 / (w.zFar - w.zNear));
  const glm::dmat3 linear = basisT * glm::dmat3(inst.linearWs);
  // In light space about the anchor: subtract in double (both may be ~1e7 m).
  const glm::dvec3 t = basisT * inst.translationWs - anchorLs - glm::dvec3(0, 0, w.zNear);
  return scaledAffine(linear, t, scale);
}

// The layer rectangles (and their block shifts) of a world rectangle.
struct LayerRect {
  TexelRect world;
  std::int64_t mx, my;
  VkRect2D scissor;
};

// The layer rectangles of world rectangle `r` in a cached window (`Window`: CacheWindow).
template <class Window>
void split(const Window& w, std::int64_t res, const TexelRect& r, std::vector<LayerRect>& out) {
  out.clear();
  if (r.empty()) return;
  for (std::int64_t mx = floorDiv(r.x0 - w.anchorX, res); mx <= floorDiv(r.x1 - 1 - w.anchorX, res);
       ++mx) {
    for (std::int64_t my = floorDiv(r.y0 - w.anchorY, res);
         my <= floorDiv(r.y1 - 1 - w.anchorY, res); ++my) {
      const TexelRect block{w.anchorX + mx * res, w.anchorY + my * res, w.anchorX + (mx + 1) * res,
                            w.anchorY + (my + 1) * res};
      const TexelRect part = r.intersect(block);
      if (part.empty()) continue;
      LayerRect lr{part, mx, my, {}};
      lr.scissor.offset = {std::int32_t(part.x0 - block.x0), std::int32_t(part.y0 - block.y0)};
      lr.scissor.extent = {std::uint32_t(part.x1 - part.x0), std::uint32_t(part.y1 - part.y0)};
      out.push_back(lr);
    }
  }
}

/// Viewport and scissor of one layer rectangle: the viewport shifted by its block.
void setLayerRect(VkCommandBuffer cmd, const LayerRect& lr, std::int64_t res) {
  const VkViewport vp{-float(lr.mx * res), -float(lr.my * res), float(res), float(res), 0.0f, 1.0f};
  vkCmdSetViewport(cmd, 0, 1, &vp);
  vkCmdSetScissor(cmd, 0, 1, &lr.scissor);
}

/// What of a kept window's static layer is stale: the rows and columns newly exposed by the
/// box's move and what lies under invalidated boxes (`Window`: ShadowRenderer::CacheWindow).
template <class Window>
void exposedAndInvalidated(const Window& w, const TexelRect& box, std::int64_t res,
                           const std::vector<AabbWs>& invalidBoxes, const glm::dmat3& basisT,
                           std::vector<TexelRect>& dirty) {
  const TexelRect old{w.boxX, w.boxY, w.boxX + res, w.boxY + res};
  if (box.x0 < old.x0) dirty.push_back({box.x0, box.y0, std::min(old.x0, box.x1), box.y1});
  if (box.x1 > old.x1) dirty.push_back({std::max(old.x1, box.x0), box.y0, box.x1, box.y1});
  const std::int64_t ox0 = std::max(box.x0, old.x0), ox1 = std::min(box.x1, old.x1);
  if (box.y0 < old.y0) dirty.push_back({ox0, box.y0, ox1, std::min(old.y0, box.y1)});
  if (box.y1 > old.y1) dirty.push_back({ox0, std::max(old.y1, box.y0), ox1, box.y1});
  for (const AabbWs& b : invalidBoxes) {
    const TexelRect r = boxTexels(b, basisT, w.texel).intersect(box);
    if (!r.empty()) dirty.push_back(r);
  }
}

/// The debug label of a cascade's static or dynamic render pass.
std::string cascadeLabel(std::uint32_t cascade, const char* what) {
  return "csm cascade " + std::to_string(cascade) + " " + what;
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
    return vkError(result, what);
  };
  if (r != VK_SUCCESS) return fail(r, "vkCreateImage(csm static cache)");
  setName(handleBits(staticImage_), VK_OBJECT_TYPE_IMAGE, "csm static depth cache");
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
    setName(handleBits(staticViews_[i]), VK_OBJECT_TYPE_IMAGE_VIEW, name.c_str());
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

// The frame must carry the windows (applyCacheWindows before culling).
Status ShadowRenderer::checkCacheWindows(const CascadeFrame& frame) const {
  const glm::dmat3& basis = frame.lightBasisWs;
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
  return {};
}

// The cached pass's start: its label, the uniform block (write after the previous frame's
// reads), the static image after last frame's copies, and a new sampled image.
void ShadowRenderer::recordCachedBegin(VkCommandBuffer cmd, bool wasUndefined) {
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
  // The static image (DEPTH_ATTACHMENT_OPTIMAL between frames) after last frame's copies.
  img[1] = img[0];
  img[1].srcStageMask = kDepthStages | VK_PIPELINE_STAGE_2_COPY_BIT;
  img[1].srcAccessMask = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  img[1].oldLayout =
      staticInitialised_ ? VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED;
  img[1].newLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  img[1].image = staticImage_;
  img[1].dstStageMask = kDepthStages;
  img[1].dstAccessMask = kDepthAccess;
  if (!staticInitialised_) {
    for (CacheWindow& w : windows_) w.staticValid = false;
  }
  staticInitialised_ = true;
  recordPassStart(cmd, "csm shadow pass (cached)",
                  wasUndefined ? std::span<const VkImageMemoryBarrier2>(img, 2)
                               : std::span<const VkImageMemoryBarrier2>(img + 1, 1));
}

// Static layer `i` -> the sampled layer `i` (whole), leaving both as depth attachments.
void ShadowRenderer::recordStaticCopy(VkCommandBuffer cmd, std::uint32_t i) {
  VkImageMemoryBarrier2 b[2] = {
      vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2),
      vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2)};
  b[0].srcStageMask = kDepthStages;
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
  // Then: the sampled layer to the attachment (dynamic casters) and, at the end, to the
  // sampled layout; the static layer back to the attachment layout for the next frame.
  b[1].srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  b[1].srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  b[1].dstStageMask = kDepthStages;
  b[1].dstAccessMask = kDepthAccess;
  b[1].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  b[1].newLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  b[0].srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  b[0].srcAccessMask = VK_ACCESS_2_NONE;
  b[0].dstStageMask = kDepthStages;
  b[0].dstAccessMask = kDepthAccess;
  b[0].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  b[0].newLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  vkCmdPipelineBarrier2(cmd, &dep);
}

// The cached pass's end: layers written this frame -> the sampled layout.
void ShadowRenderer::recordCachedEnd(VkCommandBuffer cmd, std::uint32_t copiedMask) {
  // The others stayed sampleable.
  std::vector<VkImageMemoryBarrier2> toSampled;
  for (std::uint32_t i = 0; i < layerCount_; ++i) {
    if ((copiedMask & (1u << i)) == 0) continue;
    auto b = vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2);
    b.srcStageMask = kDepthStages;
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
}

Status ShadowRenderer::recordCachedPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                                        const CasterList& casters, const CullResult& visible) {
  const std::int64_t res = resolution_;
  const glm::dmat3& basis = frame.lightBasisWs;
  const glm::dmat3 basisT = glm::transpose(basis);
  Status s = checkCacheWindows(frame);
  if (!s.ok()) return s;

  const bool wasUndefined = countRecord();
  uniforms_ = packFrameUniforms(frame);
  uniforms_.wrappedLayers = 1u;  // toroidal addressing: csm.glsl adds each cascade's wrap offset
  std::array<TexelRect, kMaxCascades> boxes{};
  for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
    const Cascade& c = frame.cascades[i];
    if (c.empty) continue;
    const CacheWindow& w = windows_[i];
    const glm::dvec3 centerLs = basisT * c.boxCenterWs;
    const std::int64_t bx = std::llround(centerLs.x / w.texel) - res / 2;
    const std::int64_t by = std::llround(centerLs.y / w.texel) - res / 2;
    boxes[i] = {bx, by, bx + res, by + res};
    uniforms_.cascades[i].wrapOffset.x = float(floorMod(bx - w.anchorX, res));
    uniforms_.cascades[i].wrapOffset.y = float(floorMod(by - w.anchorY, res));
  }
  recordCachedBegin(cmd, wasUndefined);

  // Light-space texel rectangles of the casters drawn this frame (computed once per cascade).
  const std::size_t instanceCount = casters.instances.size();
  std::vector<TexelRect> casterRects;
  const MeshDraw* bound = nullptr;

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
      bindMeshBuffers(cmd, mesh, bound, layout_.indexType);
      const DepthPushPerLayer push{anchorTransform(w, res, basisT, inst), cascade};
      vkCmdPushConstants(cmd, pipelineLayout_, VK_SHADER_STAGE_VERTEX_BIT, 0, CSM_DEPTH_PUSH_SIZE,
                         &push);
      vkCmdDrawIndexed(cmd, mesh.indexCount, 1, mesh.firstIndex, mesh.vertexOffset, 0);
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
      exposedAndInvalidated(w, box, res, invalidBoxes_, basisT, dirty);
    }
    std::erase_if(dirty, [](const TexelRect& r) { return r.empty(); });
    const bool copy = !dirty.empty() || dynamicNow || w.dynamicLast;
    if (!copy) continue;  // the sampled layer already holds this frame's depth
    if (cascadeHook_) cascadeHook_(cmd, i);
    any = true;

    if (!dirty.empty()) {
      // Both images are DEPTH_ATTACHMENT_OPTIMAL while drawn (see recordStaticCopy).
      beginDepthRendering(cmd, staticViews_[i], 1, full, cascadeLabel(i, "static"), pipeline_);
      bound = nullptr;
      for (const TexelRect& r : dirty) {
        split(w, res, r, layerRects);
        for (const LayerRect& lr : layerRects) {
          setLayerRect(cmd, lr, res);
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
      endLayer(cmd);
    }
    w.staticValid = true;
    w.boxX = box.x0;
    w.boxY = box.y0;

    recordStaticCopy(cmd, i);
    st.copied = true;
    copiedMask |= 1u << i;
    if (dynamicNow) {
      beginDepthRendering(cmd, layerViews_[i], 1, false, cascadeLabel(i, "dynamic"), pipeline_);
      bound = nullptr;
      split(w, res, box, layerRects);
      for (const LayerRect& lr : layerRects) {
        setLayerRect(cmd, lr, res);
        st.dynamicTriangles += drawRect(i, w, list, true, lr);
      }
      endLayer(cmd);
    }
    w.dynamicLast = dynamicNow;
  }
  invalidBoxes_.clear();
  if (cascadeHook_ && any) cascadeHook_(cmd, kCascadeHookEnd);

  recordCachedEnd(cmd, copiedMask);
  return {};
}

}  // namespace csm::vk
