// csm_measure's far-field flicker measure (flicker.hpp) against answers worked out by hand: the
// camera rays land where the rasteriser's projection puts them, a pixel's coverage truth is the
// lit share of its sub-samples across a known shadow edge, and frame pairs are counted as stable,
// flickering or excess exactly. No GPU: the rendered pixels are written by hand, the truth is
// Embree's.
#include <csm_measure/flicker.hpp>
#include <csm_measure/raytracer.hpp>
#include <csm_measure/scene.hpp>
#include <engine/camera.hpp>
#include <glue/camera.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace {

using csm_measure::FlickerOptions;
using csm_measure::FlickerStats;
using csm_measure::PixelSample;

engine::Camera downCamera(const glm::dvec3& eyeWs) {
  engine::Camera e;
  e.positionWs = eyeWs;
  e.setYawPitchRoll(0.0, -0.5 * glm::pi<double>());
  e.fovYRad = glm::radians(90.0);
  e.aspect = 1.0;
  e.nearM = 0.1;
  e.farM = 100.0;
  return e;
}

TEST(FlickerMeasure, CameraRaysLandWhereTheProjectionPutsThem) {
  engine::Camera e;
  e.positionWs = glm::dvec3(1e7, 20.0, -3.0);
  e.setYawPitchRoll(0.7, -0.3);
  e.fovYRad = glm::radians(50.0);
  e.aspect = 16.0 / 9.0;
  const csm::Camera cam = glue::toCsmCamera(e);
  const VkExtent2D extent{320, 180};
  const glm::dmat4 vp(e.viewProjectionCr());
  for (const glm::dvec2 p : {glm::dvec2(0.5, 0.5), glm::dvec2(160.0, 90.0), glm::dvec2(319.9, 0.1),
                             glm::dvec2(12.25, 170.75)}) {
    const glm::dvec3 dir = csm_measure::cameraRayWs(cam, extent, p.x, p.y);
    EXPECT_NEAR(glm::length(dir), 1.0, 1e-12);
    const glm::dvec4 clip = vp * glm::dvec4(dir * 25.0, 1.0);
    const glm::dvec2 ndc = glm::dvec2(clip) / clip.w;
    // Vulkan: clip y points down, pixel (0, 0) is the top left corner.
    EXPECT_NEAR((ndc.x + 1.0) * 0.5 * extent.width, p.x, 1e-3);
    EXPECT_NEAR((ndc.y + 1.0) * 0.5 * extent.height, p.y, 1e-3);
  }
}

// Ground at y = 0; a slab 4 m x 4 m, 0.2 m thick, 6 m up over the origin; the sun straight down,
// so the shadow is the square |x|, |z| < 2 on the ground. A camera 3 m up looks straight down
// (90 degrees, 64 x 64): pixel column i spans x in [(i/32 - 1) 3, ((i+1)/32 - 1) 3], so the edge
// x = 2 falls in column 53 (x from 1.97 to 2.06), between its first and second sub-sample column
// of four: 3 of 4 sub-columns lit.
TEST(FlickerMeasure, CoverageTruthIsTheLitShareOfThePixelsSubSamples) {
  csm_measure::Scene scene;
  const uint32_t ground = scene.addMesh(csm_measure::makeGroundMesh(false, 100.0, 1, 0.0, 0.0));
  const uint32_t cube = scene.addMesh(csm_measure::makeCubeMesh());
  scene.addInstance({ground, glm::dvec3(0.0)});
  csm_measure::Instance slab;
  slab.mesh = cube;
  slab.translationWs = glm::dvec3(0.0, 6.0, 0.0);
  slab.linearWs = glm::mat3(glm::vec3(4, 0, 0), glm::vec3(0, 0.2f, 0), glm::vec3(0, 0, 4));
  slab.closed = true;
  scene.addInstance(slab);
  const csm_measure::RayTracer tracer(scene);
  const engine::Camera e = downCamera(glm::dvec3(0.0, 3.0, 0.0));
  const csm::Camera cam = glue::toCsmCamera(e);
  const VkExtent2D extent{64, 64};
  const csm::DirectionalLight sun{glm::dvec3(0.0, -1.0, 0.0)};
  std::vector<PixelSample> pixels;
  for (uint32_t y = 0; y < extent.height; ++y) {
    for (uint32_t x = 0; x < extent.width; ++x) {
      PixelSample p;
      p.x = x;
      p.y = y;
      const glm::dvec3 dir = csm_measure::cameraRayWs(cam, extent, x + 0.5, y + 0.5);
      p.posWs = cam.positionWs + dir * (3.0 / -dir.y);
      p.normalWs = glm::vec3(0, 1, 0);
      p.shadow = 1.0f;
      p.cascade = x < 8 ? 1 : 2;  // the left columns in a near cascade: not compared
      pixels.push_back(p);
    }
  }
  const csm::CascadeFrame frame;  // no fade
  const std::vector<float> truth =
      csm_measure::pixelCoverageTruth(tracer, cam, extent, sun, pixels, frame);
  ASSERT_EQ(truth.size(), size_t(64 * 64));
  auto at = [&](uint32_t x, uint32_t y) { return truth[size_t(y) * 64 + x]; };
  const uint32_t row = 32;  // z near 0: inside the shadow's z range
  EXPECT_EQ(at(4, row), -1.0f) << "cascade 1: not compared";
  EXPECT_EQ(at(8, row), 1.0f) << "x from -2.25 to -2.16: lit";
  EXPECT_EQ(at(9, row), 1.0f) << "x from -2.16 to -2.06: lit";
  EXPECT_EQ(at(10, row), 0.75f) << "x from -2.06 to -1.97: 3 of 4 sub-columns lit";
  EXPECT_EQ(at(20, row), 0.0f) << "under the slab";
  EXPECT_EQ(at(52, row), 0.0f) << "x from 1.88 to 1.97: under the slab";
  EXPECT_EQ(at(53, row), 0.75f) << "x from 1.97 to 2.06: 3 of 4 sub-columns lit";
  EXPECT_EQ(at(54, row), 1.0f);
  // The shadow's z edge crosses rows the same way: every pixel's truth is a multiple of 1/16.
  for (float t : truth) {
    if (t >= 0.0f) {
      EXPECT_EQ(t * 16.0f, std::floor(t * 16.0f)) << t;
    }
  }

  // A pixel whose rendered surface is 2 m away while its sub-samples hit the ground 3 m away
  // spans a silhouette as far as the measure can tell: not compared.
  std::vector<PixelSample> moved = pixels;
  PixelSample& p = moved[size_t(row) * 64 + 30];
  p.posWs = cam.positionWs + glm::normalize(p.posWs - cam.positionWs) * 2.0;
  // Nor is a pixel whose position is not finite.
  moved[size_t(row) * 64 + 32].posWs.x = std::numeric_limits<double>::infinity();
  moved[size_t(row) * 64 + 33].posWs.y = std::numeric_limits<double>::quiet_NaN();
  const std::vector<float> truth2 =
      csm_measure::pixelCoverageTruth(tracer, cam, extent, sun, moved, frame);
  EXPECT_EQ(truth2[size_t(row) * 64 + 30], -1.0f);
  EXPECT_EQ(truth2[size_t(row) * 64 + 31], 0.0f);
  EXPECT_EQ(truth2[size_t(row) * 64 + 32], -1.0f);
  EXPECT_EQ(truth2[size_t(row) * 64 + 33], -1.0f);
}

