// csm::vk::DepthRangeReducer against an analytic scene: the depth buffer of a camera above an
// infinite ground plane (sky where the view looks above the horizon or beyond the far plane),
// computed exactly and uploaded; the reduction must return the nearest and farthest view depth
// of the ground pixels. A camera cut drops every earlier result; an empty view gives none.
// Validation on, zero messages.
#include <cmath>
#include <limits>
#include <vector>

#include <csm/vulkan/depth_range.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "engine_gpu_test.hpp"
#include "glue/shadow_host.hpp"

namespace {

struct AnalyticDepth {
  std::vector<float> depth;  // the depth buffer (D32, standard depth, 1 = clear)
  double minM = std::numeric_limits<double>::infinity();
  double maxM = 0.0;  // analytic view depths of the ground pixels
  float minF = std::numeric_limits<float>::infinity(), maxF = 0.0f;  // as the shader computes
  csm::vk::DepthProjection projection;
};

// A camera `heightM` above the plane y = 0, pitched down by `pitchDeg`.
AnalyticDepth groundPlane(std::uint32_t w, std::uint32_t h, double heightM, double pitchDeg,
                          double fovDeg, double nearM, double farM) {
  AnalyticDepth a;
  const glm::dmat4 proj = glm::perspectiveRH_ZO(glm::radians(fovDeg), double(w) / h, nearM, farM);
  a.projection.p22 = float(proj[2][2]);
  a.projection.p32 = float(proj[3][2]);
  a.projection.clearDepth = 1.0f;
  const double tanY = std::tan(glm::radians(fovDeg) * 0.5);
  const double pitch = glm::radians(pitchDeg);
  a.depth.resize(std::size_t(w) * h, 1.0f);
  for (std::uint32_t y = 0; y < h; ++y) {
    for (std::uint32_t x = 0; x < w; ++x) {
      // View-space ray through the pixel centre (Vulkan: y down in the image); its x does not
      // change the view depth at which it meets the plane.
      const double vy = -(2.0 * (y + 0.5) / h - 1.0) * tanY;
      // World y of the ray (vx, vy, -1) (view depth 1) after pitching the view about x:
      // (y, z) -> (y cos p - z sin p, ...) with z = -1; a negative pitch looks down.
      const double dirY = vy * std::cos(pitch) + std::sin(pitch);
      if (!(dirY < 0.0)) continue;            // above the horizon: sky
      const double depthM = heightM / -dirY;  // view depth at which the ray meets y = 0
      if (!(depthM < farM) || !(depthM > nearM)) continue;
      const glm::dvec4 clip = proj * glm::dvec4(0.0, 0.0, -depthM, 1.0);
      const float z = float(clip.z / clip.w);
      if (!(z < 1.0f)) continue;
      a.depth[std::size_t(y) * w + x] = z;
      a.minM = std::min(a.minM, depthM);
      a.maxM = std::max(a.maxM, depthM);
      const float d = a.projection.p32 / (z + a.projection.p22);
      a.minF = std::min(a.minF, d);
      a.maxF = std::max(a.maxF, d);
    }
  }
  return a;
}

class DepthRangeTest : public engine_test::GpuTest {};

TEST_F(DepthRangeTest, ReturnsTheAnalyticRangeAndFallsBackAfterACut) {
  constexpr std::uint32_t kW = 320, kH = 180;
  // Looking 12 degrees down from 6 m: ground from about 8 m to about 585 m (the last row below
  // the horizon).
  const AnalyticDepth scene = groundPlane(kW, kH, 6.0, -12.0, 60.0, 0.1, 800.0);
  ASSERT_LT(scene.minM, 30.0);
  ASSERT_GT(scene.maxM, 300.0);
  const AnalyticDepth sky = groundPlane(kW, kH, 6.0, 45.0, 30.0, 0.1, 800.0);  // all sky
  ASSERT_EQ(sky.maxM, 0.0);

  engine::ImageDesc desc;
  desc.format = VK_FORMAT_D32_SFLOAT;
  desc.extent = {kW, kH};
  desc.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  engine::Image depth(ctx(), desc, "analytic depth");
  engine::Image skyDepth(ctx(), desc, "sky depth");
  engine::uploadImage(ctx(), depth, engine::asBytes(std::span<const float>(scene.depth)),
                      VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  engine::uploadImage(ctx(), skyDepth, engine::asBytes(std::span<const float>(sky.depth)),
                      VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);

  csm::vk::Status status;
  auto reducer = csm::vk::DepthRangeReducer::create(glue::shadowDeviceInfo(ctx()), 2, &status);
  ASSERT_TRUE(reducer) << status.message();
  // Nothing recorded yet: no range (the splits use the full range).
  EXPECT_FALSE(reducer->read(0).has_value());

  ctx().submitAndWait([&](VkCommandBuffer cmd) {
    ASSERT_TRUE(reducer
                    ->record(cmd, depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, {kW, kH},
                             scene.projection, 0)
                    .ok());
    ASSERT_TRUE(reducer
                    ->record(cmd, skyDepth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                             {kW, kH}, sky.projection, 1)
                    .ok());
  });
  const auto range = reducer->read(0);
  ASSERT_TRUE(range.has_value());
  // Exactly what the shader's float formula gives for the uploaded values...
  EXPECT_EQ(range->minM, double(scene.minF));
  EXPECT_EQ(range->maxM, double(scene.maxF));
  // ...and the analytic truth within the depth buffer's precision.
  EXPECT_NEAR(range->minM, scene.minM, 1e-4 * scene.minM);
  EXPECT_NEAR(range->maxM, scene.maxM, 2e-3 * scene.maxM);
  std::printf("analytic ground range [%.4f, %.4f] m, reduced [%.4f, %.4f] m\n", scene.minM,
              scene.maxM, range->minM, range->maxM);
  // Only sky: no range.
  EXPECT_FALSE(reducer->read(1).has_value());

  // The range drives the splits: they start near the nearest receiver.
  csm::ShadowSettings s;
  csm::Camera cam;
  cam.farM = 800.0;
  auto f = csm::computeCascades(s, cam, csm::DirectionalLight{}, nullptr, nullptr, &*range);
  ASSERT_TRUE(f.ok());
  EXPECT_GT(f.value().splitsM[0], 0.5 * scene.minM);
  EXPECT_LE(f.value().splitsM[0], scene.minM);

  // A camera cut: the earlier result is dropped, so the splits fall back to the full range.
  reducer->invalidate();
  EXPECT_FALSE(reducer->read(0).has_value());
  auto g = csm::computeCascades(s, cam, csm::DirectionalLight{}, nullptr, nullptr, nullptr);
  ASSERT_TRUE(g.ok());
  EXPECT_EQ(g.value().splitsM[0], cam.nearM);
  // A new result after the cut is used again.
  ctx().submitAndWait([&](VkCommandBuffer cmd) {
    ASSERT_TRUE(reducer
                    ->record(cmd, depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, {kW, kH},
                             scene.projection, 0)
                    .ok());
  });
  ASSERT_TRUE(reducer->read(0).has_value());
  EXPECT_EQ(reducer->read(0)->minM, double(scene.minF));

  // Bad calls are refused by name, and leave the reducer usable.
  ctx().submitAndWait([&](VkCommandBuffer cmd) {
    const csm::vk::Status bad = reducer->record(
        cmd, depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, {kW, kH}, scene.projection, 2);
    EXPECT_EQ(bad.code(), csm::vk::ErrorCode::kIndexOutOfRange);
    EXPECT_NE(bad.message().find("slot = 2"), std::string::npos) << bad.message();
    const csm::vk::Status layout =
        reducer->record(cmd, depth.view(), VK_IMAGE_LAYOUT_GENERAL, {kW, kH}, scene.projection, 0);
    EXPECT_EQ(layout.code(), csm::vk::ErrorCode::kInvalidArgument);
  });
  EXPECT_FALSE(csm::vk::DepthRangeReducer::create(glue::shadowDeviceInfo(ctx()), 9, &status));
  EXPECT_NE(status.message().find("slots = 9"), std::string::npos) << status.message();
  reducer.reset();
}

}  // namespace
