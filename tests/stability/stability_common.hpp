// Shared set-up of the stability tests: the measurement scene at a given distance from the world
// origin, the cameras and motions, and the artefact folder.
#pragma once

#include <gtest/gtest.h>

#include <csm/names.hpp>
#include <csm_measure/harness.hpp>
#include <csm_measure/metrics.hpp>
#include <csm_measure/motions.hpp>
#include <csm_measure/raytracer.hpp>
#include <csm_measure/scene.hpp>
#include <engine/debug.hpp>
#include <engine/errors.hpp>
#include <glue/camera.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace csm_stability {

/// Where the tests write their reports (build tree).
inline std::string artefactDir() {
  const std::filesystem::path dir = std::filesystem::path(CSM_TEST_ARTEFACT_DIR) / "stability";
  std::filesystem::create_directories(dir);
  return dir.string();
}

// The shimmer scene, its light, cameras and motions (csm_measure/motions.hpp).
using csm_measure::baseCamera;
using csm_measure::distanceKey;
using csm_measure::motionCamera;
using csm_measure::originAt;
using csm_measure::setShimmerScene;
using csm_measure::testLight;
using csm_measure::viewReceivers;

/// Writes a test's report to artefactDir()/`fileName`: what it measured, its runs, and any
/// further top-level fields of `extra`.
inline void writeReport(const std::string& fileName, const std::string& what, nlohmann::json runs,
                        nlohmann::json extra = nlohmann::json::object()) {
  extra["what"] = what;
  extra["runs"] = std::move(runs);
  csm_measure::writeJson(artefactDir() + "/" + fileName, extra);
}

/// Settings of the shimmer tests: 4 cascades of 1024^2 over 120 m.
inline csm::ShadowSettings testSettings(bool stabilize) {
  csm::ShadowSettings s;
  s.cascadeCount = 4;
  s.resolution = 1024;
  s.shadowDistanceM = 120.0;
  s.splitLambda = 0.6;
  s.blendBand = 0.1;
  s.diagnostics.stabilize = stabilize;
  return s;
}

/// Creates a validation-enabled harness, or skips the test where no Vulkan device exists.
#define CSM_MAKE_HARNESS(var) CSM_MAKE_HARNESS_DESC(var, csm_measure::HarnessDesc{})
/// The same, created with `desc` (a csm_measure::HarnessDesc).
#define CSM_MAKE_HARNESS_DESC(var, desc)                                                      \
  std::unique_ptr<csm_measure::Harness> var;                                                  \
  engine::resetValidationCounts();                                                            \
  try {                                                                                       \
    var = std::make_unique<csm_measure::Harness>(desc);                                       \
  } catch (const engine::NoDeviceError& e) {                                                  \
    GTEST_SKIP() << "no Vulkan device: " << e.what();                                         \
  }                                                                                           \
  ASSERT_TRUE(var->context().validationEnabled() || std::getenv("CSM_VALIDATION") != nullptr) \
      << "VK_LAYER_KHRONOS_validation is required"

/// Asserts a csm::vk::Status is ok.
#define CSM_ASSERT_STATUS(expr)             \
  do {                                      \
    const csm::vk::Status st_ = (expr);     \
    ASSERT_TRUE(st_.ok()) << st_.message(); \
  } while (false)

/// The stabilised-shimmer bound of the percentage-closer kernels, for `settings` (its kernel)
/// and `options`: on the shimmer scene at 0 and 10^7 m, 4000 receivers in the view, 12 frames
/// each of sub-texel translation, multi-texel translation and yaw, no receiver that stays in its
/// cascade may change by more than kVisibleStep. Prints each run; returns them for a report.
inline nlohmann::json expectStabilisedShimmerBound(csm_measure::Harness& harness,
                                                   const csm::ShadowSettings& settings,
                                                   const csm::vk::RendererOptions& options = {}) {
  const csm::DirectionalLight light = testLight();
  const char* name = csm::kernelName(settings.kernel);
  nlohmann::json runs = nlohmann::json::array();
  for (double distance : {0.0, 1e7}) {
    const glm::dvec3 origin = originAt(distance);
    const csm_measure::Scene scene = setShimmerScene(harness, distance);
    const std::vector<csm_measure::Receiver> receivers = viewReceivers(scene, 4000);
    const csm::vk::Status status = harness.configure(settings, options);
    EXPECT_TRUE(status.ok()) << status.message();
    if (!status.ok()) return runs;
    csm::CascadeHistory h;
    const csm::CascadeFrame f0 = harness.computeFrame(baseCamera(origin), light, h);
    const double texel0 = f0.cascades[0].texelSizeM();
    const double texelLast = f0.cascades[f0.cascadeCount - 1].texelSizeM();
    for (const std::string motion : {"subtexel", "multitexel", "yaw"}) {
      const csm_measure::ShimmerRun run = csm_measure::measureShimmer(
          harness, receivers, light,
          [&](int f) { return motionCamera(motion, origin, texel0, texelLast, f); }, 12,
          settings.kernel);
      const csm_measure::ShimmerStats& stayed = run.total.stayed;
      std::printf("%-9s %-10s %6s m  stayed pairs %6llu  mean %.2e max %.5f  visible %llu\n", name,
                  motion.c_str(), distanceKey(distance).c_str(), (unsigned long long)stayed.pairs,
                  stayed.mean(), stayed.max, (unsigned long long)stayed.visible);
      std::fflush(stdout);
      runs.push_back({{"filter", name},
                      {"motion", motion},
                      {"distance_m", distance},
                      {"stayed", stayed.toJson()}});
      SCOPED_TRACE(std::string(name) + " " + motion + " at " + distanceKey(distance) + " m");
      EXPECT_EQ(run.nonFinite, 0u);
      EXPECT_GT(stayed.pairs, 10000u) << "too few points tracked";
      EXPECT_LE(stayed.max, csm_measure::kVisibleStep);
      EXPECT_EQ(stayed.visible, 0u);
    }
  }
  return runs;
}

}  // namespace csm_stability
