// The cache's per-frame decisions, as plain arithmetic: whether a cascade keeps its world-
// anchored window (texel grid and depth range) or opens a new one, and which cascades a texel
// budget refreshes this frame. The renderer's cached pass (csm::vk, RendererOptions::cache)
// applies them; see shadows/docs/cache.md.
#pragma once

#include <cstdint>
#include <span>

#include <glm/vec3.hpp>

namespace csm {

/// A cascade's world-anchored window: the texel size and light direction it was opened with,
/// the world texel index drawn at layer texel (0, 0) (the layer is toroidal from there), and
/// its absolute light-space depth range.
struct CacheWindowPlacement {
  bool valid = false;
  double texel = 0.0;
  glm::dvec3 lightDirection{0.0};
  std::int64_t anchorX = 0, anchorY = 0;
  double zNear = 0.0, zFar = 0.0;
};

/// The world texel index of the first texel of a box of `res` texels a side centred at
/// light-space x, y `centerLs` on a grid of `texel` metres: round(center / texel) - res / 2.
[[nodiscard]] std::int64_t cacheBoxStart(double centerLs, double texel, std::int64_t res) noexcept;

/// Keeps `window` while it serves a cascade with texels of `texel` metres under the light
/// `lightDirection` whose depths [needNearLs, needFarLs] (absolute, light space) it must hold:
/// the same texel and light, the needed range inside its depth window, and that window at most
/// 2.5 times the range (else depth precision would be wasted). Otherwise opens a new window
/// anchored at (boxX, boxY), its depth window the needed range rounded out to multiples of a
/// quarter of it plus a quarter of margin each side (so that it stays while the box's depth
/// follows the camera). Returns whether it opened a new window (the layer is re-rendered).
bool placeCacheWindow(CacheWindowPlacement& window, double texel, const glm::dvec3& lightDirection,
                      std::int64_t boxX, std::int64_t boxY, double needNearLs, double needFarLs);

/// One cascade as the texel budget sees it.
struct CacheRefreshCandidate {
  bool active = false;            // non-empty this frame
  bool shown = false;             // its layer shows an earlier refresh
  std::uint32_t lagFrames = 0;    // frames since that refresh
  bool covered = true;            // what it shows still covers this frame's slice
  std::uint64_t staleTexels = 0;  // what refreshing it renders
};

/// The cascades refreshed this frame (bit i for cascade i); the other active ones keep showing
/// their last refresh. With no budget (0) every active cascade. Else the first `exactCascades`
/// and any never shown whatever they cost; then the others, most stale first (frames of lag,
/// one more for a cascade that no longer covers its slice, and among equals the uncovered
/// first, then the nearer), each while its stale texels fit what is left of the budget (a
/// cascade that does not fit is passed over, not waited for).
[[nodiscard]] std::uint32_t scheduleCacheRefresh(std::span<const CacheRefreshCandidate> cascades,
                                                 std::uint64_t budgetTexels,
                                                 std::uint32_t exactCascades);

}  // namespace csm
