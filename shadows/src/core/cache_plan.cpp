#include "csm/cache_plan.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "csm/selection.hpp"

namespace csm {

std::int64_t cacheBoxStart(double centerLs, double texel, std::int64_t res) noexcept {
  return std::llround(centerLs / texel) - res / 2;
}

bool placeCacheWindow(CacheWindowPlacement& window, double texel, const glm::dvec3& lightDirection,
                      std::int64_t boxX, std::int64_t boxY, double needNearLs, double needFarLs) {
  const double needLen = needFarLs - needNearLs;
  const bool keep = window.valid && window.texel == texel &&
                    window.lightDirection == lightDirection && needNearLs >= window.zNear &&
                    needFarLs <= window.zFar && window.zFar - window.zNear <= 2.5 * needLen;
  if (keep) return false;
  window = CacheWindowPlacement{};
  window.valid = true;
  window.texel = texel;
  window.lightDirection = lightDirection;
  window.anchorX = boxX;
  window.anchorY = boxY;
  const double q = needLen * 0.25;
  window.zNear = std::floor(needNearLs / q) * q - q;
  window.zFar = std::ceil(needFarLs / q) * q + q;
  return true;
}

std::uint32_t scheduleCacheRefresh(std::span<const CacheRefreshCandidate> cascades,
                                   std::uint64_t budgetTexels, std::uint32_t exactCascades) {
  std::uint32_t refreshed = 0;
  std::vector<std::uint32_t> order;
  const auto n = static_cast<std::uint32_t>(std::min<std::size_t>(cascades.size(), 32));
  for (std::uint32_t i = 0; i < n; ++i) {
    const CacheRefreshCandidate& c = cascades[i];
    if (!c.active) continue;
    if (budgetTexels == 0 || i < exactCascades || !c.shown) {
      refreshed |= 1u << i;
    } else {
      order.push_back(i);
    }
  }
  // One more frame of lag for a cascade that shows a lit fringe, so that it goes first among
  // equals but cannot starve a cascade that lags longer.
  auto staleness = [&](std::uint32_t i) {
    return cascades[i].lagFrames + (cascades[i].covered ? 0u : 1u);
  };
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    if (staleness(a) != staleness(b)) return staleness(a) > staleness(b);
    return !cascades[a].covered && cascades[b].covered;
  });
  std::uint64_t left = budgetTexels;
  for (std::uint32_t i : order) {
    if (cascades[i].staleTexels <= left) {
      left -= cascades[i].staleTexels;
      refreshed |= 1u << i;
    }
  }
  return refreshed;
}

bool cacheShownCovers(const CacheShownState& shown, const Cascade& c,
                      const glm::dmat3& basis) noexcept {
  if (!shown.valid) return false;
  const glm::dvec3 centerLs = glm::transpose(basis) * c.boxCenterWs;
  const glm::dmat3 shownT = glm::transpose(shown.basis);
  const glm::dvec3 shownCenter = shownT * shown.cascade.boxCenterWs;
  const glm::dvec3 sphere = shownT * c.sphereCenterWs;
  const bool sameLight = shown.basis == basis;
  const glm::dvec3 needCenter = sameLight ? centerLs : sphere;
  const double needHalf = sameLight && c.neededHalfExtentM > 0.0
                              ? std::min(c.neededHalfExtentM, c.halfExtentLs.x)
                              : (sameLight ? c.halfExtentLs.x : c.sphereRadiusM);
  const double half = shown.cascade.halfExtentLs.x;
  return std::abs(needCenter.x - shownCenter.x) + needHalf <= half &&
         std::abs(needCenter.y - shownCenter.y) + needHalf <= half &&
         sphere.z - c.sphereRadiusM >= shown.window.zNear &&
         sphere.z + c.sphereRadiusM <= shown.window.zFar;
}

