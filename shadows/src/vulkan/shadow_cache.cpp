// Windowed cascades: stabilised per-layer cascades drawn in world-anchored windows, and the cache
// (RendererOptions::cache) on top of them: static casters' depth kept per cascade across frames,
// only newly exposed / invalidated texels re-rendered, dynamic casters drawn every frame over a
// copy of it. Uncached, every texel is drawn every frame in the same windows, so the cache
// changes the cost and never the depth.
//
// Addressing. Texels are fixed in the world: a cascade's box starts at world texel index
// (boxX, boxY) of the light-space grid anchored at the world origin (the snapped box centre).
// World texel (i, j) lives at layer texel ((i - anchorX) mod R, (j - anchorY) mod R): toroidal,
// so a cascade that moves keeps every texel it still covers where it is and only the exposed
// rows/columns are drawn (scissored). Block (mx, my) of R x R texels of the anchor-relative
// index space is drawn with the viewport over the whole layer and the geometry projected about
// the block's own origin (anchor + m R texels, composed in double), so a world texel is always
// rasterised with the same vertex positions, viewport and tile: whichever frame draws it, cached
// or not, its depth is bit-identical. (Shifting the viewport by -m R instead would put the
// geometry outside the clip volume, where Vulkan clips it: lavapipe's guard band drew some of it
// and lost the rest, which is how the fly-through lost its shadows.)
//
// Depth window. The depth range is absolute in light space, quantised in quarters of the needed
// range and kept while it covers what the cascade needs (hysteresis), so stored depths stay
// valid as the camera moves; a new window (texel size, light direction, depth range) re-renders
// the layer.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "csm/cache_rects.hpp"
#include "csm/light_space.hpp"
#include "csm/names.hpp"
#include "csm/receiver_tiles.hpp"
#include "csm/vulkan/shadow_renderer.hpp"
#include "shadow_renderer_impl.hpp"
#include "vk_util.hpp"

namespace csm::vk {

namespace {

/// The stages and accesses of a depth attachment (the depth pass's reads and writes).
constexpr VkPipelineStageFlags2 kDepthStages =
    VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
constexpr VkAccessFlags2 kDepthAccess =
    VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;

// The light-space point a window's block (mx, my) is projected about, and the scale to clip
// space (`Window`: a csm::CacheWindowPlacement or what derives from it): layer pixel x =
// world texel index - anchorX - mx * R. Every block is drawn with the same viewport [0, R)^2;
// its geometry is shifted in light space (in double) instead, so what a block draws lies inside
// the clip volume (a viewport shifted off the attachment would rely on fragments outside the
// viewport, which Vulkan clips away).
template <class Window>
void blockProjection(const Window& w, std::int64_t res, std::int64_t mx, std::int64_t my,
                     glm::dvec3& originLs, glm::dvec3& scale) {
  const double half = 0.5 * double(res) * w.texel;
  originLs = glm::dvec3(double(w.anchorX + mx * res) * w.texel + half,
                        double(w.anchorY + my * res) * w.texel + half, w.zNear);
  scale = glm::dvec3(1.0 / half, 1.0 / half, 1.0 / (w.zFar - w.zNear));
}

// Model -> clip space of block (mx, my) of a window: the same vertex positions whichever frame
// draws a world texel, so its depth is bit-identical.
template <class Window>
glm::mat4 anchorTransform(const Window& w, std::int64_t res, std::int64_t mx, std::int64_t my,
                          const glm::dmat3& basisT, const CasterInstance& inst) {
  glm::dvec3 originLs, scale;
  blockProjection(w, res, mx, my, originLs, scale);
  const glm::dmat3 linear = basisT * glm::dmat3(inst.linearWs);
  // In light space about the block's origin: subtract in double (both may be ~1e7 m).
  const glm::dvec3 t = basisT * inst.translationWs - originLs;
  return scaledAffine(linear, t, scale);
}

// The layer rectangles of world rectangle `r` in a cached window (a CacheWindowPlacement).
template <class Window>
void split(const Window& w, std::int64_t res, const TexelRect& r, std::vector<LayerRect>& out) {
  splitIntoLayer(w.anchorX, w.anchorY, res, r, out);
}

/// A layer rectangle as Vulkan's (a scissor, a clear or copy region).
VkRect2D vkRect(const TexelRect& t) noexcept {
  return {{std::int32_t(t.x0), std::int32_t(t.y0)},
          {std::uint32_t(t.x1 - t.x0), std::uint32_t(t.y1 - t.y0)}};
}

/// Viewport and scissor of one layer rectangle: the viewport shifted by its block.
void setLayerRect(VkCommandBuffer cmd, const LayerRect& lr, std::int64_t res) {
  const VkViewport vp{0.0f, 0.0f, float(res), float(res), 0.0f, 1.0f};
  vkCmdSetViewport(cmd, 0, 1, &vp);
  const VkRect2D scissor = vkRect(lr.layer);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

/// Clears a rectangle of the bound depth attachment to the far plane.
void clearRect(VkCommandBuffer cmd, const VkRect2D& rect) {
  VkClearAttachment ca{VK_IMAGE_ASPECT_DEPTH_BIT, 0, {}};
  ca.clearValue.depthStencil = {1.0f, 0};
  const VkClearRect cr{rect, 0, 1};
  vkCmdClearAttachments(cmd, 1, &ca, 1, &cr);
}

/// One caster's part of one stale rectangle (CachedPass::drawPieces).
struct PieceHit {
  std::size_t piece;
  TexelRect part;
  bool done;
};

/// The debug label of a cascade's static or dynamic render pass.
std::string cascadeLabel(std::uint32_t cascade, const char* what) {
  return "csm cascade " + std::to_string(cascade) + " " + what;
}

}  // namespace

Status ShadowRenderer::Impl::checkCacheOptions(const ShadowSettings& settings,
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
  if (options.tiles && !options.cache) {
    return Status(ErrorCode::kInvalidArgument,
                  "options.tiles = true is invalid without options.cache: receiver-marked tiles "
                  "are drawn on top of the cache");
  }
  const std::uint64_t tile =
      std::uint64_t(settings.resolution / kTilesPerSide) * (settings.resolution / kTilesPerSide);
  if (options.tileBudgetTexels != 0 && options.tileBudgetTexels < tile) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("options.tileBudgetTexels = %llu is invalid: allowed 0 (no cap) or at "
                      "least one tile, (settings.resolution / 16)^2 = %llu",
                      static_cast<unsigned long long>(options.tileBudgetTexels),
                      static_cast<unsigned long long>(tile)));
  }
  if (options.tiles && isPrefiltered(settings.kernel)) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("options.tiles = true is invalid with settings.kernel = %s: allowed with "
                      "the depth-comparison kernels (1tap, tent3x3, tent5x5, tent7x7, poisson16, "
                      "pcss); a prefiltered filter's mips and blur would read undrawn tiles",
                      kernelName(settings.kernel)));
  }
  return {};
}

