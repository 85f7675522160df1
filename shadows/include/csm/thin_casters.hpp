// How much the depth pass widens a thin caster (csm::vk::CasterInstance::thin) in a cascade, as
// plain arithmetic: the renderer's geometry stage (csm_depth_thin.geom) draws each thin caster
// with this rim, and culling and the cache grow its bounds by the most it can be. See
// shadows/docs/thin_casters.md.
#pragma once

namespace csm {

/// A thin caster at least this many texels wide is widened to a full texel in that cascade.
inline constexpr double kThinFullTexelMinWidthTexels = 0.5;
/// The most the width rule widens by, each side, in texels: (1 - 0.5) / 2.
inline constexpr float kThinWidthRuleMaxTexels = 0.25f;
/// The largest true width accepted for a thin caster, metres (CasterInstance::thinWidthM).
inline constexpr float kMaxThinWidthM = 1000.0f;

/// Texels each side by which a thin caster of true width `widthM` (metres where it is
/// narrowest; 0 = not known) is widened in a cascade of `texelM` metre texels, asked for
/// `requestedTexels` (RendererOptions::thinCasterWidenTexels; 0 = off: returns 0).
///
/// A caster at least half a texel wide (widthM >= texelM / 2) is widened to one texel:
/// (texelM - widthM) / 2 each side (at most a quarter texel), so that it covers a texel centre
/// wherever it passes and its shadow is a continuous line at most twice its true width (a 0.28 m
/// pole under 0.46 m texels), instead of dashes where it misses the centres. A thinner caster
/// gets `requestedTexels` only: a full texel would make its shadow more than twice as wide as it
/// is (a 3 cm cable under 0.46 m texels: 15 times). Never less than `requestedTexels`.
/// Non-finite or negative inputs are treated as unknown width / off (no NaN out).
[[nodiscard]] float thinCasterWidenTexels(float requestedTexels, float widthM,
                                          double texelM) noexcept;

/// The most any thin caster is widened (texels each side) under `requestedTexels`: what culling
/// and the cache grow a thin caster's bounds by. 0 when off.
[[nodiscard]] float thinCasterMaxWidenTexels(float requestedTexels) noexcept;

}  // namespace csm
