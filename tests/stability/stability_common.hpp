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
#include <filesystem>
#include <memory>
#include <string>

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