// ---------------------------------------------------------------------------------------------
// Windows

bool ShadowRenderer::Impl::windowedFor(const ShadowSettings& settings,
                                       const RendererOptions& options, RenderMode mode) noexcept {
  return options.cache || (settings.diagnostics.stabilize && mode == RenderMode::kPerLayer);
}

// The cache's plan for the frame (csm::planCacheFrame: windows, depth ranges, stale texels,
// the budget's choice, boxes and wrap offsets), applied to the frame; culling and recording
// follow it.
void ShadowRenderer::Impl::applyCacheWindows(CascadeFrame& frame) {
  if (!windowed()) {
    plan_ = {};
    return;
  }
  const std::uint64_t budget = options_.cache ? options_.cacheBudgetTexels : 0;
  tileReach_ = {};
  if (!(options_.cache && options_.tiles)) {
    plan_ = planCacheFrame(frame, cache_, resolution_, budget, options_.cacheExactCascades);
    return;
  }
  CacheTileInputs tiles;
  tiles.marks = tileMarks_ && tileMarks_->present() ? &*tileMarks_ : nullptr;
  for (std::uint32_t i = 0; i < std::min(frame.cascadeCount, kMaxCascades); ++i) {
    tileReach_[i] = receiverSampleReachTexels(settings_, frame, i);
  }
  tiles.reachTexels = tileReach_;
  tiles.budgetTexels = options_.tileBudgetTexels;
  plan_ = planCacheFrame(frame, cache_, resolution_, budget, options_.cacheExactCascades, &tiles);
}

Status ShadowRenderer::Impl::invalidate(const AabbWs& boxWs) {
  if (auto e = csm::validate(boxWs, "invalidate box")) {
    return Status(ErrorCode::kInvalidArgument, e->message());
  }
  if (!options_.cache) return {};
  invalidateCache(cache_, boxWs);
  return {};
}

void ShadowRenderer::Impl::invalidateAll() noexcept {
  invalidateCacheAll(cache_);
}

// ---------------------------------------------------------------------------------------------
// The static-depth image

Status ShadowRenderer::Impl::buildStaticImage(const ShadowSettings& settings, VkFormat format,
                                              Retired& out, VkDeviceSize& bytes) {
  VkDevice dev = device_.device;
  auto ci = vkInit<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
  ci.imageType = VK_IMAGE_TYPE_2D;
  ci.format = format;
  ci.extent = {settings.resolution, settings.resolution, 1};
  ci.mipLevels = 1;
  ci.arrayLayers = settings.cascadeCount;
  ci.samples = VK_SAMPLE_COUNT_1_BIT;
  ci.tiling = VK_IMAGE_TILING_OPTIMAL;
  // Sampled: the shader copy (CacheRestore::kShaderCopy) reads it.
  ci.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
             VK_IMAGE_USAGE_SAMPLED_BIT;
  ci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  ci.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  // Built into `out`; on failure what was made is destroyed (it was never recorded).
  auto fail = [&](Status st) {
    destroyNow(out);
    return st;
  };
  VkResult r = vkCreateImage(dev, &ci, nullptr, &out.image);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImage(csm static cache)"));
  setName(handleBits(out.image), VK_OBJECT_TYPE_IMAGE, "csm static depth cache");
  VkMemoryRequirements req{};
  vkGetImageMemoryRequirements(dev, out.image, &req);
  Status s = allocate(req, &out.memory, "csm static depth cache memory");
  if (!s.ok()) return fail(s);
  r = vkBindImageMemory(dev, out.image, out.memory, 0);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkBindImageMemory(csm static cache)"));
  auto vi = vkInit<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
  vi.image = out.image;
  vi.viewType = VK_IMAGE_VIEW_TYPE_2D;
  vi.format = format;
  for (std::uint32_t i = 0; i < settings.cascadeCount; ++i) {
    vi.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, i, 1};
    r = vkCreateImageView(dev, &vi, nullptr, &out.views[i]);
    if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImageView(csm static cache layer)"));
    const std::string name = "csm static depth cache layer " + std::to_string(i);
    setName(handleBits(out.views[i]), VK_OBJECT_TYPE_IMAGE_VIEW, name.c_str());
  }
  // The shader copy's sets, one a layer, living with the image (a set recorded in a frame in
  // flight is never rewritten).
  const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, settings.cascadeCount};
  auto pci = vkInit<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  pci.maxSets = settings.cascadeCount;
  pci.poolSizeCount = 1;
  pci.pPoolSizes = &size;
  r = vkCreateDescriptorPool(dev, &pci, nullptr, &out.pool);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateDescriptorPool(csm static cache)"));
  setName(handleBits(out.pool), VK_OBJECT_TYPE_DESCRIPTOR_POOL, "csm static depth cache pool");
  std::array<VkDescriptorSetLayout, kMaxCascades> layouts;
  layouts.fill(restoreSetLayout_);
  auto ai = vkInit<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  ai.descriptorPool = out.pool;
  ai.descriptorSetCount = settings.cascadeCount;
  ai.pSetLayouts = layouts.data();
  r = vkAllocateDescriptorSets(dev, &ai, out.sets.data());
  if (r != VK_SUCCESS) return fail(vkError(r, "vkAllocateDescriptorSets(csm static cache)"));
  std::array<VkDescriptorImageInfo, kMaxCascades> infos{};
  std::array<VkWriteDescriptorSet, kMaxCascades> writes{};
  for (std::uint32_t i = 0; i < settings.cascadeCount; ++i) {
    infos[i] = {depthSampler_, out.views[i], VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    writes[i] = vkInit<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
    writes[i].dstSet = out.sets[i];
    writes[i].dstBinding = 0;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    writes[i].pImageInfo = &infos[i];
    const std::string name = "csm static depth cache set " + std::to_string(i);
    setName(handleBits(out.sets[i]), VK_OBJECT_TYPE_DESCRIPTOR_SET, name.c_str());
  }
  vkUpdateDescriptorSets(dev, settings.cascadeCount, writes.data(), 0, nullptr);
  bytes = req.size;
  return {};
}

