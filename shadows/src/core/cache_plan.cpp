#include "csm/cache_plan.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

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

}  // namespace

CachePlan planCacheFrame(CascadeFrame& frame, CacheState& state, std::uint32_t resolution,
                         std::uint64_t budgetTexels, std::uint32_t exactCascades) {
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
    const CacheShownState& sh = state.shown[i];
    candidates[i] = {true, sh.valid, sh.lagFrames, p.covered, p.staleTexels};
  }
  // The budget: refreshed cascades show this frame; deferred ones what they showed.
  plan.refreshedMask =
      scheduleCacheRefresh(std::span(candidates.data(), count), budgetTexels, exactCascades);
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
  for (std::uint32_t i = 0; i < plan.cascadeCount; ++i) {
    CacheCascadePlan& p = plan.cascades[i];
    const CacheLayerState& layer = state.layers[i];
    if (!p.active || !p.refreshed) continue;
    if (layer.pending.size() == p.pendingPlanned &&
        layer.wholeInvalidations == p.wholeInvalidations) {
      continue;
    }
    planStale(p, layer, p.box, glm::transpose(p.basis), res);
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
