// Accuracy against a ray-traced truth: every receiver pixel of a rendered frame (position and
// shadow factor read back from stability_accuracy.frag, i.e. csm.glsl in a fragment shader)
// against an Embree shadow ray toward the light over the same full-detail triangles.
#include <cstdio>

#include "stability_common.hpp"

namespace csm_stability {
namespace {

constexpr VkExtent2D kView{320, 180};
// Bound on the misclassification rate of the analytic scene at 1024^2. Measured on lavapipe:
// 0.39% (256^2: 1.6%, 512^2: 0.87%).
constexpr double kAnalyticBound1024 = 0.01;

struct Measured {
  csm_measure::AccuracyStats stats;
  csm::CascadeFrame frame;
  engine::CpuImage image;
  std::vector<csm_measure::PixelSample> pixels;
};

Measured renderAndMeasure(csm_measure::Harness& harness, const csm_measure::RayTracer& tracer,
                          const csm::Camera& camera, const csm::DirectionalLight& light,
                          csm::PcfKernel kernel) {
  Measured m;
  csm::CascadeHistory history;
  m.frame = harness.computeFrame(camera, light, history);
  m.pixels = harness.renderAccuracy(camera, m.frame, kView, kernel, true, &m.image);
  m.stats = csm_measure::measureAccuracy(m.pixels, m.frame, tracer, light);
  return m;
}

void printStats(const char* label, const Measured& m) {
  std::printf(
      "%-28s pixels %6llu (truth shadowed %llu) misclassified %5.2f%% mean |s-v| %.4f  per "
      "cascade:",
      label, (unsigned long long)m.stats.overall.pixels,
      (unsigned long long)m.stats.overall.shadowedTruth, 100.0 * m.stats.overall.rate(),
      m.stats.overall.meanAbsError());
  for (uint32_t c = 0; c < m.frame.cascadeCount; ++c) {
    std::printf(" [%u] %llu px %.2f%% %.4f", c, (unsigned long long)m.stats.perCascade[c].pixels,
                100.0 * m.stats.perCascade[c].rate(), m.stats.perCascade[c].meanAbsError());
  }
  std::printf("\n  texel/pixel log2 histogram:");
  for (int k = 0; k < csm_measure::RatioHistogram::kBins; ++k) {
    std::printf(" %d:%llu", csm_measure::RatioHistogram::kLo + k,
                (unsigned long long)m.stats.texelToPixel.counts[size_t(k)]);
  }
  std::printf("\n");
  std::fflush(stdout);
}

// The shadow-factor image with misclassified pixels in red (v = 1, s low) or blue (v = 0, s high).
engine::CpuImage errorImage(const Measured& m, const csm_measure::RayTracer& tracer,
                            const csm::DirectionalLight& light) {
  engine::CpuImage img = m.image;
  std::vector<glm::dvec3> pos;
  std::vector<glm::vec3> nrm;
  for (const auto& p : m.pixels) {
    pos.push_back(p.posWs);
    nrm.push_back(p.normalWs);
  }
  std::vector<float> vis(pos.size());
  tracer.visibility(pos, nrm, light.directionWs, vis);
  const glm::dvec3 toLight = -glm::normalize(light.directionWs);
  for (size_t i = 0; i < m.pixels.size(); ++i) {
    const auto& p = m.pixels[i];
    if (p.cascade < 0 || !(glm::dot(glm::dvec3(p.normalWs), toLight) > 0.0)) continue;
    if (std::abs(double(p.shadow) - vis[i]) <= 0.5) continue;
    uint8_t* px = &img.rgba[4 * (size_t(p.y) * img.width + p.x)];
    px[0] = vis[i] > 0.5f ? 255 : 0;
    px[1] = 0;
    px[2] = vis[i] > 0.5f ? 0 : 255;
  }
  return img;
}

TEST(StabilityAccuracy, AnalyticSceneAgreesWithRayTracedTruthAndDegradesWithResolution) {
  nlohmann::json report;
  double rate1024 = 0.0, rate256 = 0.0;
  uint64_t pixels1024 = 0;
  {
    CSM_MAKE_HARNESS(harness);
    csm_measure::TestSceneDesc sd;
    sd.terrain = false;  // flat ground, boxes, poles, spheres: the analytic scene
    const csm_measure::Scene scene = csm_measure::Scene::makeTestScene(sd);
    harness->setScene(scene);
    const csm_measure::RayTracer tracer(scene);
    const csm::DirectionalLight light = testLight();
    const csm::Camera camera = baseCamera(sd.originWs, double(kView.width) / kView.height);
    for (uint32_t res : {1024u, 512u, 256u}) {
      csm::ShadowSettings s = testSettings(true);
      s.resolution = res;
      CSM_ASSERT_STATUS(harness->configure(s));
      const Measured m = renderAndMeasure(*harness, tracer, camera, light, csm::PcfKernel::kTent3);
      const std::string label = "analytic res " + std::to_string(res);
      printStats(label.c_str(), m);
      EXPECT_EQ(m.stats.nonFinite, 0u);
      engine::writePng(artefactDir() + "/accuracy_analytic_" + std::to_string(res) + ".png",
                       errorImage(m, tracer, light));
      nlohmann::json j = m.stats.toJson(m.frame.cascadeCount);
      j["resolution"] = res;
      j["scene"] = "analytic (flat ground)";
      report["runs"].push_back(j);
      if (res == 1024) {
        rate1024 = m.stats.overall.rate();
        pixels1024 = m.stats.overall.pixels;
      }
      if (res == 256) rate256 = m.stats.overall.rate();
    }
    // The terrain scene, for the report (receivers on slopes).
    {
      csm_measure::TestSceneDesc td;
      const csm_measure::Scene terrain = csm_measure::Scene::makeTestScene(td);
      harness->setScene(terrain);
      const csm_measure::RayTracer terrainTracer(terrain);
      CSM_ASSERT_STATUS(harness->configure(testSettings(true)));
      const Measured m =
          renderAndMeasure(*harness, terrainTracer, camera, light, csm::PcfKernel::kTent3);
      printStats("terrain res 1024", m);
      EXPECT_EQ(m.stats.nonFinite, 0u);
      engine::writePng(artefactDir() + "/accuracy_terrain_1024.png",
                       errorImage(m, terrainTracer, light));
      nlohmann::json j = m.stats.toJson(m.frame.cascadeCount);
      j["resolution"] = 1024;
      j["scene"] = "terrain";
      report["runs"].push_back(j);
    }
  }
  EXPECT_EQ(engine::validationMessageCount(), 0u);
  report["what"] =
      "Receiver pixels (320x180, facing the light, inside the shadow range) of csm.glsl "
      "(tent3x3, blend on, 4 cascades over 120 m) against Embree shadow rays; misclassified = "
      "|s - v| > 0.5. Red in the PNGs: lit by the truth, shadowed by the map; blue: the reverse.";
  csm_measure::writeJson(artefactDir() + "/accuracy.json", report);

  EXPECT_GT(pixels1024, 20000u) << "too few receiver pixels compared";
  EXPECT_LT(rate1024, kAnalyticBound1024);
  EXPECT_GT(rate256, 1.5 * rate1024) << "the metric must rise when resolution drops";
}

}  // namespace
}  // namespace csm_stability