void ShadowRenderer::Impl::installStaticImage(Retired& built, VkDeviceSize bytes) noexcept {
  retireStaticImage();
  staticImage_ = built.image;
  staticMemory_ = built.memory;
  std::copy(built.views, built.views + kMaxCascades, std::begin(staticViews_));
  staticPool_ = built.pool;
  staticSets_ = built.sets;
  cacheBytes_ = bytes;
  staticInitialised_ = false;
  built = Retired{};
}

void ShadowRenderer::Impl::retireStaticImage() noexcept {
  if (staticImage_ == VK_NULL_HANDLE && staticMemory_ == VK_NULL_HANDLE) return;
  Retired old;
  old.afterRecord = records_;
  old.image = staticImage_;
  old.memory = staticMemory_;
  std::copy(std::begin(staticViews_), std::end(staticViews_), old.views);
  old.pool = staticPool_;
  retired_.push_back(old);
  staticImage_ = VK_NULL_HANDLE;
  staticMemory_ = VK_NULL_HANDLE;
  staticPool_ = VK_NULL_HANDLE;
  staticSets_ = {};
  std::fill(std::begin(staticViews_), std::end(staticViews_), VK_NULL_HANDLE);
  cacheBytes_ = 0;
  staticInitialised_ = false;
}

// ---------------------------------------------------------------------------------------------
// The cached pass

// The cached pass's drawing state: the casters' light-space texel rectangles in the cascade
// being drawn, its light basis, the bound mesh buffers and per-cascade scratch.
struct ShadowRenderer::Impl::CachedPass {
  CachedPass(ShadowRenderer::Impl& renderer, VkCommandBuffer commands, const CasterList& list,
             std::int64_t resolution)
      : r(renderer), cmd(commands), casters(list), res(resolution) {}

  ShadowRenderer::Impl& r;
  VkCommandBuffer cmd;
  const CasterList& casters;
  std::int64_t res;
  std::array<TexelRect, kMaxCascades> boxes{};  // each cascade's box (world texel indices)
  std::vector<TexelRect> casterRects;           // computed once per cascade
  const MeshDraw* bound = nullptr;
  glm::dmat3 basisT{1.0};  // the light basis (transposed) of the cascade being drawn
  std::vector<TexelRect> dirty, copyParts, shaderCopyParts;
  std::vector<LayerRect> layerRects, staticPieces, redrawParts;
  std::vector<VkImageCopy> copyRegions;
  std::vector<PieceHit> hits;

  std::int64_t blockX = 0, blockY = 0;  // the block of the rectangle set last
  // The texel rectangles of the casters of `list` in the cascade being drawn (every texel
  // when the host gave no bounds: each block then draws every caster, scissored).
  void computeCasterRects(const std::vector<std::uint32_t>& list, double texel) {
    constexpr std::int64_t kAll = std::int64_t(1) << 62;
    const float thin = r.thinMarginTexels();
    for (std::uint32_t idx : list) {
      casterRects[idx] = casters.boundsWs.empty()
                             ? TexelRect{-kAll, -kAll, kAll, kAll}
                             : boxTexels(casters.boundsWs[idx], basisT, texel,
                                         casters.instances[idx].thin ? thin : 0.0f);
    }
  }

  void setRect(const LayerRect& lr) {
    setLayerRect(cmd, lr, res);
    blockX = lr.mx;
    blockY = lr.my;
  }

