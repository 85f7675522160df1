// The data PCSS reads from the uniform block: the light's size and the penumbra bound
// (tanHalfLightAngle, maxPenumbraRadiusM), and each cascade's world-grid texel origin
// (worldTexelOrigin), which makes a receiver's world texel index the same in every frame of a
// stabilised view.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "csm/gpu_layout.hpp"
#include "test_util.hpp"

namespace csm {
namespace {

TEST(SoftParams, PackedFromTheSettings) {
  ShadowSettings s;
  Camera c;
  DirectionalLight l;
  const auto frame = computeCascades(s, c, l);
  ASSERT_TRUE(frame.ok());
  CsmUniforms u = packUniforms(frame.value(), s);
  EXPECT_FLOAT_EQ(u.tanHalfLightAngle, float(std::tan(glm::radians(0.5 * 0.53))));
  EXPECT_FLOAT_EQ(u.maxPenumbraRadiusM, 0.25f);
  s.lightAngularDiameterDeg = 2.0;
  s.maxPenumbraM = 3.0;
  u = packUniforms(frame.value(), s);
  EXPECT_FLOAT_EQ(u.tanHalfLightAngle, float(std::tan(glm::radians(1.0))));
  EXPECT_FLOAT_EQ(u.maxPenumbraRadiusM, 1.5f);
  EXPECT_EQ(std::string(kernelName(PcfKernel::kPcss)), "pcss");
}

// A fixed world point keeps its world texel (map texel index + origin, modulo the period) while
// the camera moves, in every cascade, at 0 and 1e7 m from the origin.
TEST(SoftParams, WorldTexelOfAFixedPointDoesNotChangeAsTheCameraMoves) {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double distance : {0.0, 1e7}) {
    const glm::dvec3 origin = distance * glm::dvec3(0.6, 0.0, -0.8);
    ShadowSettings s;
    s.resolution = 1024;
    s.shadowDistanceM = 200.0;
    DirectionalLight l;
    l.directionWs = glm::dvec3(0.75, -0.6, 0.3);
    Camera c;
    c.positionWs = origin + glm::dvec3(0.0, 10.0, 0.0);
    c.orientationWs = test::lookAlong(glm::dvec3(0.2, -0.3, -1.0));
    const glm::dvec3 pointWs = origin + glm::dvec3(1.3, 0.0, -4.7);
    glm::ivec2 first[kMaxCascades];
    for (int f = 0; f < 40; ++f) {
      Camera moved = c;
      moved.positionWs += glm::dvec3(u(rng), 0.1 * u(rng), u(rng)) * 0.8;
      const auto frame = computeCascades(s, moved, l);
      ASSERT_TRUE(frame.ok());
      const CsmUniforms g = packUniforms(frame.value(), s);
      for (uint32_t i = 0; i < frame.value().cascadeCount; ++i) {
        const glm::dvec3 t = shadowTexelCoord(frame.value().cascades[i], frame.value(), pointWs);
        if (t.x < 0.0 || t.y < 0.0 || t.x >= s.resolution || t.y >= s.resolution) continue;
        const double period = CSM_WORLD_TEXEL_PERIOD;
        glm::ivec2 w;
        for (int a = 0; a < 2; ++a) {
          const double v = std::floor(t[a]) + double(g.cascades[i].worldTexelOrigin[a]);
          w[a] = int(v - period * std::floor(v / period));
        }
        if (f == 0) {
          first[i] = w;
        } else {
          EXPECT_EQ(w, first[i]) << "cascade " << i << " frame " << f << " at " << distance;
        }
      }
    }
  }
}

}  // namespace
}  // namespace csm
