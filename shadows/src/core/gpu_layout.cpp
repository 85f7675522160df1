// Packing of a CascadeFrame into the std140 block that csm.glsl declares.
#include "csm/gpu_layout.hpp"

#include "csm/cache_plan.hpp"
#include "csm/moments.hpp"
#include "csm/receiver_tiles.hpp"

#include <algorithm>
#include <cmath>

namespace csm {

// std140 offsets, pinned. csm.glsl declares the same members in the same order; a change here
// without the same change there (or the reverse) breaks these asserts or the GPU tests.
static_assert(sizeof(CsmCascadeGpu) == 112);
static_assert(offsetof(CsmCascadeGpu, viewProjCr) == 0);
static_assert(offsetof(CsmCascadeGpu, splitNearM) == 64);
static_assert(offsetof(CsmCascadeGpu, splitFarM) == 68);
static_assert(offsetof(CsmCascadeGpu, texelSizeM) == 72);
static_assert(offsetof(CsmCascadeGpu, kernelScale) == 76);
static_assert(offsetof(CsmCascadeGpu, blendStartM) == 80);
static_assert(offsetof(CsmCascadeGpu, depthRangeM) == 84);
static_assert(offsetof(CsmCascadeGpu, worldTexelOrigin) == 88);  // vec2: 8-aligned in std140
static_assert(offsetof(CsmCascadeGpu, wrapOffset) == 96);
static_assert(offsetof(CsmCascadeGpu, cascadeReserved) == 104);
static_assert(offsetof(CsmUniforms, cascades) == 0);
static_assert(offsetof(CsmUniforms, cameraForwardWs) == 112 * CSM_MAX_CASCADES);
static_assert(offsetof(CsmUniforms, shadowFarM) == 112 * CSM_MAX_CASCADES + 12);  // after a vec3
static_assert(offsetof(CsmUniforms, lightDirection) == 112 * CSM_MAX_CASCADES + 16);
static_assert(offsetof(CsmUniforms, blendBand) == 112 * CSM_MAX_CASCADES + 32);
static_assert(offsetof(CsmUniforms, normalOffsetTexels) == 112 * CSM_MAX_CASCADES + 36);
static_assert(offsetof(CsmUniforms, resolution) == 112 * CSM_MAX_CASCADES + 40);
static_assert(offsetof(CsmUniforms, invResolution) == 112 * CSM_MAX_CASCADES + 44);
static_assert(offsetof(CsmUniforms, cascadeCount) == 112 * CSM_MAX_CASCADES + 48);
static_assert(offsetof(CsmUniforms, nonEmptyMask) == 112 * CSM_MAX_CASCADES + 52);
static_assert(offsetof(CsmUniforms, debugMode) == 112 * CSM_MAX_CASCADES + 56);
static_assert(offsetof(CsmUniforms, wrappedLayers) == 112 * CSM_MAX_CASCADES + 60);
static_assert(offsetof(CsmUniforms, depthFloorTexels) == 112 * CSM_MAX_CASCADES + 64);
static_assert(offsetof(CsmUniforms, depthFloorQuantum) == 112 * CSM_MAX_CASCADES + 68);
static_assert(offsetof(CsmUniforms, momentAnisotropy) == 112 * CSM_MAX_CASCADES + 72);
static_assert(offsetof(CsmUniforms, momentQuantized) == 112 * CSM_MAX_CASCADES + 76);
static_assert(offsetof(CsmUniforms, tanHalfLightAngle) == 112 * CSM_MAX_CASCADES + 80);
static_assert(offsetof(CsmUniforms, maxPenumbraRadiusM) == 112 * CSM_MAX_CASCADES + 84);
static_assert(offsetof(CsmUniforms, fadeEndM) == 112 * CSM_MAX_CASCADES + 88);
static_assert(offsetof(CsmUniforms, invFadeLengthM) == 112 * CSM_MAX_CASCADES + 92);
static_assert(offsetof(CsmUniforms, moments) == 112 * CSM_MAX_CASCADES + 96);
static_assert(offsetof(CsmUniforms, tilePartialMask) == 112 * CSM_MAX_CASCADES + 112);
static_assert(offsetof(CsmUniforms, tileInvTexels) == 112 * CSM_MAX_CASCADES + 116);
static_assert(offsetof(CsmUniforms, tileGrid) == 112 * CSM_MAX_CASCADES + 128);
static_assert(offsetof(CsmUniforms, tileBits) ==
              112 * CSM_MAX_CASCADES + 128 + 16 * CSM_MAX_CASCADES);
static_assert(CSM_TILE_WORDS <= 12, "three uvec4 of tile bits per cascade");
static_assert(sizeof(CsmUniforms) == 112 * CSM_MAX_CASCADES + 128 + 64 * CSM_MAX_CASCADES);
static_assert(sizeof(CsmUniforms) <= 16384, "must fit the minimum maxUniformBufferRange");
static_assert(sizeof(CsmUniforms) % 4 == 0, "vkCmdUpdateBuffer needs a multiple of 4 bytes");
static_assert(CSM_MAX_CASCADES <= 32, "the non-empty mask is one 32-bit word");

float kernelRadiusTexels(PcfKernel kernel) noexcept {
  switch (kernel) {
    case PcfKernel::k1Tap:
      return float(CSM_KERNEL_RADIUS_1TAP);
    case PcfKernel::kTent3:
      return float(CSM_KERNEL_RADIUS_TENT3);
    case PcfKernel::kTent5:
      return float(CSM_KERNEL_RADIUS_TENT5);
    case PcfKernel::kTent7:
      return float(CSM_KERNEL_RADIUS_TENT7);
    case PcfKernel::kPoisson16:
      return float(CSM_KERNEL_RADIUS_POISSON16);
    case PcfKernel::kPcss:
      return float(CSM_KERNEL_RADIUS_PCSS);
    case PcfKernel::kVsm:
    case PcfKernel::kEvsm:
    case PcfKernel::kMsm:
      return float(CSM_KERNEL_RADIUS_MOMENTS);
  }
  return float(CSM_KERNEL_RADIUS_1TAP);
}

float depthQuantum(std::uint32_t depthBits) noexcept {
  if (depthBits <= 16) return 1.0f / 65535.0f;
  return 16.0f * 0x1p-24f;
}

namespace {

// Finite or zero: nothing that is not finite may reach the GPU.
float finiteOr0(double v) noexcept {
  return std::isfinite(v) ? static_cast<float>(v) : 0.0f;
}

// Index of the map's texel (0, 0) on the world-anchored grid (light-space coordinate / texel),
// modulo CSM_WORLD_TEXEL_PERIOD, in double: exact whatever the distance from the origin.
// The world texel grid's origin of cascade `c` in light basis `basis` (the frame's, or the one a
// deferred cached cascade shows), modulo CSM_WORLD_TEXEL_PERIOD.
glm::vec2 worldTexelOrigin(const Cascade& c, const CascadeFrame& frame,
                           const glm::dmat3& basis) noexcept {
  const double period = CSM_WORLD_TEXEL_PERIOD;
  const double res = static_cast<double>(frame.resolution);
  glm::vec2 out(0.0f);
  for (int a = 0; a < 2; ++a) {
    const double texel = c.texelSizeLs[a];
    if (!(texel > 0.0)) continue;
    const double centre = glm::dot(basis[a], c.boxCenterWs) / texel;
    // Stabilised: the box centre sits on a grid line (an integer) and the map spans res / 2
    // texels either side of it.
    const double origin = std::round(centre) - std::round(0.5 * res);
    const double wrapped = origin - period * std::floor(origin / period);
    out[a] = finiteOr0(wrapped);
  }
  return out;
}

}  // namespace

CsmUniforms packUniforms(const CascadeFrame& frame, const ShadowSettings& settings,
                         const UniformOptions& options) noexcept {
  CsmUniforms u{};
  const std::uint32_t count = frame.cascadeCount < kMaxCascades ? frame.cascadeCount : kMaxCascades;
  const double band = settings.blendBand;
  const double texel0 = count > 0 ? frame.cascades[0].texelSizeM() : 0.0;
  std::uint32_t nonEmpty = 0;
  for (std::uint32_t i = 0; i < count; ++i) {
    const Cascade& c = frame.cascades[i];
    if (c.empty) continue;
    nonEmpty |= 1u << i;
    CsmCascadeGpu& g = u.cascades[i];
    const double nearM = frame.splitsM[i];
    const double farM = frame.splitsM[i + 1];
    const double texel = c.texelSizeM();
    double scale = 1.0;
    if (settings.worldSpaceKernel && texel > 0.0 && texel0 > 0.0) scale = texel0 / texel;
    g.viewProjCr = c.viewProjCr;
    g.splitNearM = finiteOr0(nearM);
    g.splitFarM = finiteOr0(farM);
    g.texelSizeM = finiteOr0(texel);
    g.kernelScale = finiteOr0(scale);
    g.blendStartM = finiteOr0(farM - band * (farM - nearM));
    g.depthRangeM = finiteOr0(c.depthFarLs - c.depthNearLs);
    g.worldTexelOrigin = worldTexelOrigin(c, frame, frame.lightBasisWs);
  }
  const glm::dvec3 fwd = frame.cameraForwardWs;
  const glm::dvec3 dir = frame.lightDirectionWs;
  u.cameraForwardWs = glm::vec3(finiteOr0(fwd.x), finiteOr0(fwd.y), finiteOr0(fwd.z));
  u.shadowFarM = finiteOr0(frame.shadowFarM);
  u.lightDirection = glm::vec4(finiteOr0(dir.x), finiteOr0(dir.y), finiteOr0(dir.z), 0.0f);
  const double res = frame.resolution > 0 ? frame.resolution : settings.resolution;
  u.blendBand = finiteOr0(band);
  u.normalOffsetTexels = settings.normalOffsetTexels;
  u.resolution = finiteOr0(res);
  u.invResolution = res > 0.0 ? finiteOr0(1.0 / res) : 0.0f;
  u.cascadeCount = count;
  u.nonEmptyMask = nonEmpty;
  u.debugMode = static_cast<std::uint32_t>(options.debugMode);
  u.wrappedLayers = 0u;
  u.depthFloorTexels = settings.depthFloorTexels;
  u.depthFloorQuantum = depthQuantum(options.depthBits);
  u.momentAnisotropy =
      std::isfinite(options.momentAnisotropy) ? std::max(options.momentAnisotropy, 1.0f) : 1.0f;
  const double halfAngleRad = glm::radians(0.5 * settings.lightAngularDiameterDeg);
  u.tanHalfLightAngle = finiteOr0(std::tan(halfAngleRad));
  u.maxPenumbraRadiusM = finiteOr0(0.5 * settings.maxPenumbraM);
  if (frame.fadeLengthM > 0.0) {
    u.fadeEndM = finiteOr0(frame.fadeEndM);
    u.invFadeLengthM = finiteOr0(1.0 / frame.fadeLengthM);
  }
  const bool quantized = settings.kernel == PcfKernel::kMsm && options.msmQuantizedMoments;
  u.momentQuantized = quantized ? 1u : 0u;
  const float msmBias = quantized ? std::max(settings.msmMomentBias, kMsmQuantizedMinMomentBias)
                                  : settings.msmMomentBias;
  u.moments = glm::vec4(settings.momentBleedReduction, msmBias, settings.evsmPositiveExponent,
                        settings.evsmNegativeExponent);
  return u;
}

CsmUniforms packCachedUniforms(const CascadeFrame& frame, const ShadowSettings& settings,
                               const UniformOptions& options, const CachePlan& plan) noexcept {
  CsmUniforms u = packUniforms(frame, settings, options);
  u.wrappedLayers = 1u;  // toroidal addressing: csm.glsl adds each cascade's wrap offset
  const std::uint32_t count = std::min(plan.cascadeCount, frame.cascadeCount);
  for (std::uint32_t i = 0; i < count; ++i) {
    const CacheCascadePlan& p = plan.cascades[i];
    if (!p.active || frame.cascades[i].empty) continue;
    CsmCascadeGpu& g = u.cascades[i];
    if (p.basis != frame.lightBasisWs) {
      g.worldTexelOrigin = worldTexelOrigin(frame.cascades[i], frame, p.basis);
    }
    g.wrapOffset = glm::vec2(float(p.wrapX), float(p.wrapY));
  }
  std::array<double, kMaxCascades> reach{};
  for (std::uint32_t i = 0; i < count; ++i)
    reach[i] = receiverSampleReachTexels(settings, frame, i);
  packTileUniforms(u, plan, reach);
  return u;
}

void packTileUniforms(CsmUniforms& u, const CachePlan& plan,
                      const std::array<double, kMaxCascades>& reachTexels) noexcept {
  u.tilePartialMask = 0;
  const std::int64_t tile = std::max<std::int64_t>(plan.resolution / kTilesPerSide, 1);
  // The last active cascade has nothing to fall back to: drawn where the view can sample it, it
  // holds every texel a pixel reads there, and its bit stays clear.
  std::uint32_t last = kMaxCascades;
  for (std::uint32_t i = 0; i < std::min(plan.cascadeCount, kMaxCascades); ++i) {
    if (plan.cascades[i].active) last = i;
  }
  u.tileInvTexels = plan.resolution > 0 ? float(1.0 / double(tile)) : 0.0f;
  for (std::uint32_t i = 0; i < kMaxCascades; ++i) {
    u.tileGrid[i] = glm::vec4(0.0f);
    for (std::uint32_t k = 0; k < 3; ++k) u.tileBits[i * 3 + k] = glm::uvec4(0u);
    if (i >= plan.cascadeCount || !plan.cascades[i].active) continue;
    const CacheCascadePlan& p = plan.cascades[i];
    u.tileGrid[i].z = float(std::isfinite(reachTexels[i]) ? reachTexels[i] : 0.0);
    if (!p.partial || i == last) continue;
    u.tilePartialMask |= 1u << i;
    u.tileGrid[i].x = float(p.box.x0 - p.tiles.origin.x * tile);
    u.tileGrid[i].y = float(p.box.y0 - p.tiles.origin.y * tile);
    for (std::uint32_t w = 0; w < kTileWords; ++w)
      u.tileBits[i * 3 + w / 4][w % 4] = p.tiles.bits[w];
  }
}

std::array<SpecConstant, kLightingSpecConstantCount> lightingSpecConstants(
    const ShadowSettings& settings) noexcept {
  return {{{CSM_SPEC_KERNEL, static_cast<std::uint32_t>(settings.kernel)},
           {CSM_SPEC_BLEND, settings.blendBand > 0.0 ? 1u : 0u},
           {CSM_SPEC_PCSS_TAPS, settings.pcssTaps}}};
}

glm::vec3 cascadeTint(int index) noexcept {
  static const glm::vec3 kTints[CSM_TINT_COUNT] = {
      glm::vec3(CSM_TINT_0), glm::vec3(CSM_TINT_1), glm::vec3(CSM_TINT_2), glm::vec3(CSM_TINT_3),
      glm::vec3(CSM_TINT_4), glm::vec3(CSM_TINT_5), glm::vec3(CSM_TINT_6), glm::vec3(CSM_TINT_7)};
  if (index < 0 || index >= CSM_TINT_COUNT) return glm::vec3(0.0f);
  return kTints[index];
}

}  // namespace csm