namespace {

// The stale rectangles of static layer `layer` for box `box` (staleRects), into `p`.
void planStale(CacheCascadePlan& p, const CacheLayerState& layer, const TexelRect& box,
               const glm::dmat3& basisT, std::int64_t res) {
  p.stale.clear();
  const TexelRect held{layer.boxX, layer.boxY, layer.boxX + res, layer.boxY + res};
  p.full = staleRects(layer.staticValid, held, box, layer.pending, basisT, layer.texel, p.stale);
  p.staleTexels = totalArea(p.stale);
  p.pendingPlanned = layer.pending.size();
  p.wholeInvalidations = layer.wholeInvalidations;
}

// The tiles of a layer of `res` texels a side: resolution / kTilesPerSide texels.
std::int64_t tileTexelsOf(std::int64_t res) {
  return std::max<std::int64_t>(res / std::int64_t(kTilesPerSide), 1);
}

// The grid (origin only) of the tiles that box `box` touches.
TileMask tileGridOf(const TexelRect& box, std::int64_t res) {
  const std::int64_t t = tileTexelsOf(res);
  TileMask m;
  m.origin = glm::i64vec2(floorDiv(box.x0, t), floorDiv(box.y0, t));
  return m;
}

// The world texels of grid tile (x, y) of `mask`, within `box`.
TexelRect tileRect(const TileMask& mask, std::int64_t x, std::int64_t y, std::int64_t res,
                   const TexelRect& box) {
  const std::int64_t t = tileTexelsOf(res);
  const std::int64_t wx = (mask.origin.x + x) * t, wy = (mask.origin.y + y) * t;
  return TexelRect{wx, wy, wx + t, wy + t}.intersect(box);
}

// The tiles of box `box` that static layer `layer` holds before this frame's stale texels:
// none without a valid layer; those it holds (as far as they lie in its box) when partial;
// every tile of the box when complete. What the box has that the layer's box had not is among
// the stale rectangles.
TileMask heldTiles(const CacheLayerState& layer, const TexelRect& box, std::int64_t res) {
  TileMask m = tileGridOf(box, res);
  if (!layer.staticValid) return m;
  for (std::int64_t y = 0; y < kTileGridSide; ++y) {
    for (std::int64_t x = 0; x < kTileGridSide; ++x) {
      if (tileRect(m, x, y, res, box).empty()) continue;
      m.set(x, y, !layer.partial || layer.tiles.testWorld(m.origin.x + x, m.origin.y + y));
    }
  }
  return m;
}

// Rectangles that span the same rows and touch along x, merged; then (xy = false) those that
// span the same columns and touch along y.
void mergeAlong(std::vector<TexelRect>& rects, bool xy) {
  // Along x: (y0, y1) the span, (x0, x1) the extent; along y the other way round.
  auto key = [xy](const TexelRect& r) {
    return xy ? std::array{r.y0, r.y1, r.x0, r.x1} : std::array{r.x0, r.x1, r.y0, r.y1};
  };
  std::sort(rects.begin(), rects.end(),
            [&](const TexelRect& a, const TexelRect& b) { return key(a) < key(b); });
  std::size_t n = 0;
  for (const TexelRect& r : rects) {
    const auto k = key(r);
    if (n > 0) {
      const auto prev = key(rects[n - 1]);
      if (prev[0] == k[0] && prev[1] == k[1] && prev[3] == k[2]) {
        (xy ? rects[n - 1].x1 : rects[n - 1].y1) = k[3];
        continue;
      }
    }
    rects[n++] = r;
  }
  rects.resize(n);
}

// Rectangles of one row that touch, merged, then those of one column: fewer scissors and draws.
void mergeRows(std::vector<TexelRect>& rects) {
  mergeAlong(rects, true);
  mergeAlong(rects, false);
}

// The stale texels of `p` inside `rect`.
std::uint64_t staleIn(const CacheCascadePlan& p, const TexelRect& rect) {
  std::uint64_t a = 0;
  for (const TexelRect& r : p.stale) a += r.intersect(rect).area();
  return a;
}

// The tile budget (CacheTileInputs::budgetTexels): of the marked tiles of `p` that need a draw,
// those that fit in `left` texels, in order (held tiles' stale texels first, then the tiles the
// layer does not hold, each in square rings from the camera out: what is drawn stays compact,
// in few pieces); the first that does not fit ends the admission and empties `left`, so no
// later piece or cascade draws past it. Returns the marks admitted.
TileMask admitTiles(const CacheCascadePlan& p, const TileMask& before, std::int64_t res,
                    std::uint64_t& left) {
  struct Candidate {
    bool held;
    double ring;  // the Chebyshev distance from the camera
    double distance2;
    std::int64_t x, y;
    std::uint64_t cost;
  };
  std::vector<Candidate> need;
  const double t = double(tileTexelsOf(res));
  for (std::int64_t y = 0; y < kTileGridSide; ++y) {
    for (std::int64_t x = 0; x < kTileGridSide; ++x) {
      const TexelRect rect = tileRect(before, x, y, res, p.box);
      if (rect.empty() || !p.marked.test(x, y)) continue;
      const bool held = before.test(x, y);
      const std::uint64_t cost = held ? staleIn(p, rect) : rect.area();
      if (cost == 0) continue;
      // The tile's centre from the camera, in texels: both are world-anchored, so the difference
      // is exact enough 10^7 m from the origin.
      const double dx = (double(before.origin.x + x) + 0.5) * t - p.cameraTexel.x;
      const double dy = (double(before.origin.y + y) + 0.5) * t - p.cameraTexel.y;
      need.push_back({held, std::max(std::abs(dx), std::abs(dy)), dx * dx + dy * dy, x, y, cost});
    }
  }
  std::sort(need.begin(), need.end(), [](const Candidate& a, const Candidate& b) {
    if (a.held != b.held) return a.held;
    if (a.ring != b.ring) return a.ring < b.ring;
    if (a.distance2 != b.distance2) return a.distance2 < b.distance2;
    return a.y != b.y ? a.y < b.y : a.x < b.x;
  });
  TileMask admitted = p.marked;
  for (const Candidate& c : need) {
    if (c.cost <= left) {
      left -= c.cost;
      continue;
    }
    left = 0;
    admitted.set(c.x, c.y, false);
  }
  return admitted;
}

// A partial cascade's draw: of its stale rectangles (p.stale) only what lies in marked tiles,
// and every marked tile the layer does not hold, whole (with the gaps of at most kTileGapFill
// tiles between two such in a row); a stale texel in a tile not drawn makes the tile not held.
// With a tile budget (`left` not null: the texels still to spend this frame) only the marked
// tiles admitTiles() admits, and gaps and the bounding rectangle only where they fit.
// p.tiles: what the layer holds after the draw.
void planTiles(CacheCascadePlan& p, const CacheLayerState& layer, std::int64_t res,
               std::uint64_t* left) {
  const TileMask before = heldTiles(layer, p.box, res);
  TileMask after = before;
  const TileMask marked = left != nullptr ? admitTiles(p, before, res, *left) : p.marked;
  std::vector<TexelRect> draw;
  std::uint32_t drawn = 0;
  constexpr std::int64_t side = kTileGridSide;
  for (std::int64_t y = 0; y < side; ++y) {
    // The tiles of this row drawn whole: marked and not held, and the short gaps between them.
    std::array<bool, kTileGridSide> whole{};
    std::int64_t last = -1;
    for (std::int64_t x = 0; x < side; ++x) {
      if (tileRect(before, x, y, res, p.box).empty()) continue;
      if (!marked.test(x, y) || before.test(x, y)) continue;
      if (last >= 0 && x - last - 1 <= kTileGapFill) {
        // A gap's tiles cost texels of their own; with a budget, only where they all fit.
        std::uint64_t gap = 0;
        for (std::int64_t g = last + 1; g < x; ++g) {
          const TexelRect r = tileRect(before, g, y, res, p.box);
          gap += r.area() - (marked.test(g, y) ? staleIn(p, r) : 0u);
        }
        if (left == nullptr || gap <= *left) {
          if (left != nullptr) *left -= gap;
          for (std::int64_t g = last + 1; g < x; ++g) whole[std::size_t(g)] = true;
        }
      }
      whole[std::size_t(x)] = true;
      last = x;
    }
    for (std::int64_t x = 0; x < side; ++x) {
      const TexelRect rect = tileRect(before, x, y, res, p.box);
      if (rect.empty()) {
        after.set(x, y, false);
        continue;
      }
      if (whole[std::size_t(x)]) {
        draw.push_back(rect);
        after.set(x, y, true);
        ++drawn;
        continue;
      }
      const std::size_t first = draw.size();
      bool touched = false;
      for (const TexelRect& r : p.stale) {
        const TexelRect q = r.intersect(rect);
        if (q.empty()) continue;
        touched = true;
        if (marked.test(x, y)) draw.push_back(q);  // held (else drawn whole above)
      }
      if (marked.test(x, y)) {
        after.set(x, y, true);
        if (draw.size() > first) ++drawn;
      } else if (touched) {
        after.set(x, y, false);
      }
    }
  }
  mergeRows(draw);
  // Many pieces (a new window, marks after a cut): one rectangle around them where it is at
  // most twice their area (and, with a budget, what it adds fits). Each caster is then drawn
  // once, not once per piece, and every tile inside it is drawn whole and held.
  if (draw.size() > kTilePiecesBeforeBounds) {
    TexelRect b = draw.front();
    for (const TexelRect& r : draw) {
      b = {std::min(b.x0, r.x0), std::min(b.y0, r.y0), std::max(b.x1, r.x1), std::max(b.y1, r.y1)};
    }
    const std::uint64_t pieces = totalArea(draw);
    if (b.area() <= 2 * pieces && (left == nullptr || b.area() - pieces <= *left)) {
      if (left != nullptr) *left -= b.area() - pieces;
      draw.assign(1, b);
      drawn = 0;
      for (std::int64_t y = 0; y < side; ++y) {
        for (std::int64_t x = 0; x < side; ++x) {
          const TexelRect rect = tileRect(before, x, y, res, p.box);
          if (rect.empty()) continue;
          if (rect.intersect(b) == rect) after.set(x, y, true);
          drawn += rect.intersect(b).empty() ? 0u : 1u;
        }
      }
    }
  }
  p.stale = std::move(draw);
  p.full = false;
  p.staleTexels = totalArea(p.stale);
  p.tiles = after;
  p.tilesMarked = p.marked.count();
  p.tilesDrawn = drawn;
  // Marked tiles in the box not held after the draw: only those the budget left waiting (every
  // admitted one is held; a gap or the rectangle may hold one the budget did not admit).
  p.tilesDeferred = 0;
  for (std::int64_t y = 0; y < side; ++y) {
    for (std::int64_t x = 0; x < side; ++x) {
      if (p.marked.test(x, y) && !after.test(x, y) && !tileRect(before, x, y, res, p.box).empty()) {
        ++p.tilesDeferred;
      }
    }
  }
}

// A cascade that is complete again after being partial: its stale rectangles also cover the
// tiles its layer did not hold.
void completeTiles(CacheCascadePlan& p, const CacheLayerState& layer, std::int64_t res) {
  if (!layer.partial || !layer.staticValid || p.full) return;
  const TileMask held = heldTiles(layer, p.box, res);
  for (std::int64_t y = 0; y < kTileGridSide; ++y) {
    for (std::int64_t x = 0; x < kTileGridSide; ++x) {
      const TexelRect rect = tileRect(held, x, y, res, p.box);
      if (!rect.empty() && !held.test(x, y)) addDisjoint(p.stale, rect);
    }
  }
  p.staleTexels = totalArea(p.stale);
}

// The tiles of cascade i in `frame`, or its completion, after its stale rectangles are planned.
void planCascadeTiles(CacheCascadePlan& p, const CacheLayerState& layer, std::int64_t res,
                      std::uint64_t* left = nullptr) {
  if (p.partial) {
    planTiles(p, layer, res, left);
  } else {
    p.tiles = {};
    completeTiles(p, layer, res);
  }
}

}  // namespace

