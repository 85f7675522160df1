// Shared set-up of the stability tests: the measurement scene at a given distance from the world
// origin, the cameras and motions, and the artefact folder.
#pragma once

#include <gtest/gtest.h>

#include <csm_measure/harness.hpp>
#include <csm_measure/metrics.hpp>
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

/// The scene's local origin `distanceM` from the world origin (a direction that is on no axis).
inline glm::dvec3 originAt(double distanceM) {
  return distanceM * glm::dvec3(0.6, 0.0, -0.8);
}

/// The light of every test unless a test says otherwise: it never moves.
inline csm::DirectionalLight testLight() {
  csm::DirectionalLight l;
  l.directionWs = glm::normalize(glm::dvec3(0.75, -0.6, 0.3));
  return l;
}

/// The base camera: local (0, 7, 28) looking at local (0, 0, -25).
inline csm::Camera baseCamera(const glm::dvec3& originWs, double aspect = 16.0 / 9.0) {
  engine::Camera e;
  e.positionWs = originWs + glm::dvec3(0.0, 7.0, 28.0);
  e.lookAt(originWs + glm::dvec3(0.0, 0.0, -25.0));
  e.fovYRad = glm::radians(60.0);
  e.aspect = aspect;
  e.nearM = 0.1;
  e.farM = 1000.0;
  return glue::toCsmCamera(e);
}

/// A distance from the origin as the shimmer tests print and plot it: "0", "1e+06", "1e+07".
inline std::string distanceKey(double d) {
  if (d == 0.0) return "0";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.0e", d);
  return buf;
}

/// The shimmer tests' scene (csm_measure::Scene::makeTestScene, terrain) `distanceM` from the
/// origin, handed to the harness.
inline csm_measure::Scene setShimmerScene(csm_measure::Harness& harness, double distanceM) {
  csm_measure::TestSceneDesc sd;
  sd.originWs = originAt(distanceM);
  csm_measure::Scene scene = csm_measure::Scene::makeTestScene(sd);
  harness.setScene(scene);
  return scene;
}

/// The shimmer tests' receivers: `count` points (30% on building walls) over the whole view.
inline std::vector<csm_measure::Receiver> viewReceivers(const csm_measure::Scene& scene,
                                                        uint32_t count) {
  return scene.sampleReceivers(count, 0.3, {-45.0, -5.0, -100.0}, {45.0, 30.0, 15.0}, 7);
}

/// The camera of frame f of a shimmer motion about the base camera (`origin`'s), in texels of the
/// stabilised cascades of the base camera (cascade 0's `texel0`, the last one's `texelLast`) so
/// that "sub-texel" means the same at every distance: static, subtexel (0.3 texel0 per frame),
/// multitexel (3.3 texelLast), yaw (0.35 degrees), pitch (0.25 degrees), orbit (about a point
/// 53 m ahead, 0.4 degrees per frame).
inline csm::Camera motionCamera(const std::string& motion, const glm::dvec3& origin, double texel0,
                                double texelLast, int f) {
  csm::Camera c = baseCamera(origin);
  const glm::dvec3 dir = glm::normalize(glm::dvec3(1.0, 0.15, -0.7));
  if (motion == "subtexel") {
    c.positionWs += dir * (0.3 * texel0 * f);
  } else if (motion == "multitexel") {
    c.positionWs += dir * (3.3 * texelLast * f);
  } else if (motion == "yaw") {
    c.orientationWs = glm::angleAxis(glm::radians(0.35 * f), glm::dvec3(0, 1, 0)) * c.orientationWs;
  } else if (motion == "pitch") {
    c.orientationWs = c.orientationWs * glm::angleAxis(glm::radians(0.25 * f), glm::dvec3(1, 0, 0));
  } else if (motion == "orbit") {
    const glm::dvec3 target = origin + glm::dvec3(0.0, 0.0, -25.0);
    const glm::dquat r = glm::angleAxis(glm::radians(0.4 * f), glm::dvec3(0, 1, 0));
    engine::Camera e;
    e.positionWs = target + r * (c.positionWs - target);
    e.lookAt(target);
    c.positionWs = e.positionWs;
    c.orientationWs = e.orientation;
  }
  return c;
}

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
  s.stabilize = stabilize;
  return s;
}

/// Creates a validation-enabled harness, or skips the test where no Vulkan device exists.
#define CSM_MAKE_HARNESS(var)                                                                 \
  std::unique_ptr<csm_measure::Harness> var;                                                  \
  engine::resetValidationCounts();                                                            \
  try {                                                                                       \
    var = std::make_unique<csm_measure::Harness>();                                           \
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

}  // namespace csm_stability
