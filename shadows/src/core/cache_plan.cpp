#include "csm/cache_plan.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

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

}  // namespace csm
