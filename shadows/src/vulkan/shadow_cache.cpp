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

/// The stale parts of a static layer that holds box `old` (when `valid`) for box `box`: the
/// newly exposed rows and columns and what lies under the `pending` boxes. The whole box when
/// the layer is not valid or the parts add up to a layer or more (one full render is then no
/// dearer). Returns whether it is the whole box.
bool staleRects(bool valid, const TexelRect& old, const TexelRect& box,
                const std::vector<AabbWs>& pending, const glm::dmat3& basisT, double texel,
                std::vector<TexelRect>& out) {
  out.clear();
  if (valid) {
    if (box.x0 < old.x0) out.push_back({box.x0, box.y0, std::min(old.x0, box.x1), box.y1});
    if (box.x1 > old.x1) out.push_back({std::max(old.x1, box.x0), box.y0, box.x1, box.y1});
    const std::int64_t ox0 = std::max(box.x0, old.x0), ox1 = std::min(box.x1, old.x1);
    if (box.y0 < old.y0) out.push_back({ox0, box.y0, ox1, std::min(old.y0, box.y1)});
    if (box.y1 > old.y1) out.push_back({ox0, std::max(old.y1, box.y0), ox1, box.y1});
    for (const AabbWs& b : pending) {
      const TexelRect r = boxTexels(b, basisT, texel).intersect(box);
      if (!r.empty()) out.push_back(r);
    }
    std::erase_if(out, [](const TexelRect& r) { return r.empty(); });
    std::uint64_t sum = 0;
    for (const TexelRect& r : out) sum += r.area();
    if (sum < box.area()) return false;
  }
  out.assign(1, box);
  return true;
}

/// Adds the part of `r` that `rects` does not cover yet, as disjoint rectangles.
void addDisjoint(std::vector<TexelRect>& rects, const TexelRect& r) {
  std::vector<TexelRect> todo{r}, next;
  for (const TexelRect& p : rects) {
    next.clear();
    for (const TexelRect& t : todo) {
      const TexelRect o = t.intersect(p);
      if (o.empty()) {
        next.push_back(t);
        continue;
      }
      // t minus o: the rows above and below o, then the columns beside it.
      if (t.y0 < o.y0) next.push_back({t.x0, t.y0, t.x1, o.y0});
      if (o.y1 < t.y1) next.push_back({t.x0, o.y1, t.x1, t.y1});
      if (t.x0 < o.x0) next.push_back({t.x0, o.y0, o.x0, o.y1});
      if (o.x1 < t.x1) next.push_back({o.x1, o.y0, t.x1, o.y1});
    }
    std::swap(todo, next);
    if (todo.empty()) return;
  }
  rects.insert(rects.end(), todo.begin(), todo.end());
}

std::uint64_t totalArea(const std::vector<TexelRect>& rects) noexcept {
  std::uint64_t sum = 0;
  for (const TexelRect& r : rects) sum += r.area();
  return sum;
}

}  // namespace