bool cacheBoxHoldsSphere(const TexelRect& box, double texel, const glm::dmat3& basis,
                         double zNearLs, double zFarLs, double marginM,
                         const Cascade& inner) noexcept {
  const glm::dvec3 s = glm::transpose(basis) * inner.sphereCenterWs;
  const double r = inner.sphereRadiusM + marginM;
  return s.x - r >= double(box.x0) * texel && s.x + r <= double(box.x1) * texel &&
         s.y - r >= double(box.y0) * texel && s.y + r <= double(box.y1) * texel &&
         s.z - inner.sphereRadiusM >= zNearLs && s.z + inner.sphereRadiusM <= zFarLs;
}

CachePlan planCacheFrame(CascadeFrame& frame, CacheState& state, std::uint32_t resolution,
                         std::uint64_t budgetTexels, std::uint32_t exactCascades,
                         const CacheTileInputs* tiles) {
  CachePlan plan;
  if (frame.resolution != resolution || resolution == 0) return plan;
  const std::uint32_t count = std::min(frame.cascadeCount, kMaxCascades);
  plan.cascadeCount = count;
  plan.resolution = resolution;
  const std::int64_t res = resolution;
  const glm::dmat3& basis = frame.lightBasisWs;
  const glm::dmat3 basisT = glm::transpose(basis);
  // Windows: kept or opened; the stale texels of each layer, deferred or not.
  std::array<CacheRefreshCandidate, kMaxCascades> candidates{};
  for (std::uint32_t i = 0; i < count; ++i) {
    Cascade& c = frame.cascades[i];
    CacheCascadePlan& p = plan.cascades[i];
    if (c.empty) continue;
    p.active = true;
    CacheLayerState& layer = state.layers[i];
    const double texel = c.texelSizeLs.x;
    const glm::dvec3 centerLs = basisT * c.boxCenterWs;
    const std::int64_t boxX = cacheBoxStart(centerLs.x, texel, res);
    const std::int64_t boxY = cacheBoxStart(centerLs.y, texel, res);
    CacheWindowPlacement placed = layer;
    if (placeCacheWindow(placed, texel, frame.lightDirectionWs, boxX, boxY,
                         centerLs.z + c.depthNearLs, centerLs.z + c.depthFarLs)) {
      // A new window: the static layer holds nothing of it yet.
      const std::uint64_t whole = layer.wholeInvalidations;
      layer = CacheLayerState{};
      static_cast<CacheWindowPlacement&>(layer) = placed;
      layer.wholeInvalidations = whole;
    }
    p.newWindow = !layer.staticValid;
    p.covered = cacheShownCovers(state.shown[i], c, basis);
    c.depthNearLs = layer.zNear - centerLs.z;
    c.depthFarLs = layer.zFar - centerLs.z;
    c.viewProjCr = cameraRelativeViewProj(basis, frame.cameraPositionWs, c);
    p.box = {boxX, boxY, boxX + res, boxY + res};
    planStale(p, layer, p.box, basisT, res);
  }
  // Receiver-marked tiles: the cascades the last one can stand in for draw only marked tiles.
  std::int64_t last = -1;
  bool shownAny = false;
  for (std::uint32_t i = 0; i < count; ++i) {
    if (plan.cascades[i].active) last = i;
    shownAny = shownAny || state.shown[i].valid;
  }
  // The tile budget: what the partial cascades before the last may still draw this frame.
  const bool budget = tiles != nullptr && tiles->budgetTexels != 0;
  plan.tileBudgetTexels = budget ? tiles->budgetTexels : 0;
  std::uint64_t left = plan.tileBudgetTexels;
  const bool hasMarks = tiles != nullptr && tiles->marks != nullptr && tiles->marks->present();
  // The view's first frame (no layer shown yet: the start, or a new image) without marks draws
  // every cascade whole, as the cache alone does: no depth buffer has been marked, and a frame
  // that pays for every cascade anyway spares the next one the marked tiles of all of them.
  const bool first = tiles != nullptr && !shownAny && !hasMarks;
  bool anyPartial = false;
  for (std::uint32_t i = 0; tiles != nullptr && !first && std::int64_t(i) < last; ++i) {
    CacheCascadePlan& p = plan.cascades[i];
    if (!p.active) continue;
    const auto l = std::uint32_t(last);
    const double texelL = frame.cascades[l].texelSizeLs.x;
    const double margin = (tiles->reachTexels[l] + 2.0) * texelL;
    p.partial = cacheBoxHoldsSphere(plan.cascades[l].box, texelL, basis, state.layers[l].zNear,
                                    state.layers[l].zFar, margin, frame.cascades[i]);
    anyPartial = anyPartial || p.partial;
  }
  for (std::uint32_t i = 0; i < count; ++i) {
    CacheCascadePlan& p = plan.cascades[i];
    if (!p.active) continue;
    const Cascade& c = frame.cascades[i];
    const bool isLast = std::int64_t(i) == last;
    if (tiles != nullptr && !first && (isLast || p.partial)) {
      // What the view's frustum can sample, this frame, from the depth the lighting reads the
      // cascade at (its slice and the blend band before it); for the last cascade, with a
      // partial one, every depth: every pixel that falls back reads it.
      const double texel = c.texelSizeLs.x;
      TileMask view = tileGridOf(p.box, res);
      const bool seen = markFrustumTiles(
          frame,
          isLast && anyPartial ? frame.splitsM[0] : cascadeReadFromM(frame, i, frame.blendBand),
          frame.splitsM[i + 1], basis, texel, tileTexelsOf(res), tiles->reachTexels[i] * texel,
          view);
      if (isLast && seen) {
        p.partial = true;
        p.marked = view;
      } else if (p.partial) {
        p.marked = tileGridOf(p.box, res);
        if (hasMarks) {
          // Across a light step a marked column's receivers lie in the cascade's sphere.
          const double z = (glm::transpose(tiles->marks->lightBasisWs) * c.sphereCenterWs).z;
          const double r = 1.25 * c.sphereRadiusM;
          carryTileMarks(*tiles->marks, i, basis, texel, tileTexelsOf(res), z - r, z + r, p.marked);
          // The receivers a slice holds move with the camera: the marks also where the camera's
          // move since they were taken carries them.
          const glm::dvec3 moved = frame.cameraPositionWs - tiles->marks->cameraPositionWs;
          if (moved != glm::dvec3(0.0)) {
            TileMask ahead = p.marked;
            carryTileMarks(*tiles->marks, i, basis, texel, tileTexelsOf(res), z - r, z + r, ahead,
                           moved);
            for (std::uint32_t w = 0; w < kTileWords; ++w) p.marked.bits[w] |= ahead.bits[w];
          }
          // Of those, only what this frame's view can sample.
          if (seen) {
            for (std::uint32_t w = 0; w < kTileWords; ++w) p.marked.bits[w] &= view.bits[w];
          }
        } else if (seen && state.unmarkedFrames > 0) {
          // No marks since the frame before (the marks of the first depth buffer after a cut
          // are still on their way): what the view can sample. Only the first frame without
          // marks falls back.
          p.marked = view;
        }
      }
    }
    p.cameraTexel = glm::dvec2(basisT * frame.cameraPositionWs) / c.texelSizeLs.x;
    planCascadeTiles(p, state.layers[i], res, budget && !isLast ? &left : nullptr);
    const CacheShownState& sh = state.shown[i];
    candidates[i] = {true, sh.valid, sh.lagFrames, p.covered, p.staleTexels};
  }
  if (tiles != nullptr) {
    state.unmarkedFrames = hasMarks ? 0 : std::min(state.unmarkedFrames + 1, 1u << 30);
  }
  // The budget: refreshed cascades show this frame; deferred ones what they showed. With tiles
  // the last cascade, the fallback, is always refreshed.
  plan.refreshedMask =
      scheduleCacheRefresh(std::span(candidates.data(), count), budgetTexels, exactCascades);
  if (tiles != nullptr && last >= 0) plan.refreshedMask |= 1u << std::uint32_t(last);
  for (std::uint32_t i = 0; i < count; ++i) {
    CacheCascadePlan& p = plan.cascades[i];
    if (!p.active) continue;
    CacheShownState& sh = state.shown[i];
    Cascade& c = frame.cascades[i];
    p.refreshed = ((plan.refreshedMask >> i) & 1u) != 0;
    if (p.refreshed) {
      sh.valid = true;
      sh.lagFrames = 0;
      sh.window = state.layers[i];
      sh.cascade = c;
      sh.basis = basis;
      sh.partial = p.partial;
      sh.tiles = p.tiles;
    } else {
      ++sh.lagFrames;
      c = sh.cascade;
      c.viewProjCr = cameraRelativeViewProj(sh.basis, frame.cameraPositionWs, c);
      p.stale.clear();  // a deferred cascade draws none of it
      p.full = false;
      const glm::dvec3 shownLs = glm::transpose(sh.basis) * c.boxCenterWs;
      const std::int64_t bx = cacheBoxStart(shownLs.x, sh.window.texel, res);
      const std::int64_t by = cacheBoxStart(shownLs.y, sh.window.texel, res);
      p.box = {bx, by, bx + res, by + res};
      p.partial = sh.partial;
      p.tiles = sh.tiles;
      p.tilesDrawn = 0;
    }
    p.lagFrames = sh.lagFrames;
    p.basis = sh.basis;
    p.wrapX = floorMod(p.box.x0 - sh.window.anchorX, res);
    p.wrapY = floorMod(p.box.y0 - sh.window.anchorY, res);
  }
  return plan;
}

