// The uniform block a lighting shader reads through csm.glsl (std140), and how a CascadeFrame is
// packed into it. Pure: GLM only, no Vulkan. The GLSL side (shaders/csm.glsl) declares the same
// block; the static_asserts in gpu_layout.cpp pin every offset so that the two cannot drift.
#pragma once

#include <glm/glm.hpp>

#include <array>
#include <cstddef>
#include <cstdint>

#include "csm/cascades.hpp"
#include "csm/gpu_shared.h"
#include "csm/shared_constants.h"

namespace csm {

/// Run-time debug outputs of csm.glsl (values of CSM_DEBUG_* in csm/gpu_shared.h).
enum class DebugMode : std::uint32_t {
  kNone = CSM_DEBUG_NONE,
  kNormal = CSM_DEBUG_NORMAL,
  kShadowFactor = CSM_DEBUG_SHADOW,
  kLightCoords = CSM_DEBUG_LIGHT_COORDS,
  kSampledDepth = CSM_DEBUG_SAMPLED_DEPTH,
  kDepthDifference = CSM_DEBUG_DEPTH_DIFF,
  kCascadeTint = CSM_DEBUG_CASCADE,
  kTileFallback = CSM_DEBUG_TILES,
};

// PcfKernel (the filters of csm.glsl) is declared in csm/types.hpp, with ShadowSettings::kernel.

/// The one spelling of a kernel ("tent5x5") in code, CLI, JSON, reports and UI; parse it with
/// parseKernel() (csm/names.hpp, with the list of every kernel). "unknown" outside PcfKernel.
[[nodiscard]] const char* kernelName(PcfKernel kernel) noexcept;

/// How far (in texels of the kernel's own cascade, before kernelScale) a kernel reads from its
/// centre, bilinear footprint included. Mirrors csmKernelRadius() in csm.glsl
/// (CSM_KERNEL_RADIUS_*).
[[nodiscard]] float kernelRadiusTexels(PcfKernel kernel) noexcept;

/// One cascade as the shader sees it (std140 array element, 112 bytes; csm.glsl's CsmCascade).
struct CsmCascadeGpu {
  /// Camera-relative world position -> shadow clip space (x, y in [-1, 1], z depth in [0, 1]).
  glm::mat4 viewProjCr{1.0f};
  /// The cascade's split range: view depth (m) where it starts and where it ends.
  float splitNearM = 0.0f;
  float splitFarM = 0.0f;
  /// Side of one shadow-map texel (m).
  float texelSizeM = 0.0f;
  /// Tap spacing of the PCF kernel in texels: 1, or texel_0 / texel_i for kernels of constant
  /// world size (ShadowSettings::worldSpaceKernel).
  float kernelScale = 0.0f;
  /// View depth (m) where the blend band toward the next cascade starts (= splitFarM when there
  /// is no band).
  float blendStartM = 0.0f;
  /// Metres of light-space depth per unit of stored depth (the depth window's length).
  float depthRangeM = 0.0f;
  /// Index of the map's texel (0, 0) on the world-anchored texel grid, modulo
  /// CSM_WORLD_TEXEL_PERIOD (stabilised cascades; PCSS rotates its taps by a hash of the world
  /// texel, so that the noise stays on the ground when the map moves).
  glm::vec2 worldTexelOrigin{0.0f};
  /// With cached cascades (CsmUniforms::wrappedLayers = 1) the wrap offset in texels of the box's
  /// texel (0, 0) in the toroidally addressed layer (RendererOptions::cache), else 0.
  glm::vec2 wrapOffset{0.0f};
  /// Unused (0): pads the element to std140's 16-byte multiple.
  glm::vec2 cascadeReserved{0.0f};
};

/// The whole block (std140, set CSM_SET, binding CSM_BINDING_UNIFORMS in csm.glsl).
struct CsmUniforms {
  CsmCascadeGpu cascades[CSM_MAX_CASCADES];
  /// Camera forward (world axes; camera-relative space shares them).
  glm::vec3 cameraForwardWs{0.0f, 0.0f, -1.0f};
  /// How far shadows reach along the view (m).
  float shadowFarM = 0.0f;
  /// xyz: normalised direction the light travels (world axes), w: 0.
  glm::vec4 lightDirection{0.0f, -1.0f, 0.0f, 0.0f};
  /// Blend band (fraction of a cascade's depth range).
  float blendBand = 0.0f;
  /// Normal offset of the receiver (texels; ShadowSettings::normalOffsetTexels).
  float normalOffsetTexels = 0.0f;
  /// Shadow-map side (texels) and its inverse.
  float resolution = 0.0f;
  float invResolution = 0.0f;
  /// Cascades in the frame, and the bit mask of the non-empty ones.
  std::uint32_t cascadeCount = 0;
  std::uint32_t nonEmptyMask = 0;
  /// Run-time debug output (DebugMode, CSM_DEBUG_*).
  std::uint32_t debugMode = 0;
  /// 1 when the layers are addressed toroidally (cached cascades: wrapOffset applies), else 0.
  std::uint32_t wrappedLayers = 0;
  /// Bias of the shadow test beyond the normal offset: the depth floor in texels of the
  /// receiver's cascade (ShadowSettings::depthFloorTexels) plus one in units of stored depth (the
  /// depth format's quantum, depthQuantum()).
  float depthFloorTexels = 0.0f;
  float depthFloorQuantum = 0.0f;
  /// The moment sampler's largest anisotropy (UniformOptions::momentAnisotropy): 1 a trilinear
  /// sampler, whose mip csm.glsl picks from the footprint's geometric-mean axis.
  float momentAnisotropy = 1.0f;
  /// 1 when the moment image holds MSM's moments quantised to 64 bits (RGBA16_UNORM,
  /// csm::msmQuantize; UniformOptions::msmQuantizedMoments): csm.glsl decodes what it reads.
  std::uint32_t momentQuantized = 0;
  /// Soft shadows (PCSS): tan(light angular diameter / 2) (penumbra radius per metre between
  /// blocker and receiver), and the largest penumbra radius (m; maxPenumbraM / 2).
  float tanHalfLightAngle = 0.0f;
  float maxPenumbraRadiusM = 0.0f;
  /// The fade to lit at the end of the shadows (CascadeFrame::fadeEndM, view depth in m) and the
  /// inverse of its length (1 / fadeLengthM; 0: no fade).
  float fadeEndM = 0.0f;
  float invFadeLengthM = 0.0f;
  /// The prefiltered filters: the light-bleeding reduction, MSM's moment bias, EVSM's positive
  /// and negative exponents (ShadowSettings::momentBleedReduction, msmMomentBias,
  /// evsmPositiveExponent, evsmNegativeExponent).
  glm::vec4 moments{0.0f};
  /// Receiver-marked tiles (RendererOptions::tiles; csm::CacheCascadePlan::partial): bit i set
  /// when cascade i's layer holds only the tiles set in its tileBits; csm.glsl then samples it
  /// only where every tile under the filter's reach is held, and else falls back to the next
  /// cascade that holds the receiver (the last one always does). 0: every layer is whole.
  std::uint32_t tilePartialMask = 0;
  /// 1 / the side of a tile in texels (resolution / kTilesPerSide).
  float tileInvTexels = 0.0f;
  std::uint32_t tileReserved0 = 0;
  std::uint32_t tileReserved1 = 0;
  /// Per cascade: x, y the texels from the tile grid's first tile to the box's texel (0, 0)
  /// (grid tile = floor((texel + x, y) / tile side)); z how far its filter reads (texels,
  /// csm::receiverSampleReachTexels); w 0.
  glm::vec4 tileGrid[CSM_MAX_CASCADES]{};
  /// Per cascade three uvec4 (CSM_TILE_WORDS of the twelve words used): bit y * kTileGridSide + x
  /// set when the layer holds grid tile (x, y).
  glm::uvec4 tileBits[CSM_MAX_CASCADES * 3]{};
};

/// Per-frame choices that go into the block besides the cascades and the settings, for a host
/// that calls packUniforms itself. The renderer packs its own block from its debug mode
/// (ShadowRenderer::setDebugMode) and its depth format; it takes no UniformOptions.
struct UniformOptions {
  /// Run-time debug output of the lighting shader.
  DebugMode debugMode = DebugMode::kNone;
  /// Bits of the shadow map's depth format (16: D16_UNORM, 32: D32_SFLOAT): sets the depth floor
  /// the shader adds for the format's quantisation (depthQuantum()).
  std::uint32_t depthBits = 32;
  /// The largest anisotropy of the sampler the host binds the moments with (prefiltered filters;
  /// the renderer's own: DeviceInfo::maxSamplerAnisotropy). Above 1 the sampler filters a grazing
  /// footprint along its long axis itself and csm.glsl hands it the footprint as it is; at 1 (a
  /// trilinear sampler, which would take the mip of the long axis and blur the short one) the
  /// shader reads the mip of the footprint's geometric-mean axis. At least 1.
  float momentAnisotropy = 1.0f;
  /// The msm filter's moment image is RGBA16_UNORM with csm::msmQuantize's quantisation (the
  /// renderer's where RendererOptions::msmMomentBits = 64 and the device allow it): csm.glsl
  /// decodes the moments it reads, and MSM's moment bias is at least
  /// csm::kMsmQuantizedMinMomentBias. Ignored by the other filters.
  bool msmQuantizedMoments = false;
};

/// The smallest depth difference (units of stored depth, [0, 1]) that the shadow test can trust
/// with a depth format of `depthBits` bits: one step of D16_UNORM (the map rounds to nearest, the
/// receiver does not), 16 ulp at depth 1 of D32_SFLOAT (float error of the receiver's
/// camera-relative position and of the light matrix, and of the caster's rasteriser).
[[nodiscard]] float depthQuantum(std::uint32_t depthBits) noexcept;

/// Packs one frame's cascades for the shader. `frame` must come from computeCascades() with the
/// same `settings` (blend band, normal offset and resolution are taken from `settings`). Empty
/// and unused cascades are zeroed and left out of the non-empty mask. Never produces NaN.
[[nodiscard]] CsmUniforms packUniforms(const CascadeFrame& frame, const ShadowSettings& settings,
                                       const UniformOptions& options = {}) noexcept;

struct CachePlan;

/// The block of a frame that a cache plan (planCacheFrame) was applied to, for the cached
/// renderer's toroidal layers: packUniforms, with wrapped layers, each cascade's wrap offset
/// and, for a cascade deferred across a change of light, its world texel grid's origin in the
/// basis its layer shows. Never produces NaN.
[[nodiscard]] CsmUniforms packCachedUniforms(const CascadeFrame& frame,
                                             const ShadowSettings& settings,
                                             const UniformOptions& options,
                                             const CachePlan& plan) noexcept;

/// Fills the receiver-marked tile fields of a block packed from `plan` (packCachedUniforms does;
/// the renderer again after invalidations since planning): for each partial cascade but the last
/// active one (the fallback, drawn wherever the view can sample it) its grid
/// offset and held tiles, and for every active one its filter's reach (`reachTexels`).
void packTileUniforms(CsmUniforms& u, const CachePlan& plan,
                      const std::array<double, kMaxCascades>& reachTexels) noexcept;

/// One specialization constant of the lighting pipeline: its constant_id in csm.glsl
/// (CSM_SPEC_*) and its value (a 32-bit int or bool, as the shader declares it).
struct SpecConstant {
  std::uint32_t id = 0;
  std::uint32_t value = 0;
};

/// Specialization constants of a lighting pipeline that includes csm.glsl.
inline constexpr std::uint32_t kLightingSpecConstantCount = 3;

/// The lighting pipeline's specialization constants for `settings`: the kernel
/// (CSM_SPEC_KERNEL = settings.kernel), the blend (CSM_SPEC_BLEND: 1 when settings.blendBand
/// > 0, else 0, the hard switch) and the PCSS taps (CSM_SPEC_PCSS_TAPS = settings.pcssTaps).
/// Settings that differ only in other fields give the same constants (the same pipeline).
/// Vulkan hosts take them as a VkSpecializationInfo from csm::vk::LightingSpecialization.
[[nodiscard]] std::array<SpecConstant, kLightingSpecConstantCount> lightingSpecConstants(
    const ShadowSettings& settings) noexcept;

/// The tint CSM_DEBUG_CASCADE paints cascade `index` with (CSM_TINT_i); black for -1 or out of
/// range. Tests map a pixel back to its cascade with it.
[[nodiscard]] glm::vec3 cascadeTint(int index) noexcept;

}  // namespace csm
