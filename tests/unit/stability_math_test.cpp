// The properties that make stabilised cascades shimmer-free: rotation cannot change a texel's
// size, translation moves the texel grid by whole texels only, at any distance from the origin.
#include <gtest/gtest.h>

#include "test_util.hpp"

namespace csm {
namespace {

TEST(Stability, RotationLeavesRadiiAndTexelSizesBitIdentical) {
  std::mt19937_64 rng(11);
  for (std::uint32_t count : {1u, 4u, 8u}) {
    ShadowSettings s;
    s.cascadeCount = count;
    s.resolution = 2048;
    Camera cam;
    cam.positionWs = {1234.5, 67.0, -890.25};
    DirectionalLight light{{0.4, -0.8, 0.3}};
    cam.orientationWs = test::randomOrientation(rng);
    const CascadeFrame ref = test::computeOrDie(s, cam, light);
    for (int i = 0; i < 3000; ++i) {
      // Yaw, pitch and roll all at once: any rotation.
      cam.orientationWs = test::randomOrientation(rng);
      const CascadeFrame f = test::computeOrDie(s, cam, light);
      for (std::uint32_t c = 0; c < count; ++c) {
        ASSERT_EQ(f.cascades[c].sphereRadiusM, ref.cascades[c].sphereRadiusM);
        ASSERT_EQ(f.cascades[c].halfExtentLs, ref.cascades[c].halfExtentLs);
        ASSERT_EQ(f.cascades[c].texelSizeLs, ref.cascades[c].texelSizeLs);
        ASSERT_EQ(f.cascades[c].depthFarLs, ref.cascades[c].depthFarLs);
      }
    }
  }
}

struct Origin {
  const char* name;
  glm::dvec3 positionWs;
};

class TranslationTest : public ::testing::TestWithParam<Origin> {};

// Texel coordinates of fixed world points, by the double-precision mapping and by the float
// camera-relative matrix a shader uses.
glm::dvec2 texelByMatrix(const CascadeFrame& f, std::uint32_t c, const glm::dvec3& pWs) {
  const glm::vec3 pCr(pWs - f.cameraPositionWs);
  const glm::vec4 clip = f.cascades[c].viewProjCr * glm::vec4(pCr, 1.0f);
  return {(clip.x * 0.5 + 0.5) * f.resolution, (clip.y * 0.5 + 0.5) * f.resolution};
}

double fracDistance(double x) {
  return std::abs(x - std::round(x));
}

TEST_P(TranslationTest, MovesTheGridByWholeTexelsOnly) {
  std::mt19937_64 rng(19);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  ShadowSettings s;
  s.cascadeCount = 4;
  s.resolution = 2048;
  s.shadowDistanceM = 400.0;
  DirectionalLight light{{-0.3, -0.9, 0.2}};
  Camera cam;
  cam.positionWs = GetParam().positionWs;
  cam.orientationWs = test::randomOrientation(rng);
  const CascadeFrame first = test::computeOrDie(s, cam, light);

  // Fixed world points inside each cascade's sphere, chosen once.
  std::array<std::vector<glm::dvec3>, kMaxCascades> points;
  for (std::uint32_t c = 0; c < 4; ++c) {
    for (int k = 0; k < 32; ++k) {
      const glm::dvec3 d(unit(rng), unit(rng), unit(rng));
      points[c].push_back(first.cascades[c].sphereCenterWs +
                          0.5 * first.cascades[c].sphereRadiusM * d);
    }
  }
  CascadeFrame prev = first;
  double worstDouble = 0.0, worstFloat = 0.0;
  for (int step = 0; step < 400; ++step) {
    // Alternate sub-texel and multi-texel moves (in units of the smallest texel).
    const double texel0 = prev.cascades[0].texelSizeM();
    const double len = (step % 2 == 0) ? 0.9 * texel0 : 37.0 * texel0;
    const glm::dvec3 dir = glm::normalize(glm::dvec3(unit(rng), unit(rng), unit(rng)));
    cam.positionWs += dir * len * std::abs(unit(rng));
    const CascadeFrame f = test::computeOrDie(s, cam, light);
    for (std::uint32_t c = 0; c < 4; ++c) {
      ASSERT_EQ(f.cascades[c].texelSizeLs, first.cascades[c].texelSizeLs);
      for (const glm::dvec3& p : points[c]) {
        const glm::dvec3 a = shadowTexelCoord(prev.cascades[c], prev, p);
        const glm::dvec3 b = shadowTexelCoord(f.cascades[c], f, p);
        worstDouble = std::max({worstDouble, fracDistance(b.x - a.x), fracDistance(b.y - a.y)});
        const glm::dvec2 am = texelByMatrix(prev, c, p);
        const glm::dvec2 bm = texelByMatrix(f, c, p);
        worstFloat = std::max({worstFloat, fracDistance(bm.x - am.x), fracDistance(bm.y - am.y)});
      }
    }
    prev = f;
  }
  EXPECT_LT(worstDouble, 1e-3) << GetParam().name;
  EXPECT_LT(worstFloat, 1e-3) << GetParam().name;
}

INSTANTIATE_TEST_SUITE_P(Origins, TranslationTest,
                         ::testing::Values(Origin{"origin", {0.0, 10.0, 0.0}},
                                           Origin{"at1e6", {1e6, 10.0, -1e6}},
                                           Origin{"at1e7", {1e7, 10.0, 1e7}},
                                           Origin{"at1e7y", {-1e7, 1e7, 3e6}},
                                           // The domain's edge (kMaxWorldCoordinateM), with
                                           // room for the flight's few hundred metres.
                                           Origin{"at1e9", {-9.99999e8, 3e3, 9.99999e8}}),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(Stability, UnstabilisedModeMovesBySubTexelAmounts) {
  // The comparison mode must actually differ: a sub-texel move shifts its grid fractionally.
  ShadowSettings s;
  s.diagnostics.stabilize = false;
  Camera cam;
  DirectionalLight light{{-0.3, -0.9, 0.2}};
  const CascadeFrame a = test::computeOrDie(s, cam, light);
  cam.positionWs += glm::dvec3(0.0013, 0.0, 0.0021);
  const CascadeFrame b = test::computeOrDie(s, cam, light);
  const glm::dvec3 p = a.cascades[0].sphereCenterWs;
  const glm::dvec3 ta = shadowTexelCoord(a.cascades[0], a, p);
  const glm::dvec3 tb = shadowTexelCoord(b.cascades[0], b, p);
  EXPECT_GT(fracDistance(tb.x - ta.x) + fracDistance(tb.y - ta.y), 1e-3);
}

TEST(Stability, SceneClampChangesOnlyInRareSteps) {
  // Flying toward the end of a scene: the shadow far distance follows in quantised steps, so
  // the texel size changes on a handful of frames, not on every frame. (Stabilised, the far end
  // is the farthest corner's distance, so the scene lies within the shadow distance all round.)
  ShadowSettings s;
  s.shadowDistanceM = 1500.0;
  Camera cam;
  cam.farM = 4000.0;
  cam.orientationWs = test::lookAlong({0, -0.1, -1});
  DirectionalLight light{{0.2, -1.0, 0.1}};
  const AabbWs scene{{-300, -50, -2000}, {300, 200, -700}};
  CascadeHistory history;
  double prevTexel = 0.0;
  int changes = 0;
  const int frames = 600;
  for (int i = 0; i < frames; ++i) {
    cam.positionWs = {0.0, 20.0, -800.0 - 1.5 * i};  // approach the far edge at z = -2000
    cam.orientationWs = test::lookAlong({std::sin(i * 0.05) * 0.05, -0.1, -1});  // jitter
    const CascadeFrame f = test::computeOrDie(s, cam, light, &scene, &history);
    const double texel = f.cascades[3].texelSizeM();
    if (prevTexel != 0.0 && texel != prevTexel) ++changes;
    prevTexel = texel;
  }
  EXPECT_GT(changes, 0);            // the clamp does follow the scene
  EXPECT_LT(changes, frames / 20);  // but only in steps
}

TEST(Stability, TurningInPlaceInABoundedSceneMovesNoSplitAndNoTexel) {
  // A scene smaller than the shadow distance clips the splits; a full turn of the camera in
  // place (yaw and pitch) must not step them, nor any cascade's texel size, nor any box off its
  // grid point, at 0, 10^6 and 10^7 m from the origin.
  for (const double origin : {0.0, 1e6, 1e7}) {
    ShadowSettings s;
    s.shadowDistanceM = 200.0;
    s.cascadeCount = 4;
    s.resolution = 2048;
    Camera cam;
    cam.farM = 1000.0;
    const glm::dvec3 o(origin, 0.0, origin);
    cam.positionWs = o + glm::dvec3(10.0, 3.0, 20.0);
    DirectionalLight light{{0.35, -0.8, 0.25}};
    const AabbWs scene{o + glm::dvec3(-60, -5, -90), o + glm::dvec3(50, 30, 40)};
    CascadeHistory history;
    CascadeFrame first;
    for (int i = 0; i < 720; ++i) {
      const double yaw = glm::radians(0.5 * i);
      const double pitch = glm::radians(-10.0 + 8.0 * std::sin(0.03 * i));
      cam.orientationWs = test::lookAlong(
          {std::sin(yaw) * std::cos(pitch), std::sin(pitch), -std::cos(yaw) * std::cos(pitch)});
      const CascadeFrame f = test::computeOrDie(s, cam, light, &scene, &history);
      if (i == 0) {
        first = f;
        EXPECT_LT(f.splitsM[4], s.shadowDistanceM) << "the scene must clip the splits";
        continue;
      }
      for (std::uint32_t c = 0; c <= 4; ++c) {
        ASSERT_EQ(f.splitsM[c], first.splitsM[c]) << "split " << c << " at frame " << i;
      }
      for (std::uint32_t c = 0; c < 4; ++c) {
        ASSERT_EQ(f.cascades[c].texelSizeM(), first.cascades[c].texelSizeM())
            << "cascade " << c << " at frame " << i << ", " << origin << " m";
      }
    }
    for (std::uint32_t c = 0; c < 4; ++c) EXPECT_EQ(history.sizeRungEvents[c], 0u);
  }
}

}  // namespace
}  // namespace csm