void updateCacheStale(CachePlan& plan, const CacheState& state) {
  const std::int64_t res = plan.resolution;
  auto changed = [&](std::uint32_t i) {
    const CacheCascadePlan& p = plan.cascades[i];
    const CacheLayerState& layer = state.layers[i];
    return p.active && p.refreshed &&
           (layer.pending.size() != p.pendingPlanned ||
            layer.wholeInvalidations != p.wholeInvalidations);
  };
  std::uint32_t last = 0;
  bool any = false;
  for (std::uint32_t i = 0; i < plan.cascadeCount; ++i) {
    if (plan.cascades[i].active) last = i;
    any = any || changed(i);
  }
  if (!any) return;
  // With a tile budget the partial cascades share it in order: re-plan each of them (the same
  // plan where nothing before it changed) so that what one now draws more, a later one draws
  // less.
  const bool budget = plan.tileBudgetTexels != 0;
  std::uint64_t left = plan.tileBudgetTexels;
  for (std::uint32_t i = 0; i < plan.cascadeCount; ++i) {
    CacheCascadePlan& p = plan.cascades[i];
    if (!p.active || !p.refreshed) continue;
    const bool shared = budget && p.partial && i != last;
    if (!changed(i) && !shared) continue;
    const CacheLayerState& layer = state.layers[i];
    planStale(p, layer, p.box, glm::transpose(p.basis), res);
    planCascadeTiles(p, layer, res, shared ? &left : nullptr);
    p.newWindow = !layer.staticValid;
  }
}

