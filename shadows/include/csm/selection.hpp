// Cascade selection for a receiver, as the lighting shader does it (csm.glsl mirrors this).
#pragma once

#include "csm/cascades.hpp"

namespace csm {

/// Which cascade shades a receiver, and how much of the next one is blended in.
struct CascadeSelection {
  /// Cascade index, or -1 when the receiver lies outside every non-empty cascade (lit).
  int index = -1;
  /// Cascade blended in across the band at the far end of `index`, or -1 for none.
  int blendIndex = -1;
  /// Weight of `blendIndex` in [0, 1]: 0 at the band's start, 1 at the split.
  float blendWeight = 0.0f;
};

/// Selects by view depth: cascade i covers [split_i, split_{i+1}); inside the last
/// `blendBand * (split_{i+1} - split_i)` metres before split_{i+1}, cascade i+1 is blended in
/// linearly (if it exists and is not empty). Depth outside [split_0, split_N) or in an empty
/// cascade gives index -1.
[[nodiscard]] CascadeSelection selectCascade(const CascadeFrame& frame, double viewDepthM,
                                             double blendBand) noexcept;

/// The view depth from which the lighting reads cascade i (selectCascade with `blendBand`):
/// split_0 for cascade 0, else where the blend band of cascade i - 1 starts (split_i itself
/// without a band).
[[nodiscard]] double cascadeReadFromM(const CascadeFrame& frame, std::uint32_t i,
                                      double blendBand) noexcept;

/// How far a receiver at `viewDepthM` has faded to lit, in [0, 1]: 0 before
/// fadeEndM - fadeLengthM, rising as smoothstep to 1 at frame.fadeEndM (and beyond). The
/// shadow factor becomes mix(s, 1, shadowFade()). Always 0 when fadeLengthM is 0 (no fade).
/// csm.glsl's csmFade() mirrors it.
[[nodiscard]] double shadowFade(const CascadeFrame& frame, double viewDepthM) noexcept;

/// View depth of a world point for this frame: dot(posWs - cameraPositionWs, cameraForwardWs).
[[nodiscard]] double viewDepthM(const CascadeFrame& frame, const glm::dvec3& posWs) noexcept;

}  // namespace csm
