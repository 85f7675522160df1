// Extreme but valid inputs: every matrix finite, every slice inside its sphere and its light box.
#include <gtest/gtest.h>

#include <algorithm>

#include "test_util.hpp"

namespace csm {
namespace {

struct Extreme {
  double nearM, farM, fovDeg, aspect;
  std::uint32_t count, resolution;
};

void checkContainment(const CascadeFrame& f, const Camera& cam, const std::string& what) {
  for (std::uint32_t c = 0; c < f.cascadeCount; ++c) {
    const Cascade& k = f.cascades[c];
    ASSERT_TRUE(test::allFinite(k.viewProjCr)) << what << " cascade " << c;
    ASSERT_TRUE(std::isfinite(k.sphereRadiusM) && k.sphereRadiusM > 0.0) << what;
    ASSERT_TRUE(std::isfinite(k.texelSizeM()) && k.texelSizeM() > 0.0) << what;
    ASSERT_TRUE(std::isfinite(k.depthNearLs) && std::isfinite(k.depthFarLs)) << what;
    const auto corners = sliceCornersCr(cam, k.splitNearM, k.splitFarM);
    for (const glm::dvec3& cr : corners) {
      const glm::dvec3 pWs = cam.positionWs + cr;
      const double r = k.sphereRadiusM;
      EXPECT_LE(glm::length(pWs - k.sphereCenterWs), r * (1.0 + 1e-6)) << what << " c" << c;
      // Inside the light box, in double...
      const glm::dvec3 ls = toLightSpace(f.lightBasisWs, k.boxCenterWs, pWs);
      EXPECT_LE(std::abs(ls.x), k.halfExtentLs.x * (1.0 + 1e-9)) << what << " c" << c;
      EXPECT_LE(std::abs(ls.y), k.halfExtentLs.y * (1.0 + 1e-9)) << what << " c" << c;
      EXPECT_GE(ls.z, k.depthNearLs - 1e-9 * r) << what;
      EXPECT_LE(ls.z, k.depthFarLs + 1e-9 * r) << what;
      // ...and through the float camera-relative matrix the shader uses.
      const glm::vec4 clip = k.viewProjCr * glm::vec4(glm::vec3(cr), 1.0f);
      ASSERT_TRUE(std::isfinite(clip.x) && std::isfinite(clip.y) && std::isfinite(clip.z));
      EXPECT_LE(std::abs(clip.x), 1.0f + 1e-4f) << what << " c" << c;
      EXPECT_LE(std::abs(clip.y), 1.0f + 1e-4f) << what << " c" << c;
      EXPECT_GE(clip.z, -1e-4f) << what;
      EXPECT_LE(clip.z, 1.0f + 1e-4f) << what;
    }
  }
}

ShadowSettings settingsFor(const Extreme& e) {
  ShadowSettings s;
  s.cascadeCount = e.count;
  s.resolution = e.resolution;
  s.shadowDistanceM = std::min(e.farM, kMaxWorldCoordinateM);
  return s;
}

Camera cameraFor(const Extreme& e, const glm::dvec3& positionWs, const glm::dvec3& forward) {
  Camera cam;
  cam.nearM = e.nearM;
  cam.farM = e.farM;
  cam.fovYRad = glm::radians(e.fovDeg);
  cam.aspect = e.aspect;
  cam.positionWs = positionWs;
  cam.orientationWs = test::lookAlong(forward);
  return cam;
}

TEST(Extremes, AllCombinationsFiniteAndContained) {
  const Extreme ranges[] = {{1e-3, 1e5, 60, 16.0 / 9.0, 4, 2048}, {1e-3, 1e5, 1, 1, 8, 16384},
                            {1e-3, 1e5, 179, 100, 8, 256},        {0.1, 500, 1, 0.01, 1, 256},
                            {0.1, 500, 179, 0.01, 1, 16384},      {0.1, 500, 179, 100, 8, 16384},
                            {1e-3, 1e5, 1, 100, 1, 16384},        {0.5, 1e5, 90, 0.01, 8, 256}};
  const glm::dvec3 lights[] = {{0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}, {0.01, -1, 0}};
  const glm::dvec3 positions[] = {{0, 0, 0}, {1e7, 100, -1e7}, {-1e7, -1e7, 1e7}};
  for (const Extreme& e : ranges) {
    for (const glm::dvec3& lightDir : lights) {
      for (const glm::dvec3& pos : positions) {
        for (bool stabilize : {true, false}) {
          ShadowSettings s = settingsFor(e);
          s.diagnostics.stabilize = stabilize;
          // The camera looks along -Z: lights (0,0,-1) and (0,0,1) are along and against
          // the view; (0,-1,0) and (0,1,0) straight down and up.
          const Camera cam = cameraFor(e, pos, {0, 0, -1});
          DirectionalLight light{lightDir};
          auto r = computeCascades(s, cam, light);
          ASSERT_TRUE(r.ok()) << r.error().message();
          const std::string what = "near " + std::to_string(e.nearM) + " far " +
                                   std::to_string(e.farM) + " fov " + std::to_string(e.fovDeg) +
                                   " aspect " + std::to_string(e.aspect) + " N " +
                                   std::to_string(e.count) + " res " +
                                   std::to_string(e.resolution) + (stabilize ? " stab" : " tight");
          checkContainment(r.value(), cam, what);
        }
      }
    }
  }
}

// The domain's limits (types.hpp): positions at +-kMaxWorldCoordinateM, the nearest near
// plane and the largest far / near ratio, at every light of the test above.
TEST(Extremes, AtTheDomainLimitsFiniteAndContained) {
  const Extreme ranges[] = {{kMinNearM, kMinNearM * kMaxFarOverNear, 60, 16.0 / 9.0, 4, 2048},
                            {1e-3, 1e-3 * kMaxFarOverNear, 1, 1, 8, 16384},
                            {kMinNearM, 1.0, 179, 100, 8, 256}};
  const glm::dvec3 lights[] = {{0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}, {0.01, -1, 0}};
  const double m = kMaxWorldCoordinateM;
  const glm::dvec3 positions[] = {{m, m, m}, {-m, 100, m}, {m, -m, -m}};
  for (const Extreme& e : ranges) {
    for (const glm::dvec3& lightDir : lights) {
      for (const glm::dvec3& pos : positions) {
        const Camera cam = cameraFor(e, pos, {0.3, -0.2, -1});
        auto r = computeCascades(settingsFor(e), cam, DirectionalLight{lightDir});
        ASSERT_TRUE(r.ok()) << r.error().message();
        checkContainment(r.value(), cam,
                         "near " + std::to_string(e.nearM) + " far " + std::to_string(e.farM));
      }
    }
  }
}

TEST(Extremes, CameraLookingStraightDownAndUp) {
  for (const glm::dvec3& view : {glm::dvec3(0, -1, 0), glm::dvec3(0, 1, 0)}) {
    ShadowSettings s;
    Camera cam;
    cam.positionWs = {5e6, 300, 5e6};
    cam.orientationWs = test::lookAlong(view);
    DirectionalLight light{{0, -1, 0}};
    const CascadeFrame f = test::computeOrDie(s, cam, light);
    checkContainment(f, cam, "vertical view");
  }
}

TEST(Extremes, WithSceneBoundsDepthCoversEveryCaster) {
  ShadowSettings s;
  Camera cam;
  cam.positionWs = {1e7, 50, 1e7};
  cam.orientationWs = test::lookAlong({1, -0.2, 0});
  DirectionalLight light{{0.5, -0.3, 0.1}};
  const AabbWs scene{{1e7 - 3000, -100, 1e7 - 3000}, {1e7 + 3000, 800, 1e7 + 3000}};
  const CascadeFrame f = test::computeOrDie(s, cam, light, &scene);
  for (std::uint32_t c = 0; c < f.cascadeCount; ++c) {
    const Cascade& k = f.cascades[c];
    if (k.empty) continue;
    for (int i = 0; i < 8; ++i) {
      const glm::dvec3 p((i & 1) ? scene.maxWs.x : scene.minWs.x,
                         (i & 2) ? scene.maxWs.y : scene.minWs.y,
                         (i & 4) ? scene.maxWs.z : scene.minWs.z);
      const glm::dvec3 ls = toLightSpace(f.lightBasisWs, k.boxCenterWs, p);
      // Every scene point toward the light from the far side is within the depth range.
      if (ls.z <= k.depthFarLs) {
        EXPECT_GE(ls.z, k.depthNearLs - 1e-6) << c;
      }
    }
  }
}

}  // namespace
}  // namespace csm
