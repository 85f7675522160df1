#include <gtest/gtest.h>

#include "test_util.hpp"

namespace csm {
namespace {

TEST(Splits, StrictlyIncreasingWithExactEndpoints) {
  const double nears[] = {1e-3, 0.1, 1.0};
  const double fars[] = {2.0, 150.0, 1e5};
  for (double n : nears) {
    for (double f : fars) {
      if (!(f > n)) continue;
      for (std::uint32_t count = 1; count <= kMaxCascades; ++count) {
        for (double lambda : {0.0, 0.25, 0.5, 0.75, 0.95, 1.0}) {
          const SplitArray d = practicalSplits(n, f, count, lambda);
          ASSERT_EQ(d[0], n);
          ASSERT_EQ(d[count], f);
          for (std::uint32_t i = 0; i < count; ++i) {
            ASSERT_LT(d[i], d[i + 1])
                << "n=" << n << " f=" << f << " N=" << count << " lambda=" << lambda << " i=" << i;
          }
        }
      }
    }
  }
}

TEST(Splits, LambdaEndsAreUniformAndLogarithmicExactly) {
  for (std::uint32_t count = 1; count <= kMaxCascades; ++count) {
    const SplitArray uni = uniformSplits(0.5, 800.0, count);
    const SplitArray log = logarithmicSplits(0.5, 800.0, count);
    EXPECT_EQ(practicalSplits(0.5, 800.0, count, 0.0), uni);
    EXPECT_EQ(practicalSplits(0.5, 800.0, count, 1.0), log);
    for (std::uint32_t i = 0; i <= count; ++i) {
      // Analytic values.
      EXPECT_NEAR(uni[i], 0.5 + 799.5 * i / count, 1e-12);
      EXPECT_NEAR(log[i], 0.5 * std::pow(1600.0, double(i) / count), 1e-9);
    }
  }
}

TEST(Splits, QuantizedFarCoversAndStepsWithHysteresis) {
  const double maxM = 1000.0;
  double prev = 0.0;
  int changes = 0;
  // Needed distance oscillating by 1% around 300 m: the result must cover it and not flicker.
  for (int frame = 0; frame < 200; ++frame) {
    const double needed = 300.0 * (1.0 + 0.01 * std::sin(frame * 0.3));
    const double far = quantizedShadowFar(needed, maxM, 0.2, prev);
    ASSERT_GE(far, needed);
    ASSERT_LE(far, needed * std::exp2(3.0 / 16.0));
    if (prev != 0.0 && far != prev) ++changes;
    prev = far;
  }
  EXPECT_LE(changes, 1);
  // Growing beyond the current value takes effect at once.
  EXPECT_GE(quantizedShadowFar(700.0, maxM, 0.2, prev), 700.0);
  // At or beyond the maximum: exactly the maximum.
  EXPECT_EQ(quantizedShadowFar(1000.0, maxM, 0.2, 0.0), maxM);
  EXPECT_EQ(quantizedShadowFar(5000.0, maxM, 0.2, 0.0), maxM);
  EXPECT_EQ(quantizedShadowFar(std::nan(""), maxM, 0.2, 0.0), maxM);
}

TEST(Splits, SceneThatEndsAt300mGetsNoCascadePastIt) {
  ShadowSettings s;
  s.shadowDistanceM = 2000.0;
  s.cascadeCount = 4;
  Camera cam;
  cam.farM = 5000.0;
  cam.positionWs = {0, 2, 0};
  cam.orientationWs = test::lookAlong({0, 0, -1});
  DirectionalLight light{{0.3, -1.0, 0.2}};
  const AabbWs scene{{-300, -10, -300}, {300, 50, 300}};
  // Stabilised, the splits end at the farthest corner's distance (a turn moves no split).
  const double reachM = glm::length(glm::dvec3(300.0, 48.0, 300.0));
  const CascadeFrame f = test::computeOrDie(s, cam, light, &scene);
  EXPECT_GE(f.splitsM[4], reachM);
  EXPECT_LE(f.splitsM[4], reachM * std::exp2(1.0 / 16.0) + 1e-9);
  for (std::uint32_t i = 0; i < 4; ++i) EXPECT_FALSE(f.cascades[i].empty);
  // Unstabilised, at the far edge of the box 300 m ahead (the corner's depth along the view).
  s.diagnostics.stabilize = false;
  const CascadeFrame g = test::computeOrDie(s, cam, light, &scene);
  EXPECT_GE(g.splitsM[4], 300.0);
  EXPECT_LE(g.splitsM[4], 300.0 * std::exp2(1.0 / 16.0) + 1e-9);
  for (std::uint32_t i = 0; i < 4; ++i) EXPECT_FALSE(g.cascades[i].empty);
}

TEST(Splits, CascadesWithoutReceiversAreEmpty) {
  ShadowSettings s;
  s.shadowDistanceM = 1000.0;
  s.cascadeCount = 4;
  s.splitLambda = 0.0;  // uniform: 0.1, 250, 500, 750, 1000
  Camera cam;
  cam.orientationWs = test::lookAlong({0, 0, -1});
  DirectionalLight light;
  // Receivers only between 600 m and 900 m ahead.
  const AabbWs scene{{-20, -1, -900}, {20, 1, -600}};
  const CascadeFrame f = test::computeOrDie(s, cam, light, &scene);
  // Splits end at the scene's far end (quantised), so every cascade beyond it is gone...
  EXPECT_LE(f.shadowFarM, 900.0 * std::exp2(1.0 / 16.0));
  // ...and the near cascades, which hold no receiver, are empty.
  EXPECT_TRUE(f.cascades[0].empty);
  EXPECT_FALSE(f.cascades[3].empty);
  // Scene entirely behind the camera: every cascade is empty.
  const AabbWs behind{{-20, -1, 100}, {20, 1, 200}};
  const CascadeFrame g = test::computeOrDie(s, cam, light, &behind);
  for (std::uint32_t i = 0; i < 4; ++i) EXPECT_TRUE(g.cascades[i].empty) << i;
}

}  // namespace
}  // namespace csm
