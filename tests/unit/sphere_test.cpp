// The slice sphere: contains every corner, is minimal, and depends on the slice alone.
#include <gtest/gtest.h>

#include "test_util.hpp"

namespace csm {
namespace {

struct SliceParams {
  double fovDeg, aspect, nearM, farM;
};

TEST(SliceSphere, ContainsCornersAndIsMinimal) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> fov(1.0, 179.0),
      logAspect(std::log(0.01), std::log(100.0)), logNear(std::log(1e-3), std::log(100.0)),
      logRatio(std::log(1.0001), std::log(1e4));
  std::vector<SliceParams> params = {{60, 16.0 / 9.0, 0.1, 10}, {1, 1, 1e-3, 1e5},
                                     {179, 100, 1e-3, 1e5},     {90, 0.01, 5, 6},
                                     {170, 20, 0.5, 400},       {10, 0.05, 100, 100.5}};
  for (int i = 0; i < 2000; ++i) {
    const double n = std::exp(logNear(rng));
    params.push_back({fov(rng), std::exp(logAspect(rng)), n, n * std::exp(logRatio(rng))});
  }
  for (const auto& p : params) {
    Camera cam;
    cam.fovYRad = glm::radians(p.fovDeg);
    cam.aspect = p.aspect;
    cam.orientationWs = test::randomOrientation(rng);
    const SliceSphere s = minimalSliceSphere(cam.fovYRad, cam.aspect, p.nearM, p.farM);
    const auto corners = sliceCornersCr(cam, p.nearM, p.farM);
    const glm::dvec3 centerCr = cam.forwardWs() * s.centerDepthM;
    const double rq = quantizeLengthUp(s.radiusM);
    for (const auto& c : corners) {
      ASSERT_LE(glm::length(c - centerCr), s.radiusM * (1.0 + 1e-6))
          << "fov " << p.fovDeg << " aspect " << p.aspect << " n " << p.nearM << " f " << p.farM;
      ASSERT_LE(glm::length(c - centerCr), rq * (1.0 + 1e-6));
    }
    const test::Sphere ref = test::bruteForceMinimalSphere(corners);
    ASSERT_GT(ref.radius, 0.0);
    EXPECT_NEAR(s.radiusM, ref.radius, 1e-4 * ref.radius)
        << "fov " << p.fovDeg << " aspect " << p.aspect << " n " << p.nearM << " f " << p.farM;
    // The quantised radius is within 1e-4 of the minimal one too.
    EXPECT_LE(rq, ref.radius * (1.0 + 1e-4));
    EXPECT_GE(rq, s.radiusM);
  }
}

TEST(SliceSphere, FarCapCaseAndEquidistantCase) {
  // Narrow slice far away: centre equidistant from near and far corners, inside the slice.
  const SliceSphere a = minimalSliceSphere(glm::radians(10.0), 1.0, 100.0, 110.0);
  EXPECT_GT(a.centerDepthM, 100.0);
  EXPECT_LT(a.centerDepthM, 110.0);
  // Wide FOV: the far cap's centre, radius = far * k.
  const SliceSphere b = minimalSliceSphere(glm::radians(120.0), 2.0, 1.0, 10.0);
  EXPECT_EQ(b.centerDepthM, 10.0);
  const double t = std::tan(glm::radians(60.0));
  EXPECT_NEAR(b.radiusM, 10.0 * t * std::sqrt(1.0 + 4.0), 1e-12);
}

TEST(SliceSphere, QuantizeLengthUp) {
  EXPECT_EQ(quantizeLengthUp(1.0), 1.0);
  EXPECT_EQ(quantizeLengthUp(256.0), 256.0);
  const double q = quantizeLengthUp(1.0 + 1e-12);
  EXPECT_GT(q, 1.0);
  EXPECT_LE(q, 1.0 + std::ldexp(1.0, -16));
  // Float noise below the quantum does not change the result.
  EXPECT_EQ(quantizeLengthUp(37.1234567), quantizeLengthUp(std::nextafter(37.1234567, 40.0)));
}

}  // namespace
}  // namespace csm