Status ShadowRenderer::checkCacheOptions(const ShadowSettings& settings,
                                         const RendererOptions& options) {
  const std::uint64_t layer = std::uint64_t(settings.resolution) * settings.resolution;
  if (options.cacheBudgetTexels != 0 && options.cacheBudgetTexels < layer) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("options.cacheBudgetTexels = %llu is invalid: allowed 0 (no cap) or at "
                      "least one layer, settings.resolution^2 = %llu",
                      static_cast<unsigned long long>(options.cacheBudgetTexels),
                      static_cast<unsigned long long>(layer)));
  }
  if (options.cacheExactCascades < 1 || options.cacheExactCascades > kMaxCascades) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("options.cacheExactCascades = %u is invalid: allowed [1, %u]",
                      options.cacheExactCascades, kMaxCascades));
  }
  return {};
}

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
  std::array<bool, kMaxCascades> covered{};
  std::vector<TexelRect> stale;
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
    // What the layer shows covers this frame's slice: its box holds the box the slice needs
    // (the sphere, across a change of light), its depth window the sphere.
    CacheShown& sh = shown_[i];
    if (sh.valid) {
      const glm::dmat3 shownT = glm::transpose(sh.basis);
      const glm::dvec3 shownCenter = shownT * sh.cascade.boxCenterWs;
      const glm::dvec3 sphere = shownT * c.sphereCenterWs;
      const bool sameLight = sh.basis == basis;
      const glm::dvec3 needCenter = sameLight ? centerLs : sphere;
      const double needHalf = sameLight && c.neededHalfExtentM > 0.0
                                  ? std::min(c.neededHalfExtentM, c.halfExtentLs.x)
                                  : (sameLight ? c.halfExtentLs.x : c.sphereRadiusM);
      const double half = sh.cascade.halfExtentLs.x;
      covered[i] = std::abs(needCenter.x - shownCenter.x) + needHalf <= half &&
                   std::abs(needCenter.y - shownCenter.y) + needHalf <= half &&
                   sphere.z - c.sphereRadiusM >= sh.window.zNear &&
                   sphere.z + c.sphereRadiusM <= sh.window.zFar;
    }
    c.depthNearLs = w.zNear - centerLs.z;
    c.depthFarLs = w.zFar - centerLs.z;
    c.viewProjCr = cameraRelativeViewProj(basis, frame.cameraPositionWs, c);
    staleRects(w.staticValid, {w.boxX, w.boxY, w.boxX + res, w.boxY + res},
               {boxX, boxY, boxX + res, boxY + res}, w.pending, basisT, texel, stale);
    sh.wanted = totalArea(stale);
  }

  // The budget: the exact cascades, and those never shown, are refreshed whatever they cost;
  // the others in order of staleness while their refresh fits what is left of the budget. A
  // deferred cascade shows its last refresh.
  const std::uint64_t budget = options_.cacheBudgetTexels;
  std::vector<std::uint32_t> order;
  auto refresh = [&](std::uint32_t i) {
    CacheShown& sh = shown_[i];
    sh.valid = true;
    sh.deferred = false;
    sh.lag = 0;
    sh.window = windows_[i];
    sh.window.pending.clear();
    sh.cascade = frame.cascades[i];
    sh.basis = basis;
  };
  for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
    if (frame.cascades[i].empty) continue;
    if (budget == 0 || i < options_.cacheExactCascades || !shown_[i].valid) {
      refresh(i);
    } else {
      order.push_back(i);
    }
  }
  // The most stale first: frames of lag, one more for a cascade whose box no longer covers its
  // slice (it shows a lit fringe), so that it goes first among equals but cannot starve a
  // cascade that lags longer.
  auto staleness = [&](std::uint32_t i) { return shown_[i].lag + (covered[i] ? 0u : 1u); };
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    if (staleness(a) != staleness(b)) return staleness(a) > staleness(b);
    return !covered[a] && covered[b];
  });
  std::uint64_t left = budget;
  for (std::uint32_t i : order) {
    CacheShown& sh = shown_[i];
    if (sh.wanted <= left) {
      left -= sh.wanted;
      refresh(i);
      continue;
    }
    sh.deferred = true;
    ++sh.lag;
    Cascade& c = frame.cascades[i];
    c = sh.cascade;
    c.viewProjCr = cameraRelativeViewProj(sh.basis, frame.cameraPositionWs, c);
  }
}

Status ShadowRenderer::invalidate(const AabbWs& boxWs) {
  if (auto e = csm::validate(boxWs, "invalidate box")) {
    return Status(ErrorCode::kInvalidArgument, e->message());
  }
  if (!options_.cache) return {};
  for (CacheWindow& w : windows_) {
    if (!w.staticValid) continue;  // re-rendered whole anyway
    if (w.pending.size() >= 64) {
      w.staticValid = false;  // many boxes: one full render
      w.pending.clear();
    } else {
      w.pending.push_back(boxWs);
    }
  }
  return {};
}

