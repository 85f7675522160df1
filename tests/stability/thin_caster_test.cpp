// Thin casters against the ray-traced truth: horizontal cables (1, 3 and 10 cm thick) 3 m above
// flat ground and 3 cm antennas, receivers sampled on the centre lines of their true shadows, the
// shadow factor read through csm.glsl (compute probe). Per cascade and caster width: how often
// the shadow is lost (shaded > 0.5 where the truth is 0), against the caster's width in texels.
// Writes test_artefacts/stability/thin_casters.json.
#include <cstdio>
#include <map>

#include "stability_common.hpp"

namespace csm_stability {
namespace {

struct ThinScene {
  csm_measure::Scene scene;
  std::vector<csm_measure::Receiver> receivers;
  std::vector<double> widthM;  // per receiver: the width of the caster whose shadow it samples
};

ThinScene makeThinScene(const glm::dvec3& toLight) {
  ThinScene t;
  const uint32_t ground = t.scene.addMesh(csm_measure::makeGroundMesh(false, 240.0, 8, 0.0, -40.0));
  const uint32_t cube = t.scene.addMesh(csm_measure::makeCubeMesh());
  t.scene.addInstance({ground,
                       glm::dvec3(0.0),
                       glm::mat3(1.0f),
                       {0.6f, 0.6f, 0.55f, 1.0f},
                       csm_measure::InstanceKind::kGround});
  const double widths[] = {0.01, 0.03, 0.10};
  const double h = 3.0;
  // Where a point at height y casts its shadow on y = 0.
  const glm::dvec3 shift = -toLight * (1.0 / toLight.y);
  for (int k = 0; k < 14; ++k) {
    for (int w = 0; w < 3; ++w) {
      const double z = 22.0 - 8.0 * k + 2.0 * w;
      glm::mat3 m(1.0f);
      m[0][0] = 18.0f;
      m[1][1] = float(widths[w]);
      m[2][2] = float(widths[w]);
      t.scene.addInstance({cube,
                           glm::dvec3(-shift.x * h, h, z),
                           m,
                           {0.2f, 0.2f, 0.2f, 1.0f},
                           csm_measure::InstanceKind::kPole});
      // The cable's shadow centre line: x in [-5, 5] on the ground.
      for (double x = -5.0; x <= 5.0; x += 0.05) {
        t.receivers.push_back({glm::dvec3(x, 0.0, z + shift.z * h), glm::vec3(0, 1, 0),
                               csm_measure::InstanceKind::kGround});
        t.widthM.push_back(widths[w]);
      }
    }
    // A 3 cm antenna, 4 m tall, beside the cables: its shadow runs from its foot along `shift`.
    const double z = 22.0 - 8.0 * k + 5.0;
    glm::mat3 m(1.0f);
    m[0][0] = 0.03f;
    m[1][1] = 4.0f;
    m[2][2] = 0.03f;
    const glm::dvec3 foot(-4.0, 0.0, z);
    t.scene.addInstance({cube,
                         foot + glm::dvec3(0, 2.0, 0),
                         m,
                         {0.2f, 0.2f, 0.2f, 1.0f},
                         csm_measure::InstanceKind::kPole});
    for (double y = 0.3; y <= 3.9; y += 0.05) {
      t.receivers.push_back({foot + glm::dvec3(shift.x * y, 0.0, shift.z * y), glm::vec3(0, 1, 0),
                             csm_measure::InstanceKind::kGround});
      t.widthM.push_back(0.0301);  // antennas: reported apart (0.0301 tags them)
    }
  }
  return t;
}

struct Bucket {
  uint64_t n = 0, lost = 0;
  double sumS = 0.0;
  double texelM = 0.0;
};

TEST(StabilityThinCasters, ThinCastersKeepTheirShadowWhereTheyCoverTwoTexels) {
  nlohmann::json report;
  report["runs"] = nlohmann::json::array();
  bool checked = false;
  {
    CSM_MAKE_HARNESS(harness);
    const csm::DirectionalLight light = testLight();
    const glm::dvec3 toLight = -glm::normalize(light.directionWs);
    ThinScene ts = makeThinScene(toLight);
    harness->setScene(ts.scene);
    const csm_measure::RayTracer tracer(ts.scene);
    // Keep the receivers the truth puts in shadow (the cable ends and the antennas' tops aside).
    std::vector<glm::dvec3> pos;
    std::vector<glm::vec3> nrm;
    for (const auto& r : ts.receivers) {
      pos.push_back(r.posWs);
      nrm.push_back(r.normalWs);
    }
    std::vector<float> vis(pos.size());
    tracer.visibility(pos, nrm, light.directionWs, vis, 1e-3);
    std::vector<csm_measure::Receiver> receivers;
    std::vector<double> widths;
    for (size_t i = 0; i < vis.size(); ++i) {
      if (vis[i] < 0.5f) {
        receivers.push_back(ts.receivers[i]);
        widths.push_back(ts.widthM[i]);
      }
    }
    ASSERT_GT(receivers.size(), 5000u);
    const csm::Camera camera = baseCamera(glm::dvec3(0.0));
    for (uint32_t res : {1024u, 2048u}) {
      for (csm::PcfKernel kernel : {csm::PcfKernel::kTent3, csm::PcfKernel::k1Tap}) {
        csm::ShadowSettings s = testSettings(true);
        s.resolution = res;
        CSM_ASSERT_STATUS(harness->configure(s));
        csm::CascadeHistory history;
        const csm::CascadeFrame frame = harness->computeFrame(camera, light, history);
        const auto results = harness->probe(frame, receivers, kernel);
        std::map<std::pair<double, int>, Bucket> buckets;
        for (size_t i = 0; i < results.size(); ++i) {
          const int c = results[i].cascade;
          if (c < 0) continue;
          Bucket& b = buckets[{widths[i], c}];
          ++b.n;
          b.lost += results[i].shadow > 0.5f ? 1 : 0;
          b.sumS += results[i].shadow;
          b.texelM = frame.cascades[size_t(c)].texelSizeM();
        }
        for (const auto& [key, b] : buckets) {
          const bool antenna = key.first == 0.0301;
          const double w = antenna ? 0.03 : key.first;
          const double widthTexels = w / b.texelM;
          const double lost = double(b.lost) / double(b.n);
          std::printf(
              "%4u %-7s %-7s %5.1f cm cascade %d texel %6.2f cm (%5.2f texels wide): lost %6.2f%% "
              "of %5llu, mean s %.3f\n",
              res, csm::kernelName(kernel), antenna ? "antenna" : "cable", 100.0 * w, key.second,
              100.0 * b.texelM, widthTexels, 100.0 * lost, (unsigned long long)b.n,
              b.sumS / double(b.n));
          report["runs"].push_back({{"resolution", res},
                                    {"kernel", csm::kernelName(kernel)},
                                    {"caster", antenna ? "antenna" : "cable"},
                                    {"width_m", w},
                                    {"cascade", key.second},
                                    {"texel_m", b.texelM},
                                    {"width_texels", widthTexels},
                                    {"receivers", b.n},
                                    {"lost_fraction", lost},
                                    {"mean_shadow", b.sumS / double(b.n)}});
          // A caster two texels wide covers a texel centre in every row: its shadow must hold
          // (under the 1-tap kernel; PCF averages a 1-texel line with its lit neighbours).
          if (b.n >= 50 && widthTexels >= 2.0 && kernel == csm::PcfKernel::k1Tap) {
            EXPECT_LE(lost, 0.02) << res << " cascade " << key.second << " width " << w;
            checked = true;
          }
          if (b.n >= 50 && widthTexels < 0.25) {
            EXPECT_GT(lost, 0.5) << "a caster under a quarter texel must lose most of its shadow "
                                    "(else the metric measures nothing)";
          }
        }
      }
    }
  }
  EXPECT_TRUE(checked) << "no cascade saw a caster two texels wide";
  EXPECT_EQ(engine::validationMessageCount(), 0u);
  report["what"] =
      "Receivers on the centre lines of the true shadows of cables (1, 3, 10 cm) 3 m above flat "
      "ground and 3 cm antennas 4 m tall; lost = csm.glsl shades them > 0.5 (truth 0).";
  csm_measure::writeJson(artefactDir() + "/thin_casters.json", report);
}

}  // namespace
}  // namespace csm_stability