  // Draws caster `idx` (at the LOD of the uncached pass: the schedule and the texel error
  // budget) under the current viewport and scissor; returns its triangles.
  std::uint64_t drawCaster(std::uint32_t cascade, const CacheWindowPlacement& w,
                           std::uint32_t idx) {
    const CasterInstance& inst = casters.instances[idx];
    const MeshDraw& mesh = casters.meshes[inst.meshForLod(
        casterLod(inst, r.options_.cascadeLod[cascade], w.texel, r.options_.lodMaxErrorTexels))];
    if (mesh.indexCount == 0) return 0;
    bindMeshBuffers(cmd, mesh, bound, r.layout_.indexType);
    const DepthPushPerLayer push{anchorTransform(w, res, blockX, blockY, basisT, inst), cascade};
    vkCmdPushConstants(cmd, r.pipelineLayout_, VK_SHADER_STAGE_VERTEX_BIT, 0, CSM_DEPTH_PUSH_SIZE,
                       &push);
    Impl::LayerTexels texels{};
    texels[0] = w.texel;
    r.drawIndexedCaster(cmd, inst, mesh, 1, texels);
    return mesh.indexCount / 3;
  }

  // Draws the casters of `list` with dynamic == `dynamic` that overlap `lr`; returns triangles.
  std::uint64_t drawRect(std::uint32_t cascade, const CacheWindowPlacement& w,
                         const std::vector<std::uint32_t>& list, bool dynamic,
                         const LayerRect& lr) {
    std::uint64_t triangles = 0;
    for (std::uint32_t idx : list) {
      if (casters.instances[idx].dynamic != dynamic) continue;
      if (casterRects[idx].intersect(lr.world).empty()) continue;
      triangles += drawCaster(cascade, w, idx);
    }
    return triangles;
  }

  // Draws the static casters of `list` over the stale rectangles `pieces` (already cleared). A
  // caster over several pieces of one block (an L-shaped exposure, a strip and a box) is drawn
  // once, scissored to the bounding rectangle of its parts, when that rectangle is no larger
  // than the parts together: drawing it over texels that are valid leaves them bit-identical
  // (they already hold the minimum over every static caster, this one included). Otherwise
  // once per piece. Returns triangles; counts the draws saved in `saved`.
  std::uint64_t drawPieces(std::uint32_t cascade, const CacheWindowPlacement& w,
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
        setRect(mergeHits(pieces, h, saved));
        triangles += drawCaster(cascade, w, idx);
      }
    }
    return triangles;
  }

  // The rectangle hit `h` is drawn in: merged with the later hits of the same block (same
  // viewport, marked done) when their bounding rectangle is no larger than the parts together.
  LayerRect mergeHits(const std::vector<LayerRect>& pieces, std::size_t h, std::uint64_t& saved) {
    const LayerRect& first = pieces[hits[h].piece];
    TexelRect u = hits[h].part;
    std::uint64_t sum = u.area();
    std::size_t n = 1;
    for (std::size_t g = h + 1; g < hits.size(); ++g) {
      const LayerRect& other = pieces[hits[g].piece];
      if (other.mx != first.mx || other.my != first.my) continue;
      const TexelRect& q = hits[g].part;
      u = {std::min(u.x0, q.x0), std::min(u.y0, q.y0), std::max(u.x1, q.x1), std::max(u.y1, q.y1)};
      sum += q.area();
      ++n;
    }
    if (n == 1 || u.area() > sum) return first;
    LayerRect merged = first;
    merged.world = u;
    const std::int64_t dx = first.layer.x0 - first.world.x0;
    const std::int64_t dy = first.layer.y0 - first.world.y0;
    merged.layer = {u.x0 + dx, u.y0 + dy, u.x1 + dx, u.y1 + dy};
    saved += n - 1;
    for (std::size_t g = h + 1; g < hits.size(); ++g) {
      const LayerRect& other = pieces[hits[g].piece];
      if (other.mx == first.mx && other.my == first.my) hits[g].done = true;
    }
    return merged;
  }
};

// The frame must carry the windows (applyCacheWindows before culling). Each cascade is drawn in
// the window and light basis its layer shows (this frame's unless deferred), as planned.
Status ShadowRenderer::Impl::checkCacheWindows(const CascadeFrame& frame) const {
  for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
    const Cascade& c = frame.cascades[i];
    if (c.empty) continue;
    const CacheShownState& sh = cache_.shown[i];
    const CacheWindowPlacement& w = sh.window;
    const double centerZ = glm::dot(sh.basis[2], c.boxCenterWs);
    const double tol = 1e-6 * std::max(1.0, std::abs(w.zFar - w.zNear));
    if (!sh.valid || !w.valid || i >= plan_.cascadeCount || !plan_.cascades[i].active ||
        w.texel != c.texelSizeLs.x || std::abs(centerZ + c.depthNearLs - w.zNear) > tol ||
        std::abs(centerZ + c.depthFarLs - w.zFar) > tol) {
      return Status(ErrorCode::kInvalidArgument,
                    fmt("frame.cascades[%u] has no cache window: call applyCacheWindows(frame) "
                        "before culling and recording (ShadowView does)",
                        i));
    }
  }
  return {};
}

// The uniform block of the cached pass, packed from the plan (toroidal addressing: each
// cascade's wrap offset; a cascade deferred across a change of light addressed in the basis it
// shows), and each cascade's box in the window it shows.
void ShadowRenderer::Impl::packCachedUniforms(const CascadeFrame& frame, CachedPass& pass) {
  uniforms_ = csm::packCachedUniforms(frame, settings_, uniformOptions(), plan_);
  for (std::uint32_t i = 0; i < plan_.cascadeCount; ++i) pass.boxes[i] = plan_.cascades[i].box;
}

