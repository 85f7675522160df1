// Frustum slices and their minimal bounding spheres, from camera parameters (no matrix inverse).
#pragma once

#include <array>

#include "csm/types.hpp"

namespace csm {

/// The 8 corners of the slice [nearM, farM] of a camera's view frustum, relative to the camera
/// position, in world orientation ("camera-relative world space", Cr). Order: near plane
/// (-x-y, +x-y, +x+y, -x+y), then the far plane in the same order.
[[nodiscard]] std::array<glm::dvec3, 8> sliceCornersCr(const Camera& camera, double nearM,
                                                       double farM) noexcept;

/// Bounding sphere of a slice, described along the view axis: the centre lies on the axis at
/// view depth `centerDepthM`; `radiusM` is the exact minimal radius.
struct SliceSphere {
  double centerDepthM = 0.0;
  double radiusM = 0.0;
};

/// The minimal bounding sphere of the symmetric perspective slice [nearM, farM] of a frustum
/// with the given vertical FOV and aspect. Closed form: with k^2 = tan^2(fovY/2)(1 + aspect^2),
/// the centre is at z = (n + f)(1 + k^2) / 2 when that is < f (equidistant from near and far
/// corners), else at the far cap's centre with radius f*k. Depends on the slice alone, never on
/// the camera's orientation.
[[nodiscard]] SliceSphere minimalSliceSphere(double fovYRad, double aspect, double nearM,
                                             double farM) noexcept;

/// Rounds a positive length up to the grid 2^(floor(log2 x) - 16): at most ~0.0015% larger, and
/// identical for inputs that differ only by float noise below that step. Texel size 2r/res
/// stays exactly representable.
[[nodiscard]] double quantizeLengthUp(double lengthM) noexcept;

}  // namespace csm
