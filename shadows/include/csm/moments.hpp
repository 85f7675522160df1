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
//    Stored as 32-bit floats, or in 64 bits quantised (msmQuantize).
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

/// The footprint a mip read of the moments may take (level-0 texels: the axis whose mip it reads):
/// `wanted` (the pixel's), but no wider than keeps what the read averages (the texels within 3
/// footprints: the coarser level's texel is at most 2 footprints wide and bilinear reaches 1.5 of
/// them) inside
///  - the cascade's box: `edgeTexels` from its nearest edge (beyond it the sampler clamps to the
///    edge texel or, in a cached layer, wraps to the other side of the box);
///  - the stored depth range along the receiver's plane: a receiver at `depth` on a plane of
///    `slopePerTexel` meets depth 0 depth / |slope| texels away, where the shadow pass clamped the
///    plane's nearer texels to 0 (a sun near the horizon over ground reaching past the light's
///    box): read in, they are occluders, and darkened lit ground at the far corners of a cascade.
/// At least 1 (level 0, whose lookups csm.glsl filters by hand). Never NaN for finite input.
[[nodiscard]] float momentReadFootprint(float wanted, float edgeTexels, float depth,
                                        const glm::vec2& slopePerTexel) noexcept;

/// The depth spread of a planar receiver over what a mip read averages, in stored depth (one
/// standard deviation): a read of footprint `footprintTexels` level-0 texels (r, the axis whose
/// mip it reads; momentReadFootprint) reads the mip of r, whose box texels and bilinear and
/// trilinear weights average the moments of texels about sqrt(r^2 / 3) texels from it (at most, per
/// axis, over every sub-texel position and fraction of the level). Beyond level 0 (which the normal
/// offset and the depth floor already cover): sqrt((r^2 - 1) / 3) texels times the plane's change
/// of depth per texel
/// (`slopePerTexel`, csm.glsl's csmReceiverDepthSlope). 0 at r <= 1. Never NaN.
[[nodiscard]] float momentFootprintSpread(const glm::vec2& slopePerTexel,
                                          float footprintTexels) noexcept;

/// How far toward the light a receiver's compared depth moves when it reads a mip, so that a lit
/// plane reads lit however far its footprint spreads its depths (spread: momentFootprintSpread):
///  - msm one spread: the Hamburger reconstruction reads a plane's spread-out depths as partly
///    in front of its centre (a plane needs up to 0.84 spreads to read 0.99);
///  - evsm min(c- spread, 1) spreads (c-: settings.evsmNegativeExponent): the negative warp's
///    Jensen gap, e^(-c w) averaged over the spread exceeds its value at the centre, which a
///    receiver c- spread^2 further forward matches for a normal spread;
///  - vsm none: Chebyshev reads a receiver at the mean of any spread as lit, and a plane's
///    filtered mean is its centre's depth.
[[nodiscard]] float momentReceiverShift(PcfKernel kernel, const glm::vec2& slopePerTexel,
                                        float footprintTexels,
                                        const ShadowSettings& settings) noexcept;

/// Chebyshev's one-sided upper bound on the lit fraction: 1 in front of the mean.
[[nodiscard]] float chebyshevUpperBound(float mean, float meanSquare, float depth,
                                        float minVariance) noexcept;

/// MSM's Hamburger reconstruction: the occluded fraction's lower bound for a receiver at `depth`
/// from four power moments (biased already). In [0, 1].
[[nodiscard]] float hamburgerShadowIntensity(const glm::vec4& moments, float depth) noexcept;

/// Radius of the moment blur in texels of a cascade of `texelM` metres: momentBlurM / texelM,
/// at most CSM_MOMENT_MAX_BLUR_TEXELS. 0 when either is not positive.
[[nodiscard]] float momentBlurRadiusTexels(double momentBlurM, double texelM) noexcept;

/// MSM's 64-bit storage (RGBA16_UNORM): the centred moments (w, w^2, w^3, w^4) of depthMoments
/// mapped by Peters and Klein's optimised quantisation (CSM_MSM_QUANTIZE_*) into [0, 1]^4,
/// clamped as the format's store clamps. Affine, so filtering quantised moments and then
/// decoding them (msmDequantize) gives the filtered moments, to the format's rounding.
[[nodiscard]] glm::vec4 msmQuantize(const glm::vec4& centred) noexcept;

/// The centred moments from quantised ones (the inverse of msmQuantize before the clamp).
[[nodiscard]] glm::vec4 msmDequantize(const glm::vec4& quantized) noexcept;

/// The smallest moment bias (ShadowSettings::msmMomentBias) csm.glsl applies to 64-bit MSM moments:
/// the format's rounding (1/65535 per channel, up to about 1e-5 in the decoded moments) needs
/// about twice the 32-bit default (Peters and Klein recommend 6e-5 with this quantisation).
inline constexpr float kMsmQuantizedMinMomentBias = 6e-5f;

/// Bytes a texel of the moment image takes for `kernel`, `compact` where the device stores the
/// smaller formats (csm::vk::DeviceInfo::storageImageExtendedFormatsEnabled and the format's
/// support; for msm also RendererOptions::msmMomentBits = 64): vsm 8 (RG32F, the same bits as
/// RGBA32F's first two channels), msm 8 (RGBA16_UNORM, quantised: msmQuantize); otherwise 16
/// (evsm always: four exponential moments need 32-bit floats). 0 for a percentage-closer kernel.
[[nodiscard]] std::uint32_t momentTexelBytes(PcfKernel kernel, bool compact) noexcept;

/// Device memory of the moment images for `settings` (0 when the kernel is not prefiltered):
/// the mip-mapped moment array, momentTexelBytes(settings.kernel, compact) a texel.
[[nodiscard]] std::uint64_t momentImageBytes(const ShadowSettings& settings, bool compact) noexcept;

}  // namespace csm