// The cached pass's start: its label, the uniform block (write after the previous frame's
// reads), the static image after last frame's copies, and a new sampled image.
void ShadowRenderer::Impl::recordCachedBegin(VkCommandBuffer cmd, bool wasUndefined) {
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
    invalidateCacheAll(cache_);
    updateCacheStale(plan_, cache_);
  }
  staticInitialised_ = true;
  // What the partial cascades hold after this frame's draw, invalidations since planning
  // included (updateCacheStale), before the block is uploaded.
  if (options_.tiles) packTileUniforms(uniforms_, plan_, tileReach_);
  recordPassStart(cmd, "csm shadow pass (cached)",
                  wasUndefined ? std::span<const VkImageMemoryBarrier2>(img, 2)
                               : std::span<const VkImageMemoryBarrier2>(img + 1, 1));
}

// One cascade of the cached pass: its stale static texels re-rendered, the sampled layer
// restored to the static depth and the dynamic casters drawn over it. Returns whether the
// sampled layer was written (false: it already holds this frame's depth).
bool ShadowRenderer::Impl::recordCachedCascade(CachedPass& pass, std::uint32_t i,
                                               const std::vector<std::uint32_t>& list) {
  const std::int64_t res = resolution_;
  const CacheCascadePlan& p = plan_.cascades[i];
  const CacheWindowPlacement& win = cache_.shown[i].window;  // the window the layer shows
  DynamicDrawn& drawn = dynamicDrawn_[i];
  pass.basisT = glm::transpose(p.basis);
  CascadeCacheStats& st = cacheStats_[i];
  st.deferred = !p.refreshed;
  st.lagFrames = p.lagFrames;
  st.wantedTexels = p.staleTexels;
  st.partial = p.partial;
  st.tilesMarked = p.tilesMarked;
  st.tilesDrawn = p.refreshed ? p.tilesDrawn : 0;
  st.tilesHeld = p.tiles.count();
  st.tilesDeferred = p.refreshed ? p.tilesDeferred : 0;
  bool dynamicNow = false;
  pass.computeCasterRects(list, win.texel);
  for (std::uint32_t idx : list) dynamicNow = dynamicNow || pass.casters.instances[idx].dynamic;

  // What of the static layer is stale (planned: everything for a new window, the newly exposed
  // rows and columns, what lies under invalidated boxes). A deferred cascade draws none of it.
  pass.dirty = p.stale;
  const bool full = p.full;
  if (p.refreshed) st.newWindow = p.newWindow;
  const bool copy = !pass.dirty.empty() || dynamicNow || drawn.last;
  if (!copy) return false;  // the sampled layer already holds this frame's depth
  if (cascadeHook_) cascadeHook_(pass.cmd, i);

  if (!pass.dirty.empty()) recordStaticRects(pass, i, list, full);
  const bool whole = planRestore(pass, i, full);
  // What the sampled layer changes in, for the moment resolve: the stale rectangles, where
  // dynamic casters were drawn last time and where they are drawn now (elsewhere it holds the
  // same static depth as before, whether restored by copy or redraw).
  LayerRects& changed = momentRects_[i];
  if (full) momentWholeMask_ |= 1u << i;
  for (const TexelRect& r : pass.dirty) {
    split(win, res, r, pass.layerRects);
    for (const LayerRect& lr : pass.layerRects) {
      const TexelRect& t = lr.layer;
      changed.push_back(
          {std::int32_t(t.x0), std::int32_t(t.y0), std::int32_t(t.x1), std::int32_t(t.y1)});
    }
  }
  changed.insert(changed.end(), drawn.rects.begin(), drawn.rects.end());
  rememberDynamicRects(pass, i, list);  // none when !dynamicNow
  changed.insert(changed.end(), drawn.rects.begin(), drawn.rects.end());
  const bool shaderCopy = !pass.shaderCopyParts.empty();
  recordStaticCopy(pass.cmd, i, pass.copyRegions, whole, shaderCopy);
  st.copied = !pass.copyRegions.empty() || shaderCopy;
  if (dynamicNow || !pass.redrawParts.empty() || shaderCopy) recordDynamicPass(pass, i, list);
  if (shaderCopy) recordStaticLayerBack(pass.cmd, i);
  drawn.last = dynamicNow;
  return true;
}

// The stale rectangles of the static layer (pass.dirty): cleared (unless `full`: the whole
// layer, cleared on load) and drawn with the static casters.
void ShadowRenderer::Impl::recordStaticRects(CachedPass& pass, std::uint32_t i,
                                             const std::vector<std::uint32_t>& list, bool full) {
  const CacheWindowPlacement& win = cache_.shown[i].window;
  CascadeCacheStats& st = cacheStats_[i];
  // Both images are DEPTH_ATTACHMENT_OPTIMAL while drawn (see recordStaticCopy).
  beginDepthRendering(pass.cmd, staticViews_[i], 1, full, cascadeLabel(i, "static"), pipeline_);
  pass.bound = nullptr;
  pass.staticPieces.clear();
  for (const TexelRect& r : pass.dirty) {
    split(win, resolution_, r, pass.layerRects);
    for (const LayerRect& lr : pass.layerRects) {
      if (!full) clearRect(pass.cmd, vkRect(lr.layer));
      st.staticTexels += lr.world.area();
      pass.staticPieces.push_back(lr);
    }
  }
  st.staticTriangles += pass.drawPieces(i, win, list, pass.staticPieces, st.mergedDraws);
  endLayer(pass.cmd);
}

