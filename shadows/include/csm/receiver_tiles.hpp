// Receiver-marked tiles: which tiles of each cascade the visible receivers of a frame sample
// (csm::ReceiverTileMarks). The GPU builds them from the host's depth buffer
// (csm::vk::DepthRangeReducer with ReceiverBoundsInputs::tiles); these are the same rules on the
// CPU, in double, for tests and hosts with their own reduction.
#pragma once

#include <array>
#include <cstdint>
#include <utility>

#include "csm/cascades.hpp"
#include "csm/types.hpp"

namespace csm {

/// How far (texels of cascade i) from a receiver's light-space x, y the filter of `settings`
/// can read in cascade i of `frame`, so that marking the tiles within that reach of every
/// receiver marks every texel the lighting reads:
/// - PCF kernels: the kernel's reach (csm::kernelRadiusTexels, its taps spread by the
///   world-space kernel's scale) plus the normal offset's shift in x, y (at most
///   normalOffsetTexels x sqrt 2 texels);
/// - PCSS: the blocker search (the widest penumbra radius, at least a texel) plus its bilinear
///   tap (CSM_KERNEL_RADIUS_PCSS); its normal offset only lifts the depth;
/// - vsm, evsm, msm: level 0's bilinear tap, the moment blur's radius and the normal offset. A
///   minified tap (a mip level above 0) reads a wider area: those are not in the reach.
/// 0 for an empty cascade or one out of range.
[[nodiscard]] double receiverSampleReachTexels(const ShadowSettings& settings,
                                               const CascadeFrame& frame, std::uint32_t i) noexcept;

/// No tile marked yet, for receivers of `frame` (its cascades, splits, light basis and boxes)
/// filtered as `settings` says (receiverSampleReachTexels).
[[nodiscard]] ReceiverTileMarks emptyReceiverTileMarks(const ShadowSettings& settings,
                                                       const CascadeFrame& frame) noexcept;

/// The cascades a receiver at view depth `viewDepthM` is shaded with: the one the lighting
/// selects (first: the first non-empty cascade whose [splitsM[i], splitsM[i + 1]) holds the
/// depth, -1 for none: lit) and, inside that cascade's blend band, the next (second; -1 for none).
[[nodiscard]] std::pair<int, int> shadingCascades(const ReceiverTileMarks& marks,
                                                  double viewDepthM) noexcept;

/// Marks the tiles of cascade `i` that the light-space rectangle [minLs, maxLs] (x, y about the
/// world origin), widened by the cascade's reachM, touches. The GPU marks so per 16x16 block of
/// pixels and cascade, with the rectangle of the block's receivers shaded with it.
void markTileRect(ReceiverTileMarks& marks, std::uint32_t i, const glm::dvec2& minLs,
                  const glm::dvec2& maxLs) noexcept;

/// Marks the tiles one visible receiver samples: world position `posWs` (double) at view depth
/// `viewDepthM` (as the lighting shader computes it), in the cascades shadingCascades() names.
/// Returns the cascade it is shaded with, or -1 (no cascade holds the depth: it is lit).
int markReceiverTiles(ReceiverTileMarks& marks, const glm::dvec3& posWs,
                      double viewDepthM) noexcept;

/// One bit per tile of a cascade's tile grid (ReceiverTileMarks' layout: kTileGridSide^2 tiles
/// of resolution / kTilesPerSide texels on the cascade's world-anchored texel grid, bit
/// y * kTileGridSide + x for grid tile (x, y), whose world tile index is origin + (x, y)). The
/// cached renderer keeps one per cascade with RendererOptions::tiles: the tiles its layer holds.
struct TileMask {
  glm::i64vec2 origin{0};
  std::array<std::uint32_t, kTileWords> bits{};

  [[nodiscard]] bool test(std::int64_t x, std::int64_t y) const noexcept {
    if (x < 0 || y < 0 || x >= kTileGridSide || y >= kTileGridSide) return false;
    const auto b = std::uint32_t(y * kTileGridSide + x);
    return (bits[b / 32] >> (b % 32)) & 1u;
  }
  void set(std::int64_t x, std::int64_t y, bool on = true) noexcept {
    if (x < 0 || y < 0 || x >= kTileGridSide || y >= kTileGridSide) return;
    const auto b = std::uint32_t(y * kTileGridSide + x);
    bits[b / 32] = on ? bits[b / 32] | (1u << (b % 32)) : bits[b / 32] & ~(1u << (b % 32));
  }
  /// Whether world tile (wx, wy) is in the grid and set.
  [[nodiscard]] bool testWorld(std::int64_t wx, std::int64_t wy) const noexcept {
    return test(wx - origin.x, wy - origin.y);
  }
  [[nodiscard]] std::uint32_t count() const noexcept;
  friend bool operator==(const TileMask&, const TileMask&) = default;
};

/// The tiles of cascade `i` of `marks`, carried onto the grid of `mask.origin` (its bits are
/// replaced): tiles of `tileTexels` texels of `texelM` metres on the light-space grid of basis
/// `basis` (world -> light space: transpose(basis)). Where the marks were taken in the same
/// basis, texel and tile size, the same world tiles. Else (a light step, another ladder rung) a
/// marked tile stands for receivers anywhere in its column between light-space depths zNearLs and
/// zFarLs of the marks' basis; every tile of the new grid that column's light-space x, y touch
/// is marked (a conservative superset: a column tilted by the step's angle). With `shiftWs`
/// (world metres) every marked column is moved by it first. No marks for a cascade the marks do
/// not hold or left empty.
void carryTileMarks(const ReceiverTileMarks& marks, std::uint32_t i, const glm::dmat3& basis,
                    double texelM, std::int64_t tileTexels, double zNearLs, double zFarLs,
                    TileMask& mask, const glm::dvec3& shiftWs = glm::dvec3(0.0)) noexcept;

/// The tiles of a cascade that a receiver inside `frame`'s view frustum, at a view depth in
/// [nearM, farM], can sample with a filter reading up to `reachM` metres around its light-space
/// x, y: every tile of `mask`'s grid (its bits are replaced; tiles of `tileTexels` texels of
/// `texelM` metres on the light-space grid of basis `basis`) that the frustum section's
/// light-space outline, widened by reachM and a texel on every side, touches. Exact and
/// conservative in the same frame (no depth buffer, no lag), but blind to what hides the
/// receivers: the sky, and what lies behind the nearest surface, are marked too. False, and no
/// tile marked, when the frame does not carry its camera's frustum (cameraTanHalfFovY or
/// cameraAspect 0: a frame built by hand) or an input is not finite or out of range.
bool markFrustumTiles(const CascadeFrame& frame, double nearM, double farM, const glm::dmat3& basis,
                      double texelM, std::int64_t tileTexels, double reachM,
                      TileMask& mask) noexcept;

}  // namespace csm