TEST(FlickerMeasure, PairsAreCountedStableFlickeringOrExcessExactly) {
  const VkExtent2D extent{5, 1};
  auto px = [](uint32_t x, float shadow, int cascade) {
    PixelSample p;
    p.x = x;
    p.shadow = shadow;
    p.cascade = cascade;
    return p;
  };
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<PixelSample> a = {px(0, 0.5f, 2), px(1, 0.0f, 2), px(2, 1.0f, 1),
                                      px(3, 0.3f, 3), px(4, 0.2f, 2)};
  const std::vector<PixelSample> b = {px(0, 0.65f, 2), px(1, 0.05f, 2), px(2, 0.0f, 1),
                                      px(3, 1.0f, 3), px(4, nan, 2)};
  const std::vector<float> truthA = {0.5f, 0.0f, 1.0f, 0.3f, 0.2f};
  const std::vector<float> truthB = {0.52f, 0.0f, 0.0f, 0.5f, 0.2f};
  FlickerStats st;
  csm_measure::accumulateFlicker(st, extent, a, truthA, b, truthB);
  EXPECT_EQ(st.pairs, 3u) << "pixel 2 is in cascade 1, pixel 4 not finite";
  EXPECT_EQ(st.nonFinite, 1u);
  EXPECT_EQ(st.stablePairs, 2u) << "pixel 3's truth changed by 0.2";
  EXPECT_EQ(st.flickering, 1u) << "pixel 0 changed by 0.15 while its truth changed by 0.02";
  EXPECT_EQ(st.excess, 2u) << "pixels 0 (0.15 - 0.02) and 3 (0.7 - 0.2)";
  EXPECT_DOUBLE_EQ(st.rate(), 0.5);
  EXPECT_NEAR(st.maxRenderChange, 0.15, 1e-6);
  EXPECT_NEAR(st.meanRenderChange(), 0.1, 1e-6);
  // A pixel that is not compared in either frame (truth -1) is no pair.
  std::vector<float> unknown = truthB;
  unknown[0] = -1.0f;
  FlickerStats st2;
  csm_measure::accumulateFlicker(st2, extent, a, truthA, b, unknown);
  EXPECT_EQ(st2.pairs, 2u);
  EXPECT_EQ(st2.flickering, 0u);
  // A higher minimum cascade leaves only pixel 3.
  FlickerOptions far;
  far.minCascade = 3;
  FlickerStats st3;
  csm_measure::accumulateFlicker(st3, extent, a, truthA, b, truthB, far);
  EXPECT_EQ(st3.pairs, 1u);
}

}  // namespace