// How the sampled layer gets the static depth back. It holds the static depth except where it
// was re-rendered this frame and where dynamic casters were drawn last time: only those
// rectangles are restored, drawn with the static layer's depth (kShaderCopy:
// pass.shaderCopyParts), copied (kCopyRects: pass.copyRegions) or cleared and redrawn with the
// static casters (kRedraw, and kShaderCopy on a UNORM format: pass.redrawParts); the whole layer
// is copied on a full render, when they are most of it, or with kWholeLayer. Returns whether the
// whole layer is copied.
bool ShadowRenderer::Impl::planRestore(CachedPass& pass, std::uint32_t i, bool full) {
  const std::int64_t res = resolution_;
  const CacheWindowPlacement& win = cache_.shown[i].window;
  const DynamicDrawn& drawn = dynamicDrawn_[i];
  CascadeCacheStats& st = cacheStats_[i];
  pass.copyParts.clear();
  pass.redrawParts.clear();
  pass.shaderCopyParts.clear();
  const CacheRestore mode = settings_.diagnostics.cacheRestore;
  bool whole = full || mode == CacheRestore::kWholeLayer;
  if (!whole) {
    for (const TexelRect& r : pass.dirty) {
      split(win, res, r, pass.layerRects);
      for (const LayerRect& lr : pass.layerRects) addDisjoint(pass.copyParts, lr.layer);
    }
    for (const auto& d : drawn.rects) addDisjoint(pass.copyParts, {d[0], d[1], d[2], d[3]});
    whole = pass.copyParts.size() > 256 ||
            totalArea(pass.copyParts) * 4 >= 3 * std::uint64_t(res * res);
  }
  if (whole) pass.copyParts.assign(1, TexelRect{0, 0, res, res});
  // Redrawing the static casters costs as much as drawing them: where the rectangles are an
  // eighth of the layer or more (receiver-marked tiles after a new window or a cut) they are
  // copied instead.
  if (!whole && shaderCopyRestore()) {
    // The copy's cost follows the texels: every rectangle, however large.
    for (const TexelRect& r : pass.copyParts) st.restoredTexels += r.area();
    pass.shaderCopyParts.swap(pass.copyParts);
  }
  const bool large = totalArea(pass.copyParts) * 8 >= std::uint64_t(res * res);
  if (!whole && !large && (mode == CacheRestore::kRedraw || mode == CacheRestore::kShaderCopy)) {
    // The restored rectangles, with the block each lies in (as the box's own split).
    split(win, res, pass.boxes[i], pass.layerRects);
    for (const TexelRect& p : pass.copyParts) {
      for (const LayerRect& lr : pass.layerRects) {
        const TexelRect q = p.intersect(lr.layer);
        if (q.empty()) continue;
        const std::int64_t dx = lr.world.x0 - lr.layer.x0;
        const std::int64_t dy = lr.world.y0 - lr.layer.y0;
        pass.redrawParts.push_back({{q.x0 + dx, q.y0 + dy, q.x1 + dx, q.y1 + dy}, lr.mx, lr.my, q});
        st.restoredTexels += q.area();
      }
    }
    pass.copyParts.clear();
  }
  pass.copyRegions.clear();
  for (const TexelRect& r : pass.copyParts) {
    VkImageCopy region{};
    region.srcSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, i, 1};
    region.dstSubresource = region.srcSubresource;
    region.srcOffset = {std::int32_t(r.x0), std::int32_t(r.y0), 0};
    region.dstOffset = region.srcOffset;
    region.extent = {std::uint32_t(r.x1 - r.x0), std::uint32_t(r.y1 - r.y0), 1};
    pass.copyRegions.push_back(region);
    st.restoredTexels += r.area();
  }
  return whole;
}

// The layer rectangles this frame's dynamic casters in `list` cover (restored next time).
void ShadowRenderer::Impl::rememberDynamicRects(CachedPass& pass, std::uint32_t i,
                                                const std::vector<std::uint32_t>& list) {
  const CacheWindowPlacement& win = cache_.shown[i].window;
  DynamicDrawn& drawn = dynamicDrawn_[i];
  drawn.rects.clear();
  std::vector<TexelRect> parts;
  for (std::uint32_t idx : list) {
    if (!pass.casters.instances[idx].dynamic) continue;
    split(win, resolution_, pass.casterRects[idx].intersect(pass.boxes[i]), pass.layerRects);
    for (const LayerRect& lr : pass.layerRects) {
      if (parts.size() >= 64) {  // many casters: their bounding rectangle
        TexelRect& u = parts[0];
        const TexelRect& t = lr.layer;
        u = {std::min(u.x0, t.x0), std::min(u.y0, t.y0), std::max(u.x1, t.x1),
             std::max(u.y1, t.y1)};
        parts.resize(1);
      } else {
        parts.push_back(lr.layer);
      }
    }
  }
  for (const TexelRect& t : parts) {
    drawn.rects.push_back(
        {std::int32_t(t.x0), std::int32_t(t.y0), std::int32_t(t.x1), std::int32_t(t.y1)});
  }
}

