#include <gtest/gtest.h>

#include "csm/gpu_layout.hpp"
#include "test_util.hpp"

namespace csm {
namespace {

TEST(Selection, PicksByViewDepthAndBlendsAcrossTheBand) {
  ShadowSettings s;
  s.cascadeCount = 4;
  s.splitLambda = 0.0;  // uniform splits: easy to reason about
  s.shadowDistanceM = 400.0;
  Camera cam;
  cam.nearM = 0.5;
  const CascadeFrame f = test::computeOrDie(s, cam, DirectionalLight{});
  const double band = 0.2;
  EXPECT_EQ(selectCascade(f, 0.4, band).index, -1);    // before near
  EXPECT_EQ(selectCascade(f, 400.0, band).index, -1);  // at/after the last split
  EXPECT_EQ(selectCascade(f, 1e9, band).index, -1);
  EXPECT_EQ(selectCascade(f, std::nan(""), band).index, -1);
  for (std::uint32_t i = 0; i < 4; ++i) {
    const double a = f.splitsM[i], b = f.splitsM[i + 1];
    const auto mid = selectCascade(f, a + 0.5 * (b - a), band);
    EXPECT_EQ(mid.index, int(i));
    EXPECT_EQ(mid.blendIndex, -1);
    EXPECT_EQ(selectCascade(f, a, band).index, int(i));
    const auto inBand = selectCascade(f, b - 0.25 * band * (b - a), band);
    EXPECT_EQ(inBand.index, int(i));
    if (i + 1 < 4) {
      EXPECT_EQ(inBand.blendIndex, int(i + 1));
      EXPECT_NEAR(inBand.blendWeight, 0.75, 1e-6);
    } else {
      EXPECT_EQ(inBand.blendIndex, -1);  // nothing beyond the last cascade
    }
  }
  // The weight rises monotonically across the band from 0 to 1.
  float prev = -1.0f;
  const double a = f.splitsM[1], b = f.splitsM[2];
  for (int k = 0; k <= 100; ++k) {
    const double d = b - band * (b - a) + (band * (b - a)) * k / 100.0 * 0.9999;
    const auto sel = selectCascade(f, d, band);
    EXPECT_GE(sel.blendWeight, prev);
    prev = sel.blendWeight;
  }
  EXPECT_GT(prev, 0.99f);
  // No band: no blending anywhere.
  EXPECT_EQ(selectCascade(f, b - 1e-3, 0.0).blendIndex, -1);
  // The band's start belongs to the band (weight 0), as in csm.glsl's `viewDepth >= bandStart`.
  const double bandStart = b - band * (b - a);
  const auto atStart = selectCascade(f, bandStart, band);
  EXPECT_EQ(atStart.blendIndex, 2);
  EXPECT_EQ(atStart.blendWeight, 0.0f);
  EXPECT_EQ(selectCascade(f, std::nextafter(bandStart, 0.0), band).blendIndex, -1);
}

TEST(Selection, ViewDepthAndEmptyCascades) {
  ShadowSettings s;
  Camera cam;
  cam.positionWs = {1e7, 0, 0};
  cam.orientationWs = test::lookAlong({1, 0, 0});
  const AabbWs scene{{1e7 + 100, -5, -5}, {1e7 + 200, 5, 5}};
  s.shadowDistanceM = 400.0;
  const CascadeFrame f = test::computeOrDie(s, cam, DirectionalLight{}, &scene);
  EXPECT_NEAR(viewDepthM(f, {1e7 + 150, 3, 2}), 150.0, 1e-9);
  EXPECT_TRUE(f.cascades[0].empty);
  EXPECT_EQ(selectCascade(f, f.splitsM[0] + 1e-3, 0.1).index, -1);
}

TEST(Fade, SmoothstepToLitOverTheLastFractionOfTheShadowDistance) {
  ShadowSettings s;
  s.shadowDistanceM = 400.0;
  Camera cam;
  const CascadeFrame f = test::computeOrDie(s, cam, DirectionalLight{});
  ASSERT_EQ(s.fadeFraction, 0.1);  // the default fades
  EXPECT_EQ(f.fadeEndM, 400.0);
  EXPECT_EQ(f.fadeLengthM, 40.0);
  EXPECT_EQ(shadowFade(f, 0.0), 0.0);
  EXPECT_EQ(shadowFade(f, 360.0), 0.0);
  EXPECT_DOUBLE_EQ(shadowFade(f, 380.0), 0.5);
  EXPECT_DOUBLE_EQ(shadowFade(f, 370.0), 0.25 * 0.25 * (3.0 - 0.5));
  EXPECT_EQ(shadowFade(f, 400.0), 1.0);
  EXPECT_EQ(shadowFade(f, 1e9), 1.0);
  EXPECT_EQ(shadowFade(f, std::nan("")), 0.0);
  double last = 0.0;
  for (double d = 355.0; d <= 405.0; d += 0.5) {
    const double w = shadowFade(f, d);
    EXPECT_GE(w, last) << d;  // monotone
    last = w;
  }
  // Packed for csm.glsl: the end and the inverse length.
  const CsmUniforms u = packUniforms(f, s);
  EXPECT_EQ(u.fadeEndM, 400.0f);
  EXPECT_FLOAT_EQ(u.invFadeLengthM, 1.0f / 40.0f);

  // 0: the hard cut, nothing fades, and the block says so.
  s.fadeFraction = 0.0;
  const CascadeFrame hard = test::computeOrDie(s, cam, DirectionalLight{});
  EXPECT_EQ(hard.fadeLengthM, 0.0);
  EXPECT_EQ(shadowFade(hard, 399.9), 0.0);
  EXPECT_EQ(packUniforms(hard, s).invFadeLengthM, 0.0f);
  // A frame built by hand (no computeCascades) does not fade.
  EXPECT_EQ(shadowFade(CascadeFrame{}, 10.0), 0.0);

  // Anchored at the host's shadow distance, not at where the splits end: a scene that ends at
  // 150 m pulls the splits in, and its receivers there must not fade.
  s.fadeFraction = 0.1;
  const AabbWs scene{{-100.0, -1.0, -150.0}, {100.0, 10.0, 0.0}};
  const CascadeFrame shortScene = test::computeOrDie(s, cam, DirectionalLight{}, &scene);
  ASSERT_LT(shortScene.shadowFarM, 300.0);
  EXPECT_EQ(shadowFade(shortScene, shortScene.shadowFarM * 0.99), 0.0);
}

}  // namespace
}  // namespace csm
