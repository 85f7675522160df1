// Camera conventions: right-handed, +Y up, looking down -Z, Vulkan clip space (depth [0, 1],
// y down), camera-relative positions exact far from the origin. CPU only.
#include <gtest/gtest.h>

#include <glm/glm.hpp>

#include "engine/camera.hpp"

namespace {

glm::vec3 toNdc(const glm::mat4& m, const glm::vec3& p) {
  const glm::vec4 c = m * glm::vec4(p, 1.0f);
  return glm::vec3(c) / c.w;
}

TEST(EngineCamera, ProjectionIsVulkanClipSpace) {
  engine::Camera cam;
  cam.nearM = 0.5;
  cam.farM = 200.0;
  cam.aspect = 2.0;
  const glm::mat4 vp = cam.viewProjectionCr();
  EXPECT_NEAR(toNdc(vp, {0, 0, -0.5f}).z, 0.0f, 1e-6f);    // near plane -> depth 0
  EXPECT_NEAR(toNdc(vp, {0, 0, -200.0f}).z, 1.0f, 1e-5f);  // far plane -> depth 1
  EXPECT_LT(toNdc(vp, {0, 1, -10}).y, 0.0f);               // world up -> top of the image
  EXPECT_GT(toNdc(vp, {1, 0, -10}).x, 0.0f);               // world +X -> right
  // Vertical FOV: a point on the top frustum edge lands on y = -1.
  const float t = float(std::tan(cam.fovYRad / 2) * 10.0);
  EXPECT_NEAR(toNdc(vp, {0, t, -10}).y, -1.0f, 1e-5f);
  EXPECT_NEAR(toNdc(vp, {float(cam.aspect) * t, 0, -10}).x, 1.0f, 1e-5f);
}

TEST(EngineCamera, YawPitchAndLookAt) {
  engine::Camera cam;
  cam.setYawPitchRoll(glm::radians(90.0), 0.0);
  EXPECT_NEAR(cam.forwardWs().x, -1.0, 1e-12);  // positive yaw turns left, towards -X
  cam.setYawPitchRoll(0.0, glm::radians(30.0));
  EXPECT_GT(cam.forwardWs().y, 0.0);  // positive pitch looks up
  cam.positionWs = {10, 5, 10};
  cam.lookAt({10, 5, 0});
  EXPECT_NEAR(glm::length(cam.forwardWs() - glm::dvec3(0, 0, -1)), 0.0, 1e-12);
  cam.lookAt({10, -100, 10});  // straight down: still a valid orthonormal basis
  EXPECT_NEAR(cam.forwardWs().y, -1.0, 1e-12);
  EXPECT_NEAR(glm::dot(cam.rightWs(), cam.upWs()), 0.0, 1e-12);
  // The view rotation takes the look direction to -Z.
  cam.positionWs = {0, 0, 0};
  cam.lookAt({3, 4, 0});
  const glm::vec4 v = cam.viewRotation() * glm::vec4(3, 4, 0, 0);
  EXPECT_NEAR(v.x, 0.0f, 1e-5f);
  EXPECT_NEAR(v.y, 0.0f, 1e-5f);
  EXPECT_NEAR(v.z, -5.0f, 1e-5f);
}

TEST(EngineCamera, CameraRelativeIsExactFarFromOrigin) {
  engine::Camera cam;
  cam.positionWs = {1.0e7 + 0.25, -3.0e6, 1.0e7};
  const glm::vec3 rel = cam.toCameraRelative({1.0e7 + 1.5, -3.0e6 + 0.125, 1.0e7 - 2.0});
  EXPECT_EQ(rel, glm::vec3(1.25f, 0.125f, -2.0f));
}

TEST(EngineCamera, InvalidParametersAreRefused) {
  engine::Camera cam;
  cam.nearM = 0.0;
  EXPECT_THROW(cam.projection(), std::invalid_argument);
  cam.nearM = 1.0;
  cam.farM = 0.5;
  EXPECT_THROW(cam.projection(), std::invalid_argument);
}

}  // namespace