// Static layer `i` -> the sampled layer `i` (`regions`; `whole`: the whole layer, so its old
// content is discarded), leaving both as depth attachments. No regions (nothing to restore,
// dynamic casters appear, or the shader copy): the sampled layer straight to the attachment;
// `readStatic` (the shader copy): the static layer to the sampled layout for the dynamic pass's
// fragment shader (recordStaticLayerBack returns it).
void ShadowRenderer::Impl::recordStaticCopy(VkCommandBuffer cmd, std::uint32_t i,
                                            std::span<const VkImageCopy> regions, bool whole,
                                            bool readStatic) {
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
  // Overwritten whole by the copy, else kept where not copied (sampled since last frame).
  b[1].oldLayout = whole ? VK_IMAGE_LAYOUT_UNDEFINED : sampledLayout();
  b[1].newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.imageMemoryBarrierCount = 2;
  dep.pImageMemoryBarriers = b;
  if (regions.empty()) {
    b[1].dstStageMask = kDepthStages;
    b[1].dstAccessMask = kDepthAccess;
    b[1].newLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    // The static layer, drawn this frame or not, read texel by texel by the shader copy.
    b[0].dstStageMask = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
    b[0].dstAccessMask = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
    b[0].newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    dep.imageMemoryBarrierCount = readStatic ? 2 : 1;
    dep.pImageMemoryBarriers = readStatic ? b : b + 1;
    vkCmdPipelineBarrier2(cmd, &dep);
    return;
  }
  vkCmdPipelineBarrier2(cmd, &dep);
  vkCmdCopyImage(cmd, staticImage_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, image_,
                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, static_cast<std::uint32_t>(regions.size()),
                 regions.data());
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

// Static layer `i` back to the depth attachment layout after the shader copy read it (between
// frames every static layer is DEPTH_ATTACHMENT_OPTIMAL).
void ShadowRenderer::Impl::recordStaticLayerBack(VkCommandBuffer cmd, std::uint32_t i) {
  auto b = vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2);
  b.srcStageMask = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  b.srcAccessMask = VK_ACCESS_2_NONE;
  b.dstStageMask = kDepthStages;
  b.dstAccessMask = kDepthAccess;
  b.oldLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  b.newLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = staticImage_;
  b.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, i, 1};
  auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dep);
}

bool ShadowRenderer::Impl::shaderCopyRestore() const noexcept {
  return settings_.diagnostics.cacheRestore == CacheRestore::kShaderCopy &&
         (options_.depthFormat == VK_FORMAT_D32_SFLOAT ||
          options_.depthFormat == VK_FORMAT_D32_SFLOAT_S8_UINT);
}

// The shader copy (CacheRestore::kShaderCopy) inside the sampled layer's dynamic pass: one
// triangle over the layer per rectangle of pass.shaderCopyParts, scissored to it, writing the
// static layer's depth (the test always passes). Leaves the depth pipeline and its set bound.
void ShadowRenderer::Impl::recordShaderCopy(CachedPass& pass, std::uint32_t i) {
  VkCommandBuffer cmd = pass.cmd;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, restorePipeline_);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, restoreLayout_, 0, 1,
                          &staticSets_[i], 0, nullptr);
  vkCmdSetCullMode(cmd, VK_CULL_MODE_NONE);
  const VkViewport vp{0.0f, 0.0f, float(resolution_), float(resolution_), 0.0f, 1.0f};
  vkCmdSetViewport(cmd, 0, 1, &vp);
  for (const TexelRect& r : pass.shaderCopyParts) {
    const VkRect2D scissor = vkRect(r);
    vkCmdSetScissor(cmd, 0, 1, &scissor);
    vkCmdDraw(cmd, 3, 1, 0, 0);
  }
  vkCmdSetCullMode(cmd, drawCull_);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelineLayout_, 0, 1, &depthSet_,
                          0, nullptr);
}

// The sampled layer's dynamic pass: the rectangles restored by the shader copy
// (pass.shaderCopyParts) or by redrawing (pass.redrawParts: cleared and drawn with the static
// casters), then the dynamic casters over the box.
void ShadowRenderer::Impl::recordDynamicPass(CachedPass& pass, std::uint32_t i,
                                             const std::vector<std::uint32_t>& list) {
  const CacheWindowPlacement& win = cache_.shown[i].window;
  CascadeCacheStats& st = cacheStats_[i];
  beginDepthRendering(pass.cmd, layerViews_[i], 1, false, cascadeLabel(i, "dynamic"), pipeline_);
  pass.bound = nullptr;
  if (!pass.shaderCopyParts.empty()) recordShaderCopy(pass, i);
  for (const LayerRect& lr : pass.redrawParts) clearRect(pass.cmd, vkRect(lr.layer));
  st.restoreTriangles += pass.drawPieces(i, win, list, pass.redrawParts, st.mergedDraws);
  split(win, resolution_, pass.boxes[i], pass.layerRects);
  for (const LayerRect& lr : pass.layerRects) {
    pass.setRect(lr);
    st.dynamicTriangles += pass.drawRect(i, win, list, true, lr);
  }
  endLayer(pass.cmd);
}

// The cached pass's end: layers written this frame -> the sampled layout.
void ShadowRenderer::Impl::recordCachedEnd(VkCommandBuffer cmd, std::uint32_t copiedMask) {
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
  recordMomentResolve(cmd);
  if (endLabel_) endLabel_(cmd);
}

// The frame to record: `frame` when it carries the windows (applyCacheWindows, as ShadowView
// does before culling), else `own`, a windowed copy (uncached: the host culled the frame as
// computed; the windows only deepen the depth range, so its lists hold every caster the
// windowed box can show). Null when the cache needs the windows before culling.
const CascadeFrame* ShadowRenderer::Impl::windowedFrame(const CascadeFrame& frame,
                                                        CascadeFrame& own) {
  if (checkCacheWindows(frame).ok()) return &frame;
  if (options_.cache) return nullptr;
  own = frame;
  applyCacheWindows(own);
  return &own;
}

