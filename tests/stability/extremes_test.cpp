// Numerical stability at the extremes: each case renders (shadow pass + csm.glsl in a fragment
// shader), compares every receiver pixel with the Embree truth, then follows the visible surface
// points over a few frames of sub-texel translation and yaw. Each must show zero validation
// messages, no NaN or infinity anywhere (cascade data, shader outputs), a misclassification rate
// under the case's bound, and no visible shimmer at points that stayed in their cascade.
#include <cstdio>
#include <functional>

#include "stability_common.hpp"

namespace csm_stability {
namespace {

struct Case {
  const char* name;
  VkExtent2D view{240, 135};
  /// Misclassification bound (fraction of receiver pixels in the shadow range).
  double maxMisclassification = 0.02;
  /// Frames of the shimmer motion.
  int shimmerFrames = 10;
  /// Shimmer bounds at points that stayed in their cascade: largest change, and the fraction of
  /// point-frames allowed to change by more than 1/255.
  double maxStayedShimmer = csm_measure::kVisibleStep;
  double maxVisibleFraction = 0.0;
  /// Turn the camera toward the shadow edge of the first small crate (narrow views).
  bool aimAtCrateShadow = false;
  std::function<void(csm::Camera&, csm::ShadowSettings&, csm::DirectionalLight&,
                     csm_measure::TestSceneDesc&)>
      apply;
};

glm::dvec3 grazingLight(double elevationDeg) {
  const double e = glm::radians(elevationDeg);
  const glm::dvec3 horizontal = glm::normalize(glm::dvec3(0.9, 0.0, 0.44));
  return std::cos(e) * horizontal + glm::dvec3(0.0, -std::sin(e), 0.0);
}

void lookAt(csm::Camera& c, const glm::dvec3& targetWs) {
  engine::Camera e;
  e.positionWs = c.positionWs;
  e.lookAt(targetWs);
  c.orientationWs = e.orientation;
}

// Bounds: about twice what lavapipe measured (printed by the test), at least 1%.
const Case kCases[] = {
    {"near_1e-3_far_1e5",
     {240, 135},
     0.02,
     10,
     csm_measure::kVisibleStep,
     0.0,
     false,
     [](csm::Camera& c, csm::ShadowSettings&, csm::DirectionalLight&, csm_measure::TestSceneDesc&) {
       c.nearM = 1e-3;
       c.farM = 1e5;
     }},
    // A 1-degree view of one shadow edge magnifies a texel to 4-8 pixels: the 9.2% measured on
    // lavapipe are a band about 2 texels wide along the edge. Bound: 15% (3 texels).
    {"fov_1deg",
     {240, 135},
     0.15,
     10,
     csm_measure::kVisibleStep,
     0.0,
     true,
     [](csm::Camera& c, csm::ShadowSettings&, csm::DirectionalLight&, csm_measure::TestSceneDesc&) {
       c.fovYRad = glm::radians(1.0);
     }},
    {"fov_170deg",
     {240, 135},
     0.05,
     10,
     csm_measure::kVisibleStep,
     0.0,
     false,
     [](csm::Camera& c, csm::ShadowSettings&, csm::DirectionalLight&, csm_measure::TestSceneDesc&) {
       c.fovYRad = glm::radians(170.0);
     }},
    {"aspect_0.05",
     {16, 320},
     0.02,
     10,
     csm_measure::kVisibleStep,
     0.0,
     false,
     [](csm::Camera& c, csm::ShadowSettings&, csm::DirectionalLight&, csm_measure::TestSceneDesc&) {
       c.aspect = 0.05;
     }},
    {"aspect_20",
     {400, 20},
     0.02,
     10,
     csm_measure::kVisibleStep,
     0.0,
     false,
     [](csm::Camera& c, csm::ShadowSettings&, csm::DirectionalLight&, csm_measure::TestSceneDesc&) {
       c.aspect = 20.0;
     }},
    {"camera_1e7_from_origin",
     {240, 135},
     0.02,
     10,
     csm_measure::kVisibleStep,
     0.0,
     false,
     [](csm::Camera& c, csm::ShadowSettings&, csm::DirectionalLight&,
        csm_measure::TestSceneDesc& d) {
       const glm::dvec3 offset = originAt(1e7) - d.originWs;
       d.originWs += offset;
       c.positionWs += offset;
     }},
    {"light_straight_down",
     {240, 135},
     0.02,
     10,
     csm_measure::kVisibleStep,
     0.0,
     false,
     [](csm::Camera&, csm::ShadowSettings&, csm::DirectionalLight& l, csm_measure::TestSceneDesc&) {
       l.directionWs = {0.0, -1.0, 0.0};
     }},
    // At 1 degree the ground's light-space depth changes ~57 m per metre, so a few comparisons sit
    // on a knife edge: measured on lavapipe, 4 of 26091 point-frames of stayed points changed by
    // more than 1/255 (max 0.053) under sub-texel translation alone (rotation alone: 0). Bounded
    // here and reported; every other case allows none.
    {"light_1deg_above_horizon",
     {240, 135},
     0.10,
     10,
     0.1,
     0.001,
     false,
     [](csm::Camera&, csm::ShadowSettings&, csm::DirectionalLight& l, csm_measure::TestSceneDesc&) {
       l.directionWs = grazingLight(1.0);
     }},
    {"light_along_view",
     {240, 135},
     0.02,
     10,
     csm_measure::kVisibleStep,
     0.0,
     false,
     [](csm::Camera& c, csm::ShadowSettings&, csm::DirectionalLight& l,
        csm_measure::TestSceneDesc&) { l.directionWs = c.forwardWs(); }},
    {"cascades_1",
     {240, 135},
     0.03,
     10,
     csm_measure::kVisibleStep,
     0.0,
     false,
     [](csm::Camera&, csm::ShadowSettings& s, csm::DirectionalLight&, csm_measure::TestSceneDesc&) {
       s.cascadeCount = 1;
     }},
    {"cascades_8",
     {240, 135},
     0.02,
     10,
     csm_measure::kVisibleStep,
     0.0,
     false,
     [](csm::Camera&, csm::ShadowSettings& s, csm::DirectionalLight&, csm_measure::TestSceneDesc&) {
       s.cascadeCount = 8;
       s.resolution = 512;
     }},
    {"resolution_256",
     {240, 135},
     0.04,
     10,
     csm_measure::kVisibleStep,
     0.0,
     false,
     [](csm::Camera&, csm::ShadowSettings& s, csm::DirectionalLight&, csm_measure::TestSceneDesc&) {
       s.resolution = 256;
     }},
    // The largest map the module accepts (or the device's maximum), one cascade: 1 GiB of D32.
    {"resolution_max",
     {160, 90},
     0.02,
     3,
     csm_measure::kVisibleStep,
     0.0,
     false,
     [](csm::Camera&, csm::ShadowSettings& s, csm::DirectionalLight&, csm_measure::TestSceneDesc&) {
       s.cascadeCount = 1;
       s.resolution = csm::kMaxResolution;
     }},
};

class StabilityExtremes : public ::testing::TestWithParam<Case> {};

TEST_P(StabilityExtremes, RendersFiniteAccurateAndStable) {
  const Case& tc = GetParam();
  csm_measure::AccuracyStats accuracy;
  csm_measure::ShimmerRun shimmer;
  csm::CascadeFrame frame;
  uint32_t resolution = 0;
  {
    CSM_MAKE_HARNESS(harness);
    csm_measure::TestSceneDesc sd;
    sd.terrain = false;
    csm::Camera camera = baseCamera(sd.originWs);
    csm::ShadowSettings settings = testSettings(true);
    csm::DirectionalLight light = testLight();
    tc.apply(camera, settings, light, sd);
    camera.aspect = tc.view.width == 16 || tc.view.width == 400
                        ? camera.aspect
                        : double(tc.view.width) / double(tc.view.height);
    // The device maximum when it is below the module's.
    const uint32_t deviceMax = harness->context().properties().limits.maxImageDimension2D;
    if (settings.resolution > deviceMax) {
      uint32_t r = csm::kMinResolution;
      while (r * 2 <= deviceMax) r *= 2;
      settings.resolution = r;
    }
    resolution = settings.resolution;
    const csm_measure::Scene scene = csm_measure::Scene::makeTestScene(sd);
    if (tc.aimAtCrateShadow) {
      // The shadow of the crate's top face is the face moved by h * (0.75, 0.3) / 0.6 (flat ground
      // at y = 0, testLight()): aim at the middle of its +x edge.
      for (size_t i = 0; i < scene.instances().size(); ++i) {
        const csm::AabbWs& b = scene.instanceBounds(i);
        if (scene.instances()[i].kind == csm_measure::InstanceKind::kBuilding && b.maxWs.y < 3.0) {
          const glm::dvec3 d = glm::normalize(light.directionWs);
          const double h = b.maxWs.y;
          lookAt(camera, glm::dvec3(b.maxWs.x + h * d.x / -d.y, 0.0,
                                    0.5 * (b.minWs.z + b.maxWs.z) + h * d.z / -d.y));
          break;
        }
      }
    }
    harness->setScene(scene);
    const csm_measure::RayTracer tracer(scene);
    CSM_ASSERT_STATUS(harness->configure(settings));

    csm::CascadeHistory history;
    frame = harness->computeFrame(camera, light, history);
    EXPECT_TRUE(csm_measure::frameIsFinite(frame));
    const csm::CsmUniforms uniforms = csm::packUniforms(frame, settings);
    const auto* u = reinterpret_cast<const float*>(&uniforms);
    for (size_t i = 0; i < offsetof(csm::CsmUniforms, cascadeCount) / sizeof(float); ++i) {
      ASSERT_TRUE(std::isfinite(u[i])) << "uniform float " << i;
    }
    engine::CpuImage image;
    const std::vector<csm_measure::PixelSample> pixels =
        harness->renderAccuracy(camera, frame, tc.view, csm::PcfKernel::kTent3, true, &image);
    engine::writePng(artefactDir() + "/extreme_" + tc.name + ".png", image);
    accuracy = csm_measure::measureAccuracy(pixels, frame, tracer, light);

    // Shimmer at the surface points this view sees (every k-th receiver pixel).
    std::vector<csm_measure::Receiver> receivers;
    const size_t step = std::max<size_t>(1, pixels.size() / 3000);
    for (size_t i = 0; i < pixels.size(); i += step) {
      if (pixels[i].cascade < 0) continue;
      receivers.push_back(
          {pixels[i].posWs, pixels[i].normalWs, csm_measure::InstanceKind::kGround});
    }
    const double texel0 = frame.cascades[0].texelSizeM();
    const glm::dvec3 dir = glm::normalize(glm::dvec3(1.0, 0.15, -0.7));
    shimmer = csm_measure::measureShimmer(
        *harness, receivers, light,
        [&](int f) {
          csm::Camera c = camera;
          c.positionWs += dir * (0.3 * texel0 * f);
          c.orientationWs =
              glm::angleAxis(glm::radians(0.01 * f), glm::dvec3(0, 1, 0)) * c.orientationWs;
          return c;
        },
        tc.shimmerFrames, csm::PcfKernel::kTent3);
  }
  const uint64_t messages = engine::validationMessageCount();
  std::printf(
      "%-26s res %5u x %u  receiver px %6llu (truth shadowed %5llu) misclassified %.3f%% "
      "(bound %.1f%%) mean |s-v| %.4f | shimmer: stayed pairs %6llu max %.5f visible %.4f%% "
      "crossed %llu | non-finite %llu/%llu\n",
      tc.name, resolution, frame.cascadeCount, (unsigned long long)accuracy.overall.pixels,
      (unsigned long long)accuracy.overall.shadowedTruth, 100.0 * accuracy.overall.rate(),
      100.0 * tc.maxMisclassification, accuracy.overall.meanAbsError(),
      (unsigned long long)shimmer.total.stayed.pairs, shimmer.total.stayed.max,
      100.0 * shimmer.total.stayed.visibleFraction(),
      (unsigned long long)shimmer.total.crossed.pairs, (unsigned long long)accuracy.nonFinite,
      (unsigned long long)shimmer.nonFinite);
  nlohmann::json j;
  j["case"] = tc.name;
  j["resolution"] = resolution;
  j["cascades"] = frame.cascadeCount;
  j["view"] = {tc.view.width, tc.view.height};
  j["misclassification_bound"] = tc.maxMisclassification;
  j["stayed_shimmer_bound"] = tc.maxStayedShimmer;
  j["stayed_visible_fraction_bound"] = tc.maxVisibleFraction;
  j["accuracy"] = accuracy.toJson(frame.cascadeCount);
  j["shimmer"] = shimmer.toJson(false);
  j["validation_messages"] = messages;
  csm_measure::writeJson(artefactDir() + "/extreme_" + tc.name + ".json", j);

  EXPECT_EQ(messages, 0u);
  EXPECT_EQ(accuracy.nonFinite, 0u);
  EXPECT_EQ(shimmer.nonFinite, 0u);
  EXPECT_GT(accuracy.overall.pixels, 500u) << "too few receiver pixels in the shadow range";
  EXPECT_LE(accuracy.overall.rate(), tc.maxMisclassification);
  EXPECT_GT(shimmer.total.stayed.pairs, 500u) << "too few points followed";
  EXPECT_LE(shimmer.total.stayed.max, tc.maxStayedShimmer);
  EXPECT_LE(shimmer.total.stayed.visibleFraction(), tc.maxVisibleFraction);
}

// Test names and failure messages show the case's name, not its bytes.
void PrintTo(const Case& c, std::ostream* os) {
  *os << c.name;
}

INSTANTIATE_TEST_SUITE_P(Cases, StabilityExtremes, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           std::string n = info.param.name;
                           for (char& ch : n)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return n;
                         });

}  // namespace
}  // namespace csm_stability
