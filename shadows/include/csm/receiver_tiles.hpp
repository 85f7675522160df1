// Receiver-marked tiles: which tiles of each cascade the visible receivers of a frame sample
// (csm::ReceiverTileMarks). The GPU builds them from the host's depth buffer
// (csm::vk::DepthRangeReducer with ReceiverBoundsInputs::tiles); these are the same rules on the
// CPU, in double, for tests and hosts with their own reduction.
#pragma once

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

}  // namespace csm
