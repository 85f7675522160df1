// The prefiltered filters' math (csm/moments.hpp), which csm.glsl and csm_moments.comp mirror:
// exact answers for one depth and for two depths in known proportion, Chebyshev's bound, the
// extremes (no NaN, no overflow at the largest EVSM exponent), and the settings' refusals.
#include <gtest/gtest.h>

#include <cmath>

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

TEST(Moments, BlurRadiusAndMemory) {
  EXPECT_FLOAT_EQ(momentBlurRadiusTexels(0.1, 0.02), 5.0f);
  EXPECT_FLOAT_EQ(momentBlurRadiusTexels(1.0, 0.01), float(CSM_MOMENT_MAX_BLUR_TEXELS));
  EXPECT_EQ(momentBlurRadiusTexels(0.0, 0.02), 0.0f);
  EXPECT_EQ(momentBlurRadiusTexels(0.1, 0.0), 0.0f);
  ShadowSettings s;
  s.resolution = 256;
  s.cascadeCount = 2;
  EXPECT_EQ(momentImageBytes(s), 0u);  // a percentage-closer kernel keeps no moments
  s.kernel = PcfKernel::kMsm;
  std::uint64_t mips = 0;
  for (std::uint64_t side = 256; side >= 1; side /= 2) mips += side * side;
  EXPECT_EQ(momentImageBytes(s), (mips * 2u + 256u * 256u) * 16u);  // scratch: one layer
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