void markCacheRecorded(const CachePlan& plan, CacheState& state) {
  for (std::uint32_t i = 0; i < plan.cascadeCount; ++i) {
    const CacheCascadePlan& p = plan.cascades[i];
    CacheLayerState& layer = state.layers[i];
    if (!p.active || !p.refreshed || layer.wholeInvalidations != p.wholeInvalidations) continue;
    layer.staticValid = true;
    layer.boxX = p.box.x0;
    layer.boxY = p.box.y0;
    layer.partial = p.partial;
    layer.tiles = p.tiles;
    state.shown[i].partial = p.partial;
    state.shown[i].tiles = p.tiles;
    const std::size_t done = std::min(p.pendingPlanned, layer.pending.size());
    layer.pending.erase(layer.pending.begin(),
                        layer.pending.begin() + static_cast<std::ptrdiff_t>(done));
  }
}

void invalidateCache(CacheState& state, const AabbWs& boxWs) {
  for (CacheLayerState& layer : state.layers) {
    if (!layer.staticValid) continue;  // re-rendered whole anyway
    if (layer.pending.size() >= 64) {
      layer.staticValid = false;  // many boxes: one full render
      layer.pending.clear();
      ++layer.wholeInvalidations;
    } else {
      layer.pending.push_back(boxWs);
    }
  }
}

void invalidateCacheAll(CacheState& state) noexcept {
  for (CacheLayerState& layer : state.layers) {
    layer.staticValid = false;
    layer.pending.clear();
    ++layer.wholeInvalidations;
  }
}

}  // namespace csm
