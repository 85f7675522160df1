// The prefiltered filters' math (csm/moments.hpp), which csm.glsl and csm_moments.comp mirror:
// exact answers for one depth and for two depths in known proportion, Chebyshev's bound, the
// extremes (no NaN, no overflow at the largest EVSM exponent), and the settings' refusals.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "csm/core.hpp"
#include "csm/moments.hpp"
#include "csm/names.hpp"

namespace csm {
namespace {

ShadowSettings noBleedReduction() {
  ShadowSettings s;
  s.momentBleedReduction = 0.0f;
  return s;
}

// The filtered moments of depths `z` with weights `w` (what a blur over them stores).
glm::vec4 mixture(PcfKernel k, std::initializer_list<std::pair<float, float>> zw,
                  const ShadowSettings& s) {
  glm::vec4 m(0.0f);
  for (const auto& [z, w] : zw) m += w * depthMoments(k, z, s);
  return m;
}

TEST(Moments, OneDepthIsLitInFrontAndShadowedBehind) {
  const ShadowSettings s = noBleedReduction();
  for (PcfKernel k : kPrefilteredKernels) {
    for (float d : {0.05f, 0.3f, 0.5f, 0.9f}) {
      const glm::vec4 m = depthMoments(k, d, s);
      EXPECT_GE(momentLitFraction(k, m, d - 0.01f, 1e-8f, s), 0.99f) << kernelName(k) << " " << d;
      EXPECT_LE(momentLitFraction(k, m, d + 0.05f, 1e-8f, s), 0.05f) << kernelName(k) << " " << d;
    }
  }
}

TEST(Moments, ChebyshevIsAnUpperBoundOfTheLitFraction) {
  // Half the footprint at 0.3 (a blocker), half at 0.7 (the receiver's own surface): a receiver
  // just in front of 0.7 is truly half lit; one behind both is in full shadow.
  const ShadowSettings s = noBleedReduction();
  const glm::vec4 m = mixture(PcfKernel::kVsm, {{0.3f, 0.5f}, {0.7f, 0.5f}}, s);
  EXPECT_GE(momentLitFraction(PcfKernel::kVsm, m, 0.69f, 1e-8f, s), 0.5f);
  const float behind = momentLitFraction(PcfKernel::kVsm, m, 0.9f, 1e-8f, s);
  EXPECT_GE(behind, 0.0f);
  // sigma^2 = 0.04, (0.9 - 0.5)^2 = 0.16: exactly 0.2.
  EXPECT_NEAR(behind, 0.2f, 1e-5f);
}

TEST(Moments, MsmRecoversTheFractionOfTwoDepths) {
  // Four moments pin a two-depth footprint: the Hamburger reconstruction is within a few per
  // cent of the true lit fraction for a receiver at the far depth (v = 1 - weight of the near).
  const ShadowSettings s = noBleedReduction();
  for (float nearWeight : {0.25f, 0.5f, 0.75f}) {
    const glm::vec4 m =
        mixture(PcfKernel::kMsm, {{0.3f, nearWeight}, {0.7f, 1.0f - nearWeight}}, s);
    const float lit = momentLitFraction(PcfKernel::kMsm, m, 0.699f, 1e-8f, s);
    EXPECT_NEAR(lit, 1.0f - nearWeight, 0.05f) << nearWeight;
  }
}

TEST(Moments, EvsmBoundsAreTighterThanVsmBetweenTwoDepths) {
  const ShadowSettings s = noBleedReduction();
  const glm::vec4 v = mixture(PcfKernel::kVsm, {{0.3f, 0.5f}, {0.7f, 0.5f}}, s);
  const glm::vec4 e = mixture(PcfKernel::kEvsm, {{0.3f, 0.5f}, {0.7f, 0.5f}}, s);
  const float vsm = momentLitFraction(PcfKernel::kVsm, v, 0.9f, 1e-8f, s);
  const float evsm = momentLitFraction(PcfKernel::kEvsm, e, 0.9f, 1e-8f, s);
  EXPECT_LT(evsm, vsm);
  EXPECT_LT(evsm, 0.01f);
}

TEST(Moments, BleedReductionCutsLowLitFractions) {
  ShadowSettings s;
  s.momentBleedReduction = 0.25f;
  const glm::vec4 m = mixture(PcfKernel::kVsm, {{0.3f, 0.5f}, {0.7f, 0.5f}}, s);
  // 0.2 without the reduction (above): below 0.25, so 0.
  EXPECT_EQ(momentLitFraction(PcfKernel::kVsm, m, 0.9f, 1e-8f, s), 0.0f);
  // Fully lit stays fully lit.
  EXPECT_EQ(momentLitFraction(PcfKernel::kVsm, m, 0.2f, 1e-8f, s), 1.0f);
}

TEST(Moments, ExtremesStayFiniteAndInRange) {
  ShadowSettings s;
  s.evsmPositiveExponent = CSM_EVSM_MAX_EXPONENT;
  s.evsmNegativeExponent = CSM_EVSM_MAX_EXPONENT;
  for (PcfKernel k : kPrefilteredKernels) {
    for (float d : {0.0f, 1.0f, -1.0f, 2.0f}) {
      const glm::vec4 m = depthMoments(k, d, s);
      for (int c = 0; c < 4; ++c) EXPECT_TRUE(std::isfinite(m[c])) << kernelName(k) << " " << d;
      for (float r : {0.0f, 0.5f, 1.0f}) {
        const float lit = momentLitFraction(k, m, r, 0.0f, s);
        EXPECT_TRUE(lit >= 0.0f && lit <= 1.0f) << kernelName(k) << " " << d << " " << r;
      }
    }
    // Degenerate moments (all zero, as a cleared image would hold) give a number, not NaN.
    const float lit = momentLitFraction(k, glm::vec4(0.0f), 0.5f, 0.0f, s);
    EXPECT_TRUE(lit >= 0.0f && lit <= 1.0f) << kernelName(k);
  }
}

// What a trilinear read of a plane's moment mips returns: the moments of level-0 texels (one
// depth each: the plane's at the texel's centre) box-averaged into the texels of levels L and L+1
// of footprint `r` (L = floor(log2 r)), then bilinear at point `p` (level-0 texel units) and
// mixed between the two levels by the fraction of log2 r. `depth(x, y)`: the plane at a point.
template <typename Plane>
glm::vec4 trilinearMipRead(PcfKernel k, const Plane& depth, glm::vec2 p, float r,
                           const ShadowSettings& s) {
  const float lod = std::log2(r);
  const int level = int(std::floor(lod));
  auto levelRead = [&](int l) {
    const int side = 1 << l;
    auto texel = [&](int tx, int ty) {  // box average of level-0 texels (tx, ty) at level l
      glm::dvec4 sum(0.0);
      for (int y = 0; y < side; ++y)
        for (int x = 0; x < side; ++x)
          sum += glm::dvec4(
              depthMoments(k, depth(float(tx * side + x) + 0.5f, float(ty * side + y) + 0.5f), s));
      return glm::vec4(sum / double(side * side));
    };
    const glm::vec2 f = p / float(side) - 0.5f;
    const glm::vec2 i0 = glm::floor(f);
    const glm::vec2 w = f - i0;
    const int x0 = int(i0.x), y0 = int(i0.y);
    return glm::mix(glm::mix(texel(x0, y0), texel(x0 + 1, y0), w.x),
                    glm::mix(texel(x0, y0 + 1), texel(x0 + 1, y0 + 1), w.x), w.y);
  };
  const glm::vec4 lo = levelRead(level);
  return lod > float(level) ? glm::mix(lo, levelRead(level + 1), lod - float(level)) : lo;
}

// A lit plane read at a mip reads lit with every filter: the receiver's compared depth moves in
// front of the spread the mip gives its own depths (momentReceiverShift). Without the shift evsm
// and msm read such a plane as partly shadowed (down to 0.73 where the spread is a tenth of the
// depth range), the stipple a grazing sun drew on flat ground beyond the first cascades. And the
// shift is not so large that a parallel occluder a few spreads in front stops shadowing.
TEST(Moments, APlaneReadAtItsMipIsLitAndStillShadowedByAnOccluderInFront) {
  const ShadowSettings s;  // the default bleeding reduction, as the renderer reads
  bool unshiftedDimmed = false;
  for (PcfKernel k : kPrefilteredKernels) {
    for (float r : {1.0f, 1.5f, 2.0f, 3.0f, 5.7f, 8.0f, 16.0f, 23.0f}) {
      for (float spread : {1e-3f, 1e-2f, 3e-2f, 0.1f}) {
        for (float angle : {0.0f, 0.4f, 0.785f}) {
          // The slope (stored depth per texel) whose spread over the footprint is `spread` (at
          // level 0, over a footprint of 2 texels).
          const float rr = std::max(r, 2.0f);
          const float slopeLen = spread / std::sqrt((rr * rr - 1.0f) / 3.0f);
          const glm::vec2 slope = slopeLen * glm::vec2(std::cos(angle), std::sin(angle));
          // The read point: level-0 texel coordinates away from the origin's texel corners.
          const glm::vec2 p(300.3f, 301.7f);
          auto plane = [&](float x, float y) {
            return 0.5f + glm::dot(slope, glm::vec2(x, y) - p);
          };
          const glm::vec4 m = trilinearMipRead(k, plane, p, r, s);
          const float shift = momentReceiverShift(k, slope, r, s);
          const std::string what = std::string(kernelName(k)) + " r " + std::to_string(r) +
                                   " spread " + std::to_string(spread) + " angle " +
                                   std::to_string(angle);
          EXPECT_TRUE(std::isfinite(shift) && shift >= 0.0f) << what;
          if (r <= 1.0f || k == PcfKernel::kVsm) {
            EXPECT_EQ(shift, 0.0f) << what;
          }
          // The receiver as csm.glsl compares it: the normal offset puts it at least
          // normalOffsetTexels texels of the plane's slope in front of the plane (what level 0
          // relies on), and the shift.
          const float receiver = 0.5f - s.normalOffsetTexels * slopeLen;
          const float lit = momentLitFraction(k, m, receiver - shift, 1e-8f, s);
          EXPECT_GE(lit, 0.99f) << what;
          const float unshifted = momentLitFraction(k, m, receiver, 1e-8f, s);
          if (unshifted < 0.9f) unshiftedDimmed = true;
          // Shadowed: the same plane behind a parallel occluder plane covering the footprint,
          // far enough in front that its spread and the receiver's do not overlap (2 spreads
          // each, at least those of a level-0 bilinear read) beyond the shift.
          const float gap = 4.0f * momentFootprintSpread(slope, std::max(r, 2.0f)) + shift +
                            s.normalOffsetTexels * slopeLen + 0.02f;
          auto occluder = [&](float x, float y) { return plane(x, y) - gap; };
          const glm::vec4 o = trilinearMipRead(k, occluder, p, r, s);
          const float occluded = momentLitFraction(k, o, receiver - shift, 1e-8f, s);
          EXPECT_LE(occluded, 0.05f) << what;
        }
      }
    }
  }
  EXPECT_TRUE(unshiftedDimmed) << "the measure must see the dimming the shift removes";
  EXPECT_FLOAT_EQ(momentFootprintSpread(glm::vec2(3.0f, 4.0f), 2.0f), 5.0f);
  EXPECT_EQ(momentFootprintSpread(glm::vec2(3.0f, 4.0f), 0.5f), 0.0f);
  EXPECT_EQ(momentFootprintSpread(glm::vec2(std::nanf(""), 0.0f), 4.0f), 0.0f);
}

// A mip read stays inside the cascade's box and its stored depth range (3 footprints of reach),
// never below level 0.
TEST(Moments, AMipReadStaysInsideTheBoxAndTheDepthRange) {
  const glm::vec2 flat(0.0f);
  EXPECT_FLOAT_EQ(momentReadFootprint(8.0f, 1000.0f, 0.5f, flat), 8.0f);
  EXPECT_FLOAT_EQ(momentReadFootprint(8.0f, 12.0f, 0.5f, flat), 4.0f);  // 12 texels from the edge
  EXPECT_FLOAT_EQ(momentReadFootprint(8.0f, 1.0f, 0.5f, flat), 1.0f);   // never below level 0
  EXPECT_FLOAT_EQ(momentReadFootprint(0.5f, 1000.0f, 0.5f, flat), 0.5f);
  // A plane falling 0.01 per texel toward the light reaches depth 0 30 texels away from a
  // receiver at 0.3: a footprint of 10 at most.
  const glm::vec2 slope(0.006f, 0.008f);
  EXPECT_NEAR(momentReadFootprint(64.0f, 1000.0f, 0.3f, slope), 10.0f, 1e-4f);
  EXPECT_NEAR(momentReadFootprint(64.0f, 15.0f, 0.3f, slope), 5.0f, 1e-4f);
  EXPECT_FLOAT_EQ(momentReadFootprint(64.0f, 1000.0f, 0.0f, slope), 1.0f);
  for (float wanted : {0.0f, 1.0f, 3.0f, 1e9f}) {
    const float f = momentReadFootprint(wanted, 200.0f, 0.4f, slope);
    EXPECT_TRUE(std::isfinite(f) && f <= std::max(wanted, 1.0f) && f >= std::min(wanted, 1.0f))
        << wanted;
  }
}

TEST(Moments, BlurRadiusAndMemory) {
  EXPECT_FLOAT_EQ(momentBlurRadiusTexels(0.1, 0.02), 5.0f);
  EXPECT_FLOAT_EQ(momentBlurRadiusTexels(1.0, 0.01), float(CSM_MOMENT_MAX_BLUR_TEXELS));
  EXPECT_EQ(momentBlurRadiusTexels(0.0, 0.02), 0.0f);
  EXPECT_EQ(momentBlurRadiusTexels(0.1, 0.0), 0.0f);
  ShadowSettings s;
  s.resolution = 256;
  s.cascadeCount = 2;
  for (bool two : {false, true}) {
    EXPECT_EQ(momentImageBytes(s, two), 0u);  // a percentage-closer kernel keeps no moments
    EXPECT_EQ(momentTexelBytes(s.kernel, two), 0u);
  }
  // 2 layers x 87,381 texels (256^2 + 128^2 + ... + 1) x 16 bytes, and no blur scratch; where
  // the device stores the compact formats, vsm's two moments in two 32-bit channels and msm's
  // four quantised to 16 bits: 8 bytes. evsm's exponentials need 32-bit floats.
  for (PcfKernel k : {PcfKernel::kMsm, PcfKernel::kEvsm, PcfKernel::kVsm}) {
    s.kernel = k;
    EXPECT_EQ(momentImageBytes(s, false), 2796192u) << kernelName(k);
    EXPECT_EQ(momentImageBytes(s, true), k == PcfKernel::kEvsm ? 2796192u : 1398096u)
        << kernelName(k);
    EXPECT_EQ(momentTexelBytes(k, true), k == PcfKernel::kEvsm ? 16u : 8u) << kernelName(k);
  }
  s.cascadeCount = 0;
  EXPECT_EQ(momentImageBytes(s, true), 0u);
}

// MSM's 64-bit moments (CSM_MSM_QUANTIZE_*, which csm.glsl and csm_moments.comp share): the
// paper's optimised quantisation of (z, z^2, z^3, z^4) (Peters and Klein 2015, sec. 4.3),
// composed with the centring w = 2 z - 1, computed here in double from the paper's matrix.
TEST(Moments, MsmQuantisationIsThePapersComposedWithTheCentring) {
  const double paper[4][4] = {{-2.07224649, 13.7948857237, 0.105877704, 9.7924062118},
                              {32.23703778, -59.4683975703, -1.9077466311, -33.7652110555},
                              {-68.571074599, 82.0359750338, 9.3496555107, 47.9456096605},
                              {39.3703274134, -35.364903257, -6.6543490743, -23.9728048165}};
  const double offset0 = 0.035955884801;
  const ShadowSettings s;
  double worstQ = 0.0, worstRoundTrip = 0.0, lowest = 1.0, highest = 0.0;
  for (int n = 0; n <= 4096; ++n) {
    const double z = n / 4096.0;
    const double b[4] = {z, z * z, z * z * z, z * z * z * z};
    const glm::vec4 centred = depthMoments(PcfKernel::kMsm, float(z), s);
    const glm::vec4 q = msmQuantize(centred);
    for (int j = 0; j < 4; ++j) {
      double want = j == 0 ? offset0 : 0.0;
      for (int i = 0; i < 4; ++i) want += b[i] * paper[i][j];
      lowest = std::min(lowest, want);
      highest = std::max(highest, want);
      worstQ = std::max(worstQ, std::abs(double(q[j]) - std::clamp(want, 0.0, 1.0)));
    }
    const glm::vec4 back = msmDequantize(q);
    for (int j = 0; j < 4; ++j) {
      worstRoundTrip = std::max(worstRoundTrip, double(std::abs(back[j] - centred[j])));
    }
  }
  EXPECT_LT(worstQ, 2e-6);          // float arithmetic on the composed constants
  EXPECT_LT(worstRoundTrip, 2e-5);  // float arithmetic through E and D
  // Every depth's quantised moments lie in [0, 1]: the format holds them without clamping.
  EXPECT_GT(lowest, -1e-7);
  EXPECT_LT(highest, 1.0 + 1e-7);
}

// What the 64-bit image gives the lighting: each texel's moments quantised to 16 bits (rounded
// to nearest), mixed as the blur and the bilinear tap mix them, decoded, then reconstructed with
// the bias csm.glsl applies to them (kMsmQuantizedMinMomentBias), against 32-bit moments at the
// same bias. Receivers on or in front of a depth read lit with both; away from the depths (at
// least 0.02 of the depth range from each) the two agree within 0.07 for two depths in any
// proportion; a receiver 0.02 behind one depth reads at most 0.02 lit. Nearer a depth the format's
// rounding matters: 0.003 behind one depth, 32-bit moments read 0.06-0.22 lit and 64-bit ones
// 0.04-0.41 (the figures shadows/docs/prefiltered.md gives; why 128 bits stay the default).
TEST(Moments, QuantisedMsmReadsAsFloatMsmToTheFormatsRounding) {
  ShadowSettings s = noBleedReduction();
  s.msmMomentBias = kMsmQuantizedMinMomentBias;
  auto stored = [&](float z) {
    const glm::vec4 m = msmQuantize(depthMoments(PcfKernel::kMsm, z, s));
    return glm::round(m * 65535.0f) / 65535.0f;
  };
  float worst = 0.0f;
  std::string where;
  for (float z1 : {0.05f, 0.3f, 0.5f, 0.71f, 0.95f}) {
    for (float gap : {0.002f, 0.005f, 0.01f, 0.02f, 0.2f}) {
      const float z2 = std::min(z1 + gap, 1.0f);
      for (float f : {0.0f, 0.1f, 0.5f, 0.9f, 1.0f}) {
        const glm::vec4 exact = mixture(PcfKernel::kMsm, {{z1, f}, {z2, 1.0f - f}}, s);
        const glm::vec4 decoded = msmDequantize(f * stored(z1) + (1.0f - f) * stored(z2));
        for (float r = z1 - 0.05f; r <= z2 + 0.05f; r += 0.0025f) {
          if (std::min(std::abs(r - z1), std::abs(r - z2)) < 0.02f) continue;
          const float a = momentLitFraction(PcfKernel::kMsm, exact, r, 0.0f, s);
          const float b = momentLitFraction(PcfKernel::kMsm, decoded, r, 0.0f, s);
          if (std::abs(a - b) > worst) {
            worst = std::abs(a - b);
            where = "z " + std::to_string(z1) + ".." + std::to_string(z2) + " f " +
                    std::to_string(f) + " receiver " + std::to_string(r);
          }
        }
      }
    }
    // One depth: a receiver on it or in front reads lit, one 0.02 behind nearly shadowed.
    const glm::vec4 one = msmDequantize(stored(z1));
    for (float ahead : {0.0f, 0.001f, 0.01f}) {
      EXPECT_GT(momentLitFraction(PcfKernel::kMsm, one, z1 - ahead, 0.0f, s), 0.99f) << z1;
    }
    EXPECT_LT(momentLitFraction(PcfKernel::kMsm, one, z1 + 0.02f, 0.0f, s), 0.02f) << z1;
    EXPECT_LT(momentLitFraction(PcfKernel::kMsm, one, z1 + 0.05f, 0.0f, s), 0.003f) << z1;
  }
  EXPECT_LE(worst, 0.07f) << where;
}

TEST(Moments, SettingsOutOfRangeAreRefusedByName) {
  auto refused = [](auto edit, const char* field) {
    ShadowSettings s;
    s.kernel = PcfKernel::kEvsm;
    edit(s);
    const auto e = validate(s);
    ASSERT_TRUE(e.has_value()) << field;
    EXPECT_EQ(e->field, std::string("settings.") + field);
  };
  refused([](ShadowSettings& s) { s.momentBlurM = 10.5; }, "momentBlurM");
  refused([](ShadowSettings& s) { s.momentBlurM = -0.1; }, "momentBlurM");
  refused([](ShadowSettings& s) { s.momentBleedReduction = 0.96f; }, "momentBleedReduction");
  refused([](ShadowSettings& s) { s.evsmPositiveExponent = 42.5f; }, "evsmPositiveExponent");
  refused([](ShadowSettings& s) { s.evsmNegativeExponent = 0.0f; }, "evsmNegativeExponent");
  refused([](ShadowSettings& s) { s.msmMomentBias = 0.0f; }, "msmMomentBias");
  refused([](ShadowSettings& s) { s.kernel = static_cast<PcfKernel>(CSM_FILTER_COUNT); }, "kernel");
  ShadowSettings ok;
  ok.kernel = PcfKernel::kMsm;
  EXPECT_FALSE(validate(ok).has_value());
}

TEST(Moments, NamesParseAndRoundTrip) {
  for (PcfKernel k : kAllFilters) {
    const Result<PcfKernel> r = parseKernel(kernelName(k));
    ASSERT_TRUE(r) << kernelName(k);
    EXPECT_EQ(r.value(), k);
  }
  EXPECT_TRUE(isPrefiltered(PcfKernel::kVsm));
  EXPECT_FALSE(isPrefiltered(PcfKernel::kPcss));
  EXPECT_NE(kernelNames().find("msm"), std::string::npos);
}

}  // namespace
}  // namespace csm
