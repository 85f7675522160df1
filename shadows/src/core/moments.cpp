// The prefiltered filters' math (see moments.hpp); csm.glsl and csm_moments.comp mirror it.
#include "csm/moments.hpp"

#include <algorithm>
#include <cmath>

namespace csm {
namespace {

float clamp01(float x) noexcept {
  return std::clamp(x, 0.0f, 1.0f);
}

// Lit fractions below the reduction read 0; the rest is stretched back to [0, 1].
float reduceBleeding(float lit, float reduction) noexcept {
  return clamp01((lit - reduction) / (1.0f - reduction));
}

}  // namespace

glm::vec4 depthMoments(PcfKernel kernel, float depth, const ShadowSettings& settings) noexcept {
  const float z = clamp01(depth);
  switch (kernel) {
    case PcfKernel::kVsm:
      return {z, z * z, 0.0f, 0.0f};
    case PcfKernel::kEvsm: {
      const float w = 2.0f * z - 1.0f;
      const float pos = std::exp(settings.evsmPositiveExponent * w);
      const float neg = -std::exp(-settings.evsmNegativeExponent * w);
      return {pos, pos * pos, neg, neg * neg};
    }
    case PcfKernel::kMsm: {
      // Centred on [-1, 1]: the Hankel matrix is far better conditioned in 32-bit floats than
      // with z in [0, 1] (whose fourth moment loses the variance to rounding).
      const float w = 2.0f * z - 1.0f;
      const float w2 = w * w;
      return {w, w2, w2 * w, w2 * w2};
    }
    default:
      return glm::vec4(0.0f);
  }
}

float chebyshevUpperBound(float mean, float meanSquare, float depth, float minVariance) noexcept {
  if (!(depth > mean)) return 1.0f;
  const float variance = std::max(meanSquare - mean * mean, minVariance);
  const float d = depth - mean;
  const float p = variance / (variance + d * d);
  return std::isfinite(p) ? clamp01(p) : 0.0f;
}

float hamburgerShadowIntensity(const glm::vec4& b, float zf) noexcept {
  // Hankel matrix of the moments, B = [[1, b1, b2], [b1, b2, b3], [b2, b3, b4]] (positive
  // definite after the bias), factored B = L D L^T with L unit lower triangular.
  const float d22 = b.y - b.x * b.x;
  if (!(d22 > 0.0f)) return 0.0f;
  const float l32 = (b.z - b.x * b.y) / d22;
  const float d33 = b.w - b.y * b.y - l32 * l32 * d22;
  if (!(d33 > 0.0f)) return 0.0f;
  // Solve B c = (1, zf, zf^2): forward (L), diagonal (D), backward (L^T).
  const float y2 = zf - b.x;
  const float y3 = zf * zf - b.y - l32 * y2;
  const float c3 = y3 / d33;
  const float c2 = y2 / d22 - l32 * c3;
  const float c1 = 1.0f - b.x * c2 - b.y * c3;
  // The other two support points: roots of c3 z^2 + c2 z + c1 = 0.
  if (c3 == 0.0f) return 0.0f;
  const float p = c2 / c3;
  const float q = c1 / c3;
  const float r = std::sqrt(std::max(0.25f * p * p - q, 0.0f));
  const float z2 = -0.5f * p - r;
  const float z3 = -0.5f * p + r;
  float g = 0.0f;
  if (zf <= z2) {
    g = 0.0f;
  } else if (zf <= z3) {
    g = (zf * z3 - b.x * (zf + z3) + b.y) / ((z3 - z2) * (zf - z2));
  } else {
    g = 1.0f - (z2 * z3 - b.x * (z2 + z3) + b.y) / ((zf - z2) * (zf - z3));
  }
  return std::isfinite(g) ? clamp01(g) : 0.0f;
}

float momentLitFraction(PcfKernel kernel, const glm::vec4& moments, float depth, float minVariance,
                        const ShadowSettings& settings) noexcept {
  const float z = clamp01(depth);
  float lit = 1.0f;
  switch (kernel) {
    case PcfKernel::kVsm:
      lit = chebyshevUpperBound(moments.x, moments.y, z,
                                std::max(minVariance, float(CSM_VSM_MIN_VARIANCE)));
      break;
    case PcfKernel::kEvsm: {
      const float w = 2.0f * z - 1.0f;
      const float cp = settings.evsmPositiveExponent;
      const float cn = settings.evsmNegativeExponent;
      const float pos = std::exp(cp * w);
      const float neg = -std::exp(-cn * w);
      // The variance floor scales with the warp's slope at the receiver (d e^(c w)/dz = 2c e^(cw)).
      const float posFloor = minVariance * (2.0f * cp * pos) * (2.0f * cp * pos);
      const float negFloor = minVariance * (2.0f * cn * neg) * (2.0f * cn * neg);
      lit = std::min(chebyshevUpperBound(moments.x, moments.y, pos, posFloor),
                     chebyshevUpperBound(moments.z, moments.w, neg, negFloor));
      break;
    }
    case PcfKernel::kMsm: {
      const float a = settings.msmMomentBias;
      // A uniform distribution on [-1, 1] has moments 0, 1/3, 0, 1/5.
      const glm::vec4 biased = (1.0f - a) * moments + a * glm::vec4(0.0f, 1.0f / 3.0f, 0.0f, 0.2f);
      lit = 1.0f - hamburgerShadowIntensity(biased, 2.0f * z - 1.0f);
      break;
    }
    default:
      return 1.0f;
  }
  return reduceBleeding(lit, settings.momentBleedReduction);
}

float momentReadFootprint(float wanted, float edgeTexels, float depth,
                          const glm::vec2& slopePerTexel) noexcept {
  const float slope = glm::length(slopePerTexel);
  const float byDepth = slope > 0.0f ? depth / slope : edgeTexels;
  const float cap = std::max(std::min(edgeTexels, byDepth) / 3.0f, 1.0f);
  return std::min(wanted, cap);
}

float momentFootprintSpread(const glm::vec2& slopePerTexel, float footprintTexels) noexcept {
  if (!(footprintTexels > 1.0f)) return 0.0f;
  const float texels = std::sqrt((footprintTexels * footprintTexels - 1.0f) / 3.0f);
  const float spread = texels * glm::length(slopePerTexel);
  return std::isfinite(spread) ? spread : 0.0f;
}

float momentReceiverShift(PcfKernel kernel, const glm::vec2& slopePerTexel, float footprintTexels,
                          const ShadowSettings& settings) noexcept {
  const float spread = momentFootprintSpread(slopePerTexel, footprintTexels);
  if (kernel == PcfKernel::kMsm) return spread;
  if (kernel != PcfKernel::kEvsm) return 0.0f;
  // The negative warp's Jensen gap: a normal spread sigma (in w = 2z - 1: 2 sigma) raises the
  // mean of e^(-c w) by e^(c^2 (2 sigma)^2 / 2), which a receiver c (2 sigma)^2 / 2 = 2 c sigma^2
  // further forward in w (c sigma^2 in z) matches; at most one spread (the bounded spread of a
  // footprint never needs more).
  return std::min(settings.evsmNegativeExponent * spread, 1.0f) * spread;
}

float momentBlurRadiusTexels(double momentBlurM, double texelM) noexcept {
  if (!(momentBlurM > 0.0) || !(texelM > 0.0)) return 0.0f;
  const double r = momentBlurM / texelM;
  return static_cast<float>(std::min(r, double(CSM_MOMENT_MAX_BLUR_TEXELS)));
}

glm::vec4 msmQuantize(const glm::vec4& centred) noexcept {
  static const glm::mat4 e(CSM_MSM_QUANTIZE_MATRIX);
  static const glm::vec4 offset(CSM_MSM_QUANTIZE_OFFSET);
  return glm::clamp(e * centred + offset, 0.0f, 1.0f);
}

glm::vec4 msmDequantize(const glm::vec4& quantized) noexcept {
  static const glm::mat4 d(CSM_MSM_DEQUANTIZE_MATRIX);
  static const glm::vec4 offset(CSM_MSM_QUANTIZE_OFFSET);
  return d * (quantized - offset);
}

std::uint32_t momentTexelBytes(PcfKernel kernel, bool compact) noexcept {
  if (!isPrefiltered(kernel)) return 0;
  return kernel != PcfKernel::kEvsm && compact ? 8u : 16u;
}

std::uint64_t momentImageBytes(const ShadowSettings& settings, bool compact) noexcept {
  const std::uint64_t texel = momentTexelBytes(settings.kernel, compact);
  if (texel == 0 || settings.cascadeCount == 0) return 0;
  // The moments with their mips (the blur needs no image of its own: csm_moments.comp keeps a
  // workgroup's tile in shared memory).
  std::uint64_t bytes = 0;
  for (std::uint64_t side = settings.resolution; side >= 1; side /= 2) {
    bytes += side * side * settings.cascadeCount * texel;
  }
  return bytes;
}

}  // namespace csm
