// The bias metric of bias_test.cpp on the sample world itself (the issue's own case: the
// fly-through's forest path, first frame, with its shadow settings), at every elevation of the
// issue and three azimuths, D32 and D16, tent 3x3 (the fly-through's kernel): acne <= 0.05% and
// faint acne <= 0.1% asserted, leaks reported. Writes test_artefacts/stability/bias_world.json
// (the cases in bias.json's format) and bias_world_elev<e>.png (acne red, leaks blue).
#include <sample_world/paths.hpp>
#include <sample_world/settings.hpp>
#include <sample_world/world.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <csm_measure/bias_metrics.hpp>
#include <csm_measure/world_scene.hpp>
#include <engine/camera.hpp>
#include <engine/image_io.hpp>

#include "small_world.hpp"
#include "stability_common.hpp"

namespace csm_stability {
namespace {

constexpr VkExtent2D kView{320, 180};
constexpr double kMaxAcne = 0.0005;
constexpr double kMaxDimmed = 0.001;

/// As bias_test.cpp: the direction the light travels for a sun `elevationDeg` above the horizon
/// from `azimuthDeg` (0 = from +z, 90 = from +x); exactly straight down at 90.
glm::dvec3 sunDirection(double elevationDeg, double azimuthDeg) {
  if (elevationDeg >= 90.0) return glm::dvec3(0.0, -1.0, 0.0);
  const double e = glm::radians(elevationDeg);
  const double a = glm::radians(azimuthDeg);
  return -glm::dvec3(std::cos(e) * std::sin(a), std::sin(e), std::cos(e) * std::cos(a));
}

TEST(StabilityBias, SampleWorldForestPathNoAcneAtEveryElevation) {
  nlohmann::json report;
  report["cases"] = nlohmann::json::array();
  {
    CSM_MAKE_HARNESS(harness);
    world::WorldError err;
    const std::optional<world::World> w = smallSampleWorld(&err);
    ASSERT_TRUE(w.has_value()) << err.message;
    const csm_measure::WorldScene ws = csm_measure::sceneFromWorld(*w, true);
    harness->setScene(ws.scene);
    const csm_measure::RayTracer tracer(ws.scene);
    const world::AppSettings app;
    const csm::ShadowSettings settings = world::effectiveShadow(app);
    // The forest path's first frame, as the fly-through poses it.
    const std::optional<world::FlightPath> path = world::FlightPath::make("forest", *w, 60.0);
    ASSERT_TRUE(path.has_value());
    const world::CameraPose pose = path->at(0.0);
    const csm::Camera camera = glue::toCsmCamera(
        world::poseCamera(pose, double(kView.width) / kView.height, 0.5, app.farM));
    for (double elevation : {1.0, 2.0, 5.0, 10.0, 30.0, 60.0, 89.0, 89.999, 90.0}) {
      // Lit interior pixels of the elevation's best-lit view: the acne bound must be measured
      // on something (at 1-2 degrees most of the view is in the hills' shadow).
      uint64_t interior = 0;
      for (double azimuth : {30.0, 140.0, 250.0}) {
        if (elevation == 90.0 && azimuth != 30.0) continue;  // straight down: one azimuth
        const csm::DirectionalLight light{sunDirection(elevation, azimuth)};
        csm_measure::BiasTruth truth;
        bool haveTruth = false;
        for (VkFormat format : {VK_FORMAT_D32_SFLOAT, VK_FORMAT_D16_UNORM}) {
          csm::vk::RendererOptions opt;
          opt.depthFormat = format;
          CSM_ASSERT_STATUS(harness->configure(settings, opt));
          csm::CascadeHistory history;
          const csm::CascadeFrame frame = harness->computeFrame(camera, light, history);
          engine::CpuImage image;
          const auto pixels =
              harness->renderAccuracy(camera, frame, kView, csm::PcfKernel::kTent3, true, &image);
          if (!haveTruth) {
            truth = csm_measure::computeBiasTruth(pixels, kView.width, kView.height, frame, tracer,
                                                  light);
            haveTruth = true;
          }
          const csm_measure::BiasStats st = csm_measure::scoreBias(pixels, truth, light);
          const char* fmtName = format == VK_FORMAT_D32_SFLOAT ? "D32" : "D16";
          // Surfaces facing away from the light: dark by their own shading, so the shadow test
          // must return 0 there, neither noise nor light. Facing away by the triangle under the
          // pixel (Embree's geometric normal, turned toward the camera; csmShadow tests the
          // facet normal), by more than a margin: N.L < -0.05.
          uint64_t away = 0, awayNotDark = 0, awayLit = 0;
          for (const auto& p : pixels) {
            if (p.cascade < 0 || glm::dot(glm::dvec3(p.normalWs), -light.directionWs) >= 0.3)
              continue;
            const glm::dvec3 eye = camera.positionWs;
            const glm::dvec3 dir = glm::normalize(p.posWs - eye);
            glm::dvec3 hit;
            glm::vec3 ng;
            if (!tracer.intersect(eye, dir, &hit, &ng) || glm::length(hit - p.posWs) > 0.05)
              continue;
            glm::dvec3 n = glm::normalize(glm::dvec3(ng));
            if (glm::dot(n, dir) > 0.0) n = -n;
            if (glm::dot(n, -light.directionWs) >= -0.05) continue;
            ++away;
            awayNotDark += p.shadow != 0.0f ? 1 : 0;
            awayLit += p.shadow > 0.5f ? 1 : 0;
          }
          report["cases"].push_back({{"scene", "sample world (forest path, first frame)"},
                                     {"elevation_deg", elevation},
                                     {"azimuth_deg", azimuth},
                                     {"format", fmtName},
                                     {"kernel", csm::kernelName(csm::PcfKernel::kTent3)},
                                     {"resolution", settings.resolution},
                                     {"false_shadow_lit_facing", st.acne()},
                                     {"false_shadow_lit_facing_incl_edges", st.acneRaw()},
                                     {"dimmed_lit_facing", st.dimmed()},
                                     {"false_lit_near_contact", st.leaks()},
                                     {"false_lit_near_contact_facing", st.leaksFacing()},
                                     {"counts", st.toJson()},
                                     {"facing_away", away},
                                     {"facing_away_not_dark", awayNotDark},
                                     {"facing_away_lit", awayLit}});
          std::printf(
              "world elev %7.3f az %5.1f %s: acne %.4f%% (%llu/%llu) dimmed %.4f%% leaks %.2f%% "
              "(%llu/%llu), facing %.2f%%; facing away %llu, not dark %llu, lit %llu\n",
              elevation, azimuth, fmtName, 100.0 * st.acne(),
              (unsigned long long)st.litInteriorDark, (unsigned long long)st.litInterior,
              100.0 * st.dimmed(), 100.0 * st.leaks(), (unsigned long long)st.contactLit,
              (unsigned long long)st.contact, 100.0 * st.leaksFacing(), (unsigned long long)away,
              (unsigned long long)awayNotDark, (unsigned long long)awayLit);
          std::fflush(stdout);
          EXPECT_EQ(st.nonFinite, 0u);
          EXPECT_EQ(st.unmatched, 0u);
          interior = std::max(interior, st.litInterior);
          // Of the pixels facing away, none lit and none noisy: exactly 0 (a handful allowed for
          // pixels whose triangle the ray and the raster disagree on, at silhouettes).
          EXPECT_LE(double(awayLit), 0.001 * double(away))
              << elevation << " " << azimuth << " " << fmtName;
          EXPECT_LE(double(awayNotDark), 0.005 * double(away))
              << elevation << " " << azimuth << " " << fmtName;
          EXPECT_LE(st.acne(), kMaxAcne) << elevation << " " << azimuth << " " << fmtName;
          EXPECT_LE(st.dimmed(), kMaxDimmed) << elevation << " " << azimuth << " " << fmtName;
          if (format == VK_FORMAT_D32_SFLOAT && azimuth == 30.0) {
            csm_measure::paintBiasErrors(image, pixels, truth);
            char name[64];
            std::snprintf(name, sizeof(name), "/bias_world_elev%g.png", elevation);
            engine::writePng(artefactDir() + name, image);
          }
        }
      }
      EXPECT_GT(interior, 400u) << "elevation " << elevation << ": too few lit pixels to score";
    }
  }
  EXPECT_EQ(engine::validationMessageCount(), 0u);
  report["what"] =
      "bias.json's metric on the sample world (3000 trees, 40 buildings; thin clusters flagged), "
      "the fly-through's forest path, first frame, its shadow settings, 320x180, tent 3x3.";
  csm_measure::writeJson(artefactDir() + "/bias_world.json", report);
}

}  // namespace
}  // namespace csm_stability