void ShadowRenderer::invalidateAll() noexcept {
  for (CacheWindow& w : windows_) {
    w.staticValid = false;
    w.pending.clear();
  }
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
  // The frame must carry the windows (applyCacheWindows before culling). Each cascade is drawn
  // in the window and light basis its layer shows (shown_: this frame's unless deferred).
  for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
    const Cascade& c = frame.cascades[i];
    if (c.empty) continue;
    const CacheWindow& w = shown_[i].window;
    const double centerZ = glm::dot(shown_[i].basis[2], c.boxCenterWs);
    const double tol = 1e-6 * std::max(1.0, std::abs(w.zFar - w.zNear));
    if (!shown_[i].valid || !w.valid || w.texel != c.texelSizeLs.x ||
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
    const CacheWindow& w = shown_[i].window;
    if (shown_[i].basis != frame.lightBasisWs) {
      // Deferred across a change of light: its world-grid origin in the basis it shows.
      CascadeFrame old = frame;
      old.lightBasisWs = shown_[i].basis;
      uniforms_.cascades[i].depthInfo =
          packUniforms(old, settings_, uniformOptions_).cascades[i].depthInfo;
    }
    const glm::dvec3 centerLs = glm::transpose(shown_[i].basis) * c.boxCenterWs;
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
  glm::dmat3 basisT(1.0);  // the light basis (transposed) of the cascade being drawn

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

  auto layerTexels = [](const LayerRect& lr) {
    return TexelRect{lr.scissor.offset.x, lr.scissor.offset.y,
                     lr.scissor.offset.x + std::int64_t(lr.scissor.extent.width),
                     lr.scissor.offset.y + std::int64_t(lr.scissor.extent.height)};
  };
  std::vector<TexelRect> copyParts;
  std::vector<VkImageCopy> copyRegions;
  std::vector<LayerRect> redrawParts;
  std::vector<LayerRect> staticPieces;

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
  // Draws caster `idx` (at the LOD of the uncached pass: the schedule and the texel error
  // budget) under the current viewport and scissor; returns its triangles.
  auto drawCaster = [&](std::uint32_t cascade, const CacheWindow& w, std::uint32_t idx) {
    const CasterInstance& inst = casters.instances[idx];
    const MeshDraw& mesh = casters.meshes[inst.meshForLod(
        casterLod(inst, options_.cascadeLod[cascade], w.texel, options_.lodMaxErrorTexels))];
    if (mesh.indexCount == 0) return std::uint64_t(0);
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
    return std::uint64_t(mesh.indexCount / 3);
  };
  // Draws the casters of `list` with dynamic == `dynamic` that overlap `lr`; returns triangles.
  auto drawRect = [&](std::uint32_t cascade, const CacheWindow& w,
                      const std::vector<std::uint32_t>& list, bool dynamic, const LayerRect& lr) {
    std::uint64_t triangles = 0;
    for (std::uint32_t idx : list) {
      if (casters.instances[idx].dynamic != dynamic) continue;
      if (casterRects[idx].intersect(lr.world).empty()) continue;
      triangles += drawCaster(cascade, w, idx);
    }
    return triangles;
  };
  // Draws the static casters of `list` over the stale rectangles `pieces` (already cleared). A
  // caster over several pieces of one block (an L-shaped exposure, a strip and a box) is drawn
  // once, scissored to the bounding rectangle of its parts, when that rectangle is no larger
  // than the parts together: drawing it over texels that are valid leaves them bit-identical
  // (they already hold the minimum over every static caster, this one included). Otherwise
  // once per piece. Returns triangles; counts the draws saved in `saved`.
  struct Hit {
    std::size_t piece;
    TexelRect part;
    bool done;
  };
  std::vector<Hit> hits;
  auto drawPieces = [&](std::uint32_t cascade, const CacheWindow& w,
                        const std::vector<std::uint32_t>& list,
                        const std::vector<LayerRect>& pieces, std::uint64_t& saved) {
    std::uint64_t triangles = 0;
    for (std::uint32_t idx : list) {
      if (casters.instances[idx].dynamic) continue;
      hits.clear();
      for (std::size_t k = 0; k < pieces.size(); ++k) {
        const TexelRect q = casterRects[idx].intersect(pieces[k].world);
        if (!q.empty()) hits.push_back({k, q, false});
      }
      for (std::size_t h = 0; h < hits.size(); ++h) {
        if (hits[h].done) continue;  // drawn with an earlier hit of its block
        const LayerRect& first = pieces[hits[h].piece];
        // This hit and the later ones of the same block (same viewport).
        TexelRect u = hits[h].part;
        std::uint64_t sum = u.area();
        std::size_t n = 1;
        for (std::size_t g = h + 1; g < hits.size(); ++g) {
          const LayerRect& other = pieces[hits[g].piece];
          if (other.mx != first.mx || other.my != first.my) continue;
          const TexelRect& q = hits[g].part;
          u = {std::min(u.x0, q.x0), std::min(u.y0, q.y0), std::max(u.x1, q.x1),
               std::max(u.y1, q.y1)};
          sum += q.area();
          ++n;
        }
        if (n > 1 && u.area() <= sum) {
          LayerRect merged = first;
          merged.world = u;
          merged.scissor.offset = {std::int32_t(first.scissor.offset.x + (u.x0 - first.world.x0)),
                                   std::int32_t(first.scissor.offset.y + (u.y0 - first.world.y0))};
          merged.scissor.extent = {std::uint32_t(u.x1 - u.x0), std::uint32_t(u.y1 - u.y0)};
          setRect(merged);
          triangles += drawCaster(cascade, w, idx);
          saved += n - 1;
          for (std::size_t g = h + 1; g < hits.size(); ++g) {
            const LayerRect& other = pieces[hits[g].piece];
            if (other.mx == first.mx && other.my == first.my) hits[g].done = true;
          }
          continue;
        }
        setRect(first);
        triangles += drawCaster(cascade, w, idx);
      }
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
    CacheWindow& w = windows_[i];        // the static layer's state
    CacheShown& sh = shown_[i];          // what the sampled layer shows (drawn in its window)
    const CacheWindow& win = sh.window;  // = w's window unless deferred
    basisT = glm::transpose(sh.basis);
    CascadeCacheStats& st = cacheStats_[i];
    st.deferred = sh.deferred;
    st.lagFrames = sh.lag;
    st.wantedTexels = sh.wanted;
    const TexelRect box = boxes[i];
    const std::vector<std::uint32_t>& list = visible.visible[i];
    bool dynamicNow = false;
    for (std::uint32_t idx : list) {
      casterRects[idx] = boxTexels(casters.boundsWs[idx], basisT, win.texel);
      dynamicNow = dynamicNow || casters.instances[idx].dynamic;
    }

    // What of the static layer is stale: everything (new window), the newly exposed rows and
    // columns, and what lies under invalidated boxes. A deferred cascade draws none of it.
    dirty.clear();
    bool full = false;
    if (!sh.deferred) {
      full = staleRects(w.staticValid, {w.boxX, w.boxY, w.boxX + res, w.boxY + res}, box, w.pending,
                        basisT, w.texel, dirty);
      st.newWindow = !w.staticValid;
    }
    const bool copy = !dirty.empty() || dynamicNow || sh.dynamicLast;
    if (!sh.deferred) {
      w.staticValid = true;
      w.boxX = box.x0;
      w.boxY = box.y0;
      w.pending.clear();
    }
    if (!copy) continue;  // the sampled layer already holds this frame's depth
    if (cascadeHook_) cascadeHook_(cmd, i);
    any = true;

    if (!dirty.empty()) {
      beginPass(staticViews_[i], full, "static", i);
      staticPieces.clear();
      for (const TexelRect& r : dirty) {
        split(win, r, layerRects);
        for (const LayerRect& lr : layerRects) {
          if (!full) {
            VkClearAttachment ca{VK_IMAGE_ASPECT_DEPTH_BIT, 0, {}};
            ca.clearValue.depthStencil = {1.0f, 0};
            const VkClearRect cr{lr.scissor, 0, 1};
            vkCmdClearAttachments(cmd, 1, &ca, 1, &cr);
          }
          st.staticTexels += lr.world.area();
          staticPieces.push_back(lr);
        }
      }
      st.staticTriangles += drawPieces(i, win, list, staticPieces, st.mergedDraws);
      endPass();
    }

    // Static layer -> sampled layer, then the dynamic casters over it. The sampled layer holds
    // the static depth except where it was re-rendered this frame and where dynamic casters were
    // drawn last time: only those rectangles are restored, copied (kCopyRects) or cleared and
    // redrawn with the static casters (kRedraw); the whole layer is copied on a full render, when
    // they are most of it, or with kWholeLayer.
    copyParts.clear();
    redrawParts.clear();
    bool whole = full || options_.cacheRestore == CacheRestore::kWholeLayer;
    if (!whole) {
      for (const TexelRect& r : dirty) {
        split(win, r, layerRects);
        for (const LayerRect& lr : layerRects) addDisjoint(copyParts, layerTexels(lr));
      }
      for (const auto& d : sh.dynamicRects) addDisjoint(copyParts, {d[0], d[1], d[2], d[3]});
      whole = copyParts.size() > 256 || totalArea(copyParts) * 4 >= 3 * std::uint64_t(res * res);
    }
    if (whole) copyParts.assign(1, TexelRect{0, 0, res, res});
    if (!whole && options_.cacheRestore == CacheRestore::kRedraw) {
      // The restored rectangles, with the block each lies in (as the box's own split).
      split(win, box, layerRects);
      for (const TexelRect& p : copyParts) {
        for (const LayerRect& lr : layerRects) {
          const TexelRect q = p.intersect(layerTexels(lr));
          if (q.empty()) continue;
          const std::int64_t dx = lr.world.x0 - lr.scissor.offset.x;
          const std::int64_t dy = lr.world.y0 - lr.scissor.offset.y;
          LayerRect r{{q.x0 + dx, q.y0 + dy, q.x1 + dx, q.y1 + dy}, lr.mx, lr.my, {}};
          r.scissor.offset = {std::int32_t(q.x0), std::int32_t(q.y0)};
          r.scissor.extent = {std::uint32_t(q.x1 - q.x0), std::uint32_t(q.y1 - q.y0)};
          redrawParts.push_back(r);
          st.restoredTexels += q.area();
        }
      }
      copyParts.clear();
    }
    copyRegions.clear();
    for (const TexelRect& r : copyParts) {
      VkImageCopy region{};
      region.srcSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, i, 1};
      region.dstSubresource = region.srcSubresource;
      region.srcOffset = {std::int32_t(r.x0), std::int32_t(r.y0), 0};
      region.dstOffset = region.srcOffset;
      region.extent = {std::uint32_t(r.x1 - r.x0), std::uint32_t(r.y1 - r.y0), 1};
      copyRegions.push_back(region);
      st.restoredTexels += r.area();
    }
    // The rectangles this frame's dynamic casters cover (copied back next time).
    sh.dynamicRects.clear();
    if (dynamicNow) {
      std::vector<TexelRect> parts;
      for (std::uint32_t idx : list) {
        if (!casters.instances[idx].dynamic) continue;
        split(win, casterRects[idx].intersect(box), layerRects);
        for (const LayerRect& lr : layerRects) {
          if (parts.size() >= 64) {  // many casters: their bounding rectangle
            TexelRect& u = parts[0];
            const TexelRect t = layerTexels(lr);
            u = {std::min(u.x0, t.x0), std::min(u.y0, t.y0), std::max(u.x1, t.x1),
                 std::max(u.y1, t.y1)};
            parts.resize(1);
          } else {
            parts.push_back(layerTexels(lr));
          }
        }
      }
      for (const TexelRect& t : parts) {
        sh.dynamicRects.push_back(
            {std::int32_t(t.x0), std::int32_t(t.y0), std::int32_t(t.x1), std::int32_t(t.y1)});
      }
    }
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
    // Overwritten whole by the copy, else kept where not copied (sampled since last frame).
    b[1].oldLayout = whole ? VK_IMAGE_LAYOUT_UNDEFINED : sampledLayout();
    b[1].newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
    dep.imageMemoryBarrierCount = 2;
    dep.pImageMemoryBarriers = b;
    if (copyRegions.empty()) {
      // Nothing to restore (dynamic casters appear): the layer straight to the attachment.
      b[1].dstStageMask = depthStages;
      b[1].dstAccessMask = depthAccess;
      b[1].newLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
      dep.imageMemoryBarrierCount = 1;
      dep.pImageMemoryBarriers = b + 1;
      vkCmdPipelineBarrier2(cmd, &dep);
    } else {
      vkCmdPipelineBarrier2(cmd, &dep);
      vkCmdCopyImage(cmd, staticImage_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, image_,
                     VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                     static_cast<std::uint32_t>(copyRegions.size()), copyRegions.data());
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
    }
    copiedMask |= 1u << i;
    if (dynamicNow || !redrawParts.empty()) {
      beginPass(layerViews_[i], false, "dynamic", i);
      for (const LayerRect& lr : redrawParts) {
        VkClearAttachment ca{VK_IMAGE_ASPECT_DEPTH_BIT, 0, {}};
        ca.clearValue.depthStencil = {1.0f, 0};
        const VkClearRect cr{lr.scissor, 0, 1};
        vkCmdClearAttachments(cmd, 1, &ca, 1, &cr);
      }
      st.restoreTriangles += drawPieces(i, win, list, redrawParts, st.mergedDraws);
      split(win, box, layerRects);
      for (const LayerRect& lr : layerRects) {
        setRect(lr);
        st.dynamicTriangles += drawRect(i, win, list, true, lr);
      }
      endPass();
    }
    sh.dynamicLast = dynamicNow;
  }
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