// Every texel of cascade `i` rendered into the sampled layer (windowed, uncached): the box's
// blocks, each caster drawn over the blocks its bounds touch, static and dynamic alike. The same
// vertices, viewport and tiles as the cached pass, so the same depth in every texel.
void ShadowRenderer::Impl::recordFullCascade(CachedPass& pass, std::uint32_t i,
                                             const std::vector<std::uint32_t>& list) {
  const CacheWindowPlacement& win = cache_.shown[i].window;
  CascadeCacheStats& st = cacheStats_[i];
  pass.basisT = glm::transpose(plan_.cascades[i].basis);
  pass.computeCasterRects(list, win.texel);
  if (cascadeHook_) cascadeHook_(pass.cmd, i);
  beginDepthRendering(pass.cmd, layerViews_[i], 1, true, cascadeLabel(i, "full"), pipeline_);
  pass.bound = nullptr;
  split(win, resolution_, pass.boxes[i], pass.layerRects);
  for (const LayerRect& lr : pass.layerRects) {
    pass.setRect(lr);
    st.staticTriangles += pass.drawRect(i, win, list, false, lr);
    st.dynamicTriangles += pass.drawRect(i, win, list, true, lr);
  }
  st.staticTexels = std::uint64_t(resolution_) * resolution_;
  st.wantedTexels = st.staticTexels;
  st.newWindow = true;
  endLayer(pass.cmd);
}

Status ShadowRenderer::Impl::recordCachedPass(VkCommandBuffer cmd, const CascadeFrame& frameIn,
                                              const CasterList& casters,
                                              const CullResult* visible) {
  CascadeFrame own;
  const CascadeFrame* framePtr = windowedFrame(frameIn, own);
  if (framePtr == nullptr) return checkCacheWindows(frameIn);
  const CascadeFrame& frame = *framePtr;
  // Without cull lists every caster is drawn in every cascade (its bounds still pick blocks).
  std::vector<std::uint32_t> all;
  if (visible == nullptr) {
    all.resize(casters.instances.size());
    for (std::size_t k = 0; k < all.size(); ++k) all[k] = static_cast<std::uint32_t>(k);
  }
  auto listOf = [&](std::uint32_t c) -> const std::vector<std::uint32_t>& {
    return visible != nullptr ? visible->visible[c] : all;
  };

  const bool wasUndefined = countRecord();
  CachedPass pass(*this, cmd, casters, resolution_);
  // Boxes invalidated since the plan was made join this frame's stale rectangles (before the
  // uniform block, which carries the tiles the partial cascades hold after this frame).
  if (options_.cache) updateCacheStale(plan_, cache_);
  packCachedUniforms(frame, pass);
  cacheStats_ = {};
  pass.casterRects.resize(casters.instances.size());
  if (!options_.cache) {
    recordDiscardingStart(cmd, "csm shadow pass (windowed)");
    bool any = false;
    for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
      if (frame.cascades[i].empty) continue;
      recordFullCascade(pass, i, listOf(i));
      any = true;
    }
    if (cascadeHook_ && any) cascadeHook_(cmd, kCascadeHookEnd);
    recordEnd(cmd);
    return {};
  }

  recordCachedBegin(cmd, wasUndefined);
  momentPartial_ = true;  // recordCachedCascade fills the changed rectangles
  momentWholeMask_ = 0;
  for (LayerRects& r : momentRects_) r.clear();
  bool any = false;
  std::uint32_t copiedMask = 0;
  for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
    if (frame.cascades[i].empty) continue;
    if (!recordCachedCascade(pass, i, listOf(i))) continue;
    any = true;
    copiedMask |= 1u << i;
  }
  markCacheRecorded(plan_, cache_);
  if (cascadeHook_ && any) cascadeHook_(cmd, kCascadeHookEnd);

  recordCachedEnd(cmd, copiedMask);
  return {};
}

// The callback form with windowed cascades: the host's draws once per block of each cascade's
// box, projected about the block (CascadeDrawContext::setTransform), viewport and scissor set.
Status ShadowRenderer::Impl::recordWindowedCallbackPass(VkCommandBuffer cmd,
                                                        const CascadeFrame& frameIn,
                                                        const CascadeDrawCallback& draw,
                                                        const CullResult* visible) {
  CascadeFrame own;
  const CascadeFrame& frame = *windowedFrame(frameIn, own);  // uncached: never null
  countRecord();
  const CasterList none{};
  CachedPass pass(*this, cmd, none, resolution_);
  packCachedUniforms(frame, pass);
  cacheStats_ = {};
  recordDiscardingStart(cmd, "csm shadow pass (windowed)");
  bool any = false;
  for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
    if (frame.cascades[c].empty) continue;
    if (cascadeHook_) cascadeHook_(cmd, c);
    any = true;
    const CacheWindowPlacement& win = cache_.shown[c].window;
    beginDepthRendering(cmd, layerViews_[c], 1, true, cascadeLabel(c, "full"), pipeline_);
    split(win, resolution_, pass.boxes[c], pass.layerRects);
    for (const LayerRect& lr : pass.layerRects) {
      pass.setRect(lr);
      CascadeDrawContext ctx = drawContext(cmd, frame, c, visible);
      ctx.anchored = true;
      blockProjection(win, resolution_, lr.mx, lr.my, ctx.originLs, ctx.clipPerMetre);
      draw(ctx);
    }
    endLayer(cmd);
  }
  if (cascadeHook_ && any) cascadeHook_(cmd, kCascadeHookEnd);
  recordEnd(cmd);
  return {};
}

}  // namespace csm::vk
