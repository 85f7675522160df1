// csm_measure::classifyMisses (issue 10's fit study explains its misclassified pixels with it):
// a scene whose every occluder's distance and chord along the light is known, pixels placed on
// it with chosen shadow factors, and the class each misclassified pixel must land in. No GPU:
// the pixels are written by hand, the truth is Embree's.
#include <csm_measure/metrics.hpp>
#include <csm_measure/raytracer.hpp>
#include <csm_measure/scene.hpp>

#include <gtest/gtest.h>

#include <vector>

namespace {

using csm_measure::MissCauses;
using csm_measure::PixelSample;

// Flat ground at y = 0 and, under a sun straight overhead: a fence rail 10 cm tall (0.5-0.6 m)
// over x = 0, a 1 m box floating 1 m up over x = 10, a box 10 m up over x = 20, and a 2 m box
// standing on the ground at x = 39..41 (its -x wall is vertical: it faces away from the sun).
csm_measure::Scene missScene(const glm::dvec3& originWs) {
  csm_measure::Scene scene(originWs);
  const uint32_t ground = scene.addMesh(csm_measure::makeGroundMesh(false, 200.0, 1, 0.0, 0.0));
  const uint32_t cube = scene.addMesh(csm_measure::makeCubeMesh());  // [-0.5, 0.5]^3
  scene.addInstance({ground, originWs});
  auto box = [&](glm::dvec3 centre, glm::vec3 size) {
    csm_measure::Instance in;
    in.mesh = cube;
    in.translationWs = originWs + centre;
    in.linearWs =
        glm::mat3(glm::vec3(size.x, 0, 0), glm::vec3(0, size.y, 0), glm::vec3(0, 0, size.z));
    in.kind = csm_measure::InstanceKind::kBuilding;
    in.closed = true;
    scene.addInstance(in);
  };
  box({0.0, 0.55, 0.0}, {4.0f, 0.1f, 0.06f});  // the rail: chord 0.1 m, 0.5 m up
  box({10.0, 1.5, 0.0}, {1.0f, 1.0f, 1.0f});   // contact: chord 1 m, 1 m up
  box({20.0, 10.5, 0.0}, {1.0f, 1.0f, 1.0f});  // far: 10 m up
  box({40.0, 1.0, 0.0}, {2.0f, 2.0f, 2.0f});   // the wall at x = 39
  return scene;
}

PixelSample pixel(uint32_t x, const glm::dvec3& posWs, glm::vec3 normal, float shadow,
                  int cascade = 0) {
  PixelSample p;
  p.x = x;
  p.y = 7;
  p.posWs = posWs;
  p.normalWs = glm::normalize(normal);
  p.shadow = shadow;
  p.cascade = cascade;
  return p;
}

class MissCausesTest : public ::testing::TestWithParam<double> {};

TEST_P(MissCausesTest, EachMisclassifiedPixelLandsInItsCause) {
  const glm::dvec3 o(GetParam(), 0.0, -GetParam());  // 0 and 10^7 m from the origin
  const csm_measure::Scene scene = missScene(o);
  const csm_measure::RayTracer tracer(scene);
  const csm::DirectionalLight sun{glm::dvec3(0.0, -1.0, 0.0)};
  // A camera low and to the side: its rays reach every ground pixel under the occluders and
  // the wall's -x face first.
  const glm::dvec3 cameraWs = o + glm::dvec3(15.0, 3.0, -40.0);
  csm::CascadeFrame frame;
  frame.cascadeCount = 1;
  const glm::vec3 up(0, 1, 0);
  std::vector<PixelSample> px = {
      pixel(0, o + glm::dvec3(0.0, 0.0, 0.0), up, 1.0f),   // under the rail, map lit
      pixel(1, o + glm::dvec3(10.0, 0.0, 0.0), up, 1.0f),  // under the floating box, map lit
      pixel(2, o + glm::dvec3(20.0, 0.0, 0.0), up, 0.9f),  // under the high box, map lit
      pixel(3, o + glm::dvec3(30.0, 0.0, 0.0), up, 0.1f),  // in the open, map shadowed
      pixel(4, o + glm::dvec3(39.0, 1.0, 0.0), {-0.6f, 0.8f, 0.0f}, 0.0f),  // the wall
      // Not misclassified, or not judged: none of these may be counted.
      pixel(5, o + glm::dvec3(30.0, 0.0, 5.0), up, 1.0f),      // in the open, map lit
      pixel(6, o + glm::dvec3(10.0, 0.0, 0.2), up, 0.0f),      // under the box, map shadowed
      pixel(7, o + glm::dvec3(30.0, 0.0, 9.0), up, 0.0f, -1),  // beyond every cascade
      pixel(8, o + glm::dvec3(30.0, 0.0, 7.0), {1.0f, -0.2f, 0.0f}, 0.0f),  // normal away
  };
  const MissCauses m = csm_measure::classifyMisses(px, frame, tracer, sun, cameraWs);
  EXPECT_EQ(m.missedThin, 1u);
  EXPECT_EQ(m.missedContact, 1u);
  EXPECT_EQ(m.missedFar, 1u);
  EXPECT_EQ(m.falseShadow, 1u);
  EXPECT_EQ(m.facingAway, 1u);
  ASSERT_EQ(m.total(), 5u);
  // The same pixels measureAccuracy counts, in (x, y) order.
  const csm_measure::AccuracyStats acc = csm_measure::measureAccuracy(px, frame, tracer, sun);
  EXPECT_EQ(acc.overall.misclassified, m.total());
  ASSERT_EQ(m.pixels.size(), 5u);
  for (uint32_t i = 0; i < 5; ++i) EXPECT_EQ(m.pixels[i], std::make_pair(i, 7u));
  // Shared pixels between two runs: the map made right at pixels 0 and 3.
  std::vector<PixelSample> better = px;
  better[0].shadow = 0.0f;
  better[3].shadow = 1.0f;
  const MissCauses b = csm_measure::classifyMisses(better, frame, tracer, sun, cameraWs);
  EXPECT_EQ(b.total(), 3u);
  EXPECT_EQ(b.missedThin, 0u);
  EXPECT_EQ(b.falseShadow, 0u);
  EXPECT_EQ(b.sharedWith(m), 3u);
  EXPECT_EQ(m.sharedWith(b), 3u);
  EXPECT_EQ(m.sharedWith(m), 5u);
  const nlohmann::json j = m.toJson();
  EXPECT_EQ(j["total"], 5u);
  EXPECT_EQ(j["missed_thin_occluder"], 1u);
}

INSTANTIATE_TEST_SUITE_P(Origins, MissCausesTest, ::testing::Values(0.0, 1e7));

}  // namespace
