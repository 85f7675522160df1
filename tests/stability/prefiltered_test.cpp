// The prefiltered filters (vsm, evsm, msm) against the ray-traced truth, beside the 3x3 and 5x5
// tents: per filter the misclassification against the point truth (one shadow ray per pixel),
// the mean |s - v_soft| against the sun-disk truth (256 rays), the leak (truly shadowed pixels,
// v_soft = 0, that read more than 0.1 lit) and the lit pass's GPU time. Scene: a plane, a tall
// box, and stacked occluders (a slab floating 3 m above a low box above the ground: the bleeding
// case of variance methods, where the slab's and the box's depths mix in one filter footprint).
// Writes prefiltered.json and prefiltered_strip.png (truth | tent3x3 | vsm | evsm | msm).
#include <algorithm>
#include <cstdio>
#include <map>

#include <csm/names.hpp>
#include <csm_measure/soft_truth.hpp>

#include "stability_common.hpp"

namespace csm_stability {
namespace {

constexpr VkExtent2D kView{320, 180};
constexpr double kSunDeg = 0.53;

csm_measure::Scene stackedScene(const csm::DirectionalLight& light) {
  csm_measure::Scene scene;
  const uint32_t ground = scene.addMesh(csm_measure::makeGroundMesh(false, 80.0, 1, 0.0, -10.0));
  const uint32_t cube = scene.addMesh(csm_measure::makeCubeMesh());
  scene.addInstance({ground,
                     glm::dvec3(0.0),
                     glm::mat3(1.0f),
                     {0.7f, 0.7f, 0.7f, 1.0f},
                     csm_measure::InstanceKind::kGround});
  const glm::dvec3 l = glm::normalize(light.directionWs);
  const glm::dvec3 along = glm::normalize(glm::dvec3(l.x, 0.0, l.z));
  const glm::dvec3 across(-along.z, 0.0, along.x);
  const double turn = glm::radians(25.0);
  const glm::dvec3 a = std::cos(turn) * along + std::sin(turn) * across;
  const glm::dvec3 b(-a.z, 0.0, a.x);
  auto box = [&](const glm::dvec3& centre, double sa, double h, double sb, glm::vec4 colour,
                 csm_measure::InstanceKind kind) {
    glm::mat3 m(1.0f);
    m[0] = glm::vec3(a * sa);
    m[1] = glm::vec3(0.0f, float(h), 0.0f);
    m[2] = glm::vec3(b * sb);
    scene.addInstance({cube, centre, m, colour, kind});
  };
  const auto kBuilding = csm_measure::InstanceKind::kBuilding;
  // A tall box (hard edges from contact to 12 m).
  box(glm::dvec3(-6.0, 6.0, -13.0), 3.0, 12.0, 4.0, {0.8f, 0.6f, 0.5f, 1.0f}, kBuilding);
  // Stacked: a low box 1.5 m tall, a slab 0.3 m thick 3 m above it, both 5 m x 5 m.
  box(glm::dvec3(5.0, 0.75, -16.0), 5.0, 1.5, 5.0, {0.6f, 0.6f, 0.7f, 1.0f}, kBuilding);
  box(glm::dvec3(5.0, 4.65, -16.0), 5.0, 0.3, 5.0, {0.5f, 0.7f, 0.5f, 1.0f}, kBuilding);
  return scene;
}

csm::Camera viewCamera() {
  engine::Camera e;
  e.positionWs = glm::dvec3(1.5, 9.0, 4.0);
  e.lookAt(glm::dvec3(1.5, 0.0, -12.0));
  e.fovYRad = glm::radians(60.0);
  e.aspect = double(kView.width) / kView.height;
  e.nearM = 0.1;
  e.farM = 500.0;
  return glue::toCsmCamera(e);
}

struct FilterResult {
  double misclassification = 0.0;
  double meanAbsErr = 0.0;  // against the sun-disk truth
  double leak = 0.0;        // of the pixels fully in shadow (v_soft = 0), read > 0.1
  uint64_t umbraPixels = 0;
  double litMs = 0.0;
  uint64_t nonFinite = 0;
};

TEST(Prefiltered, EachFilterAgainstRayTracedTruthWithStackedOccluders) {
  const csm::DirectionalLight light = testLight();
  CSM_MAKE_HARNESS(harness);
  const csm_measure::Scene scene = stackedScene(light);
  harness->setScene(scene);
  const csm_measure::RayTracer tracer(scene);
  const csm::Camera camera = viewCamera();
  const std::vector<csm::PcfKernel> filters = {csm::PcfKernel::kTent3, csm::PcfKernel::kTent5,
                                               csm::PcfKernel::kVsm, csm::PcfKernel::kEvsm,
                                               csm::PcfKernel::kMsm};
  std::map<csm::PcfKernel, FilterResult> results;
  std::vector<float> truth;
  std::vector<const engine::CpuImage*> stripImages;
  std::map<csm::PcfKernel, engine::CpuImage> images;
  for (const csm::PcfKernel kernel : filters) {
    csm::ShadowSettings settings = testSettings(true);
    settings.shadowDistanceM = 40.0;
    settings.kernel = kernel;
    CSM_ASSERT_STATUS(harness->configure(settings));
    csm::CascadeHistory history;
    const csm::CascadeFrame frame = harness->computeFrame(camera, light, history);
    engine::CpuImage image;
    const std::vector<csm_measure::PixelSample> pixels =
        harness->renderAccuracy(camera, frame, kView, kernel, true, &image);
    if (truth.empty())
      truth = csm_measure::softTruthOfPixels(pixels, frame, tracer, light, kSunDeg);
    ASSERT_EQ(truth.size(), pixels.size());
    FilterResult r;
    const csm_measure::AccuracyStats point =
        csm_measure::measureAccuracy(pixels, frame, tracer, light);
    r.misclassification = point.overall.rate();
    r.nonFinite = point.nonFinite;
    const csm_measure::SoftErrorStats soft = csm_measure::measureSoftError(pixels, truth);
    r.meanAbsErr = soft.meanAbsError();
    uint64_t leaks = 0;
    for (size_t i = 0; i < pixels.size(); ++i) {
      if (truth[i] != 0.0f) continue;  // -1: not compared; > 0: some of the sun is seen
      ++r.umbraPixels;
      if (pixels[i].shadow > 0.1f) ++leaks;
    }
    r.leak = r.umbraPixels ? double(leaks) / double(r.umbraPixels) : 0.0;
    csm::CascadeHistory timedHistory;
    double best = 1e30;
    for (int k = 0; k < 3; ++k) {
      best =
          std::min(best, harness->timeFrame(camera, light, timedHistory, kView, kernel).litGpuMs);
    }
    r.litMs = best;
    std::printf(
        "%-8s misclassified %.5f  mean |s - v_soft| %.5f  leak %.5f of %llu umbra "
        "pixels  lit %.2f ms\n",
        csm::kernelName(kernel), r.misclassification, r.meanAbsErr, r.leak,
        (unsigned long long)r.umbraPixels, r.litMs);
    std::fflush(stdout);
    results[kernel] = r;
    images[kernel] = std::move(image);
  }
  EXPECT_EQ(engine::validationMessageCount(), 0u);
  nlohmann::json runs = nlohmann::json::array();
  for (const auto& [kernel, r] : results) {
    runs.push_back({{"scene", "plane, box 3 x 4 x 12 m, slab 3 m above a 1.5 m box"},
                    {"filter", csm::kernelName(kernel)},
                    {"misclassification", r.misclassification},
                    {"mean_abs_err", r.meanAbsErr},
                    {"leak", r.leak},
                    {"umbra_pixels", r.umbraPixels},
                    {"lit_ms", r.litMs}});
  }
  writeReport("prefiltered.json",
              "prefiltered filters against the point and sun-disk truths, stacked occluders", runs);
  engine::writePng(artefactDir() + "/prefiltered_tent3.png", images[csm::PcfKernel::kTent3]);
  engine::writePng(artefactDir() + "/prefiltered_vsm.png", images[csm::PcfKernel::kVsm]);
  engine::writePng(artefactDir() + "/prefiltered_evsm.png", images[csm::PcfKernel::kEvsm]);
  engine::writePng(artefactDir() + "/prefiltered_msm.png", images[csm::PcfKernel::kMsm]);

  // Measured (lavapipe, this scene): tent3x3 misclassifies 0.252%, tent5x5 0.257%; vsm 0.269%,
  // evsm 0.252%, msm 0.269%. Against the sun-disk truth the prefiltered filters err 0.0028 on
  // average, tent3x3 0.0038; of the 5232 umbra pixels tent3x3 reads 2.3% more than 0.1 lit (at
  // the umbra's edge), the prefiltered filters 1.0-1.1% (the slab's bleeding included).
  const FilterResult& tent3 = results[csm::PcfKernel::kTent3];
  const FilterResult& tent5 = results[csm::PcfKernel::kTent5];
  for (const auto& [kernel, r] : results) {
    const char* name = csm::kernelName(kernel);
    EXPECT_EQ(r.nonFinite, 0u) << name;
    EXPECT_GT(r.umbraPixels, 2000u) << name << ": the view must hold umbrae to count leaks in";
    if (!csm::isPrefiltered(kernel)) continue;
    EXPECT_LE(r.misclassification, 1.15 * tent5.misclassification) << name;
    EXPECT_LT(r.meanAbsErr, tent3.meanAbsErr) << name << ": against the sun-disk truth";
    EXPECT_LE(r.leak, tent3.leak) << name << ": bleeding under the slab";
  }
}

// Shimmer at fixed receivers under translation (sub-texel and multi-texel) and rotation, at 0
// and 10^7 m from the origin: the bound of the percentage-closer kernels (shimmer_test) holds for
// the prefiltered filters too. The moments live on the same world-anchored texels as the depth
// (the blur works in box coordinates), so a receiver that stays in its cascade reads the same
// filtered moments frame after frame. (The probe evaluates csm.glsl in a compute shader: level 0,
// no derivatives; the mip choice of a fragment shader is not in this measure.)
TEST(Prefiltered, StabilisedFiltersDoNotShimmer) {
  CSM_MAKE_HARNESS(harness);
  // Through the cache, as a host runs by default: each frame resolves only the moment tiles the
  // camera's motion made stale (cache_world_tests prove that equal to a full resolve).
  csm::vk::RendererOptions cached;
  cached.cache = true;
  nlohmann::json runs = nlohmann::json::array();
  for (const csm::PcfKernel kernel : csm::kPrefilteredKernels) {
    csm::ShadowSettings settings = testSettings(true);
    settings.kernel = kernel;
    for (nlohmann::json& run : expectStabilisedShimmerBound(*harness, settings, cached))
      runs.push_back(std::move(run));
  }
  EXPECT_EQ(engine::validationMessageCount(), 0u);
  writeReport("prefiltered_shimmer.json",
              "frame-to-frame shimmer of the prefiltered filters at 4000 fixed receivers", runs);
}

}  // namespace
}  // namespace csm_stability
