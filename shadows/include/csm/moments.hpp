// The prefiltered filters' math (PcfKernel::kVsm, kEvsm, kMsm), on the CPU: what csm_moments.comp
// stores per texel and what csm.glsl reconstructs from the filtered moments. Pure (no Vulkan);
// the GLSL mirrors these functions line for line, and the tests check both against each other
// and against exact answers (a single depth, two depths in known proportion).
//
// Depth z is the stored depth in [0, 1] (0 nearest the light).
//  - vsm: (z, z^2). Lit fraction: Chebyshev's one-sided bound, sigma^2 / (sigma^2 + (z_r - mu)^2)
//    for a receiver behind the mean, floored variance.
//  - evsm: depth warped to w = 2z - 1 in [-1, 1], then (e^(c+ w), e^(2 c+ w), -e^(-c- w),
//    e^(-2 c- w)): Chebyshev on each warp, the smaller bound wins (Lauritzen's EVSM).
//  - msm: (w, w^2, w^3, w^4) of w = 2z - 1 (centred: better conditioned in 32-bit floats), mixed
//    with a uniform distribution's moments by the moment bias, then
//    the Hamburger reconstruction (Peters and Klein 2015): the three-point distribution with a
//    point at the receiver that matches the moments bounds the occluded fraction from below.
// Every lit fraction then goes through the light-bleeding reduction:
// clamp((p - r) / (1 - r), 0, 1).
#pragma once

#include <glm/glm.hpp>

#include <cstdint>

#include "csm/types.hpp"

namespace csm {

/// The moments a texel of depth `depth` stores for prefiltered filter `kernel` (zero for a
/// percentage-closer kernel). EVSM's exponents from `settings`.
[[nodiscard]] glm::vec4 depthMoments(PcfKernel kernel, float depth,
                                     const ShadowSettings& settings) noexcept;

/// The lit fraction in [0, 1] a receiver at `depth` reads from filtered `moments` (bleeding
/// reduction applied). `minVariance`: the variance floor in units of stored depth squared
/// (vsm and evsm; csm.glsl uses a quarter texel of the cascade's depth slope; vsm takes at least
/// CSM_VSM_MIN_VARIANCE). Never NaN.
[[nodiscard]] float momentLitFraction(PcfKernel kernel, const glm::vec4& moments, float depth,
                                      float minVariance, const ShadowSettings& settings) noexcept;

/// Chebyshev's one-sided upper bound on the lit fraction: 1 in front of the mean.
[[nodiscard]] float chebyshevUpperBound(float mean, float meanSquare, float depth,
                                        float minVariance) noexcept;

/// MSM's Hamburger reconstruction: the occluded fraction's lower bound for a receiver at `depth`
/// from four power moments (biased already). In [0, 1].
[[nodiscard]] float hamburgerShadowIntensity(const glm::vec4& moments, float depth) noexcept;

/// Radius of the moment blur in texels of a cascade of `texelM` metres: momentBlurM / texelM,
/// at most CSM_MOMENT_MAX_BLUR_TEXELS. 0 when either is not positive.
[[nodiscard]] float momentBlurRadiusTexels(double momentBlurM, double texelM) noexcept;

/// Device memory of the moment images for `settings` (0 when the kernel is not prefiltered):
/// the mip-mapped moment array and the blur's scratch (level 0 of one layer), RGBA32F each.
[[nodiscard]] std::uint64_t momentImageBytes(const ShadowSettings& settings) noexcept;

}  // namespace csm
