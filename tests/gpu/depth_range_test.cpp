// csm::vk::DepthRangeReducer against an analytic scene: the depth buffer of a camera above an
// infinite ground plane (sky where the view looks above the horizon or beyond the far plane),
// computed exactly and uploaded; the reduction must return the nearest and farthest view depth
// of the ground pixels, and their histogram over log-spaced view-depth bins pixel for pixel. A
// camera cut drops every earlier result; an empty view gives none. ShadowView's receiver fit
// (one switch and one call a frame) gives the same ranges and the frames they make.
// Validation on, zero messages.
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <csm/light_space.hpp>
#include <csm/receiver_bounds.hpp>
#include <csm/receiver_tiles.hpp>
#include <csm/selection.hpp>
#include <csm/splits.hpp>
#include <csm/vulkan/depth_range.hpp>
#include <csm/vulkan/shadow_view.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine_gpu_test.hpp"
#include "glue/shadow_host.hpp"

namespace {

struct AnalyticDepth {
  std::vector<float> depth;    // the depth buffer (D32, standard depth, 1 = clear)
  std::vector<double> depthM;  // analytic view depth of each ground pixel (0: sky)
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
  a.depthM.resize(std::size_t(w) * h, 0.0);
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
      a.depthM[std::size_t(y) * w + x] = depthM;
      a.minM = std::min(a.minM, depthM);
      a.maxM = std::max(a.maxM, depthM);
      const float d = a.projection.p32 / (z + a.projection.p22);
      a.minF = std::min(a.minF, d);
      a.maxF = std::max(a.maxF, d);
    }
  }
  return a;
}

// The camera of groundPlane() `heightM` above the ground at (3e6, 7e6) m from the origin, yawed
// 30 degrees (the ground's depths do not change) and pitched by `pitchDeg`.
csm::Camera yawedCamera(double heightM, double pitchDeg, double fovDeg, double aspect, double nearM,
                        double farM) {
  csm::Camera cam;
  cam.positionWs = glm::dvec3(3.0e6, heightM, -7.0e6);
  cam.orientationWs = glm::angleAxis(glm::radians(30.0), glm::dvec3(0, 1, 0)) *
                      glm::angleAxis(glm::radians(pitchDeg), glm::dvec3(1, 0, 0));
  cam.fovYRad = glm::radians(fovDeg);
  cam.aspect = aspect;
  cam.nearM = nearM;
  cam.farM = farM;
  return cam;
}

// The view of the bounds and tiles tests: groundPlane() seen 20 m up, pitched down 8 degrees,
// field of view 30 degrees, by yawedCamera() far from the origin, with the projection's terms
// for light-space positions (row 0 at the top: +y up in the view).
struct GroundView {
  AnalyticDepth scene;
  csm::vk::DepthProjection proj;
  csm::Camera cam;
  double tanY = 0.0;
  double aspect = 0.0;
};

GroundView groundView(std::uint32_t w, std::uint32_t h, double fovDeg = 30.0) {
  const double pitchDeg = -8.0, heightM = 20.0, nearM = 0.5, farM = 1500.0;
  GroundView v;
  v.scene = groundPlane(w, h, heightM, pitchDeg, fovDeg, nearM, farM);
  v.tanY = std::tan(glm::radians(fovDeg) * 0.5);
  v.aspect = double(w) / h;
  v.proj = v.scene.projection;
  v.proj.p00 = float(1.0 / (v.tanY * v.aspect));
  v.proj.p11 = float(-1.0 / v.tanY);
  v.cam = yawedCamera(heightM, pitchDeg, fovDeg, v.aspect, nearM, farM);
  return v;
}

class DepthRangeTest : public engine_test::GpuTest {
 protected:
  // A view, and a reducer of as many slots to drive by hand beside it.
  struct ViewAndReducer {
    std::unique_ptr<csm::vk::ShadowView> view;
    std::unique_ptr<csm::vk::DepthRangeReducer> reducer;
    std::uint32_t slots = 0;
  };
  ViewAndReducer makeViewAndReducer() {
    ViewAndReducer r;
    r.view = glue::createShadowView(ctx());
    r.slots = glue::shadowDeviceInfo(ctx()).framesInFlight;
    csm::vk::Status status;
    r.reducer = csm::vk::DepthRangeReducer::create(glue::shadowDeviceInfo(ctx()), r.slots, &status);
    EXPECT_TRUE(r.reducer) << status.message();
    return r;
  }

  // The analytic depth buffer as a sampled D32 image, in SHADER_READ_ONLY_OPTIMAL.
  engine::Image uploadDepth(const AnalyticDepth& scene, std::uint32_t w, std::uint32_t h) {
    engine::ImageDesc desc;
    desc.format = VK_FORMAT_D32_SFLOAT;
    desc.extent = {w, h};
    desc.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    engine::Image depth(ctx(), desc, "analytic depth");
    engine::uploadImage(ctx(), depth, engine::asBytes(std::span<const float>(scene.depth)),
                        VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    return depth;
  }

  // The tiles' tests: a 60 degree view of the ground (the cascades before the last lie in its
  // box: they can be partial), its projection, light, settings and depth buffer.
  struct TileView {
    GroundView g;
    glm::mat4 projection{1.0f};
    csm::DirectionalLight light{glm::dvec3(0.45, -0.8, -0.35)};
    csm::ShadowSettings s;
    std::optional<engine::Image> depth;
    csm::vk::ReceiverDepthInput input{};
  };
  std::unique_ptr<TileView> tileView(std::uint32_t w, std::uint32_t h) {
    const double fovDeg = 60.0, nearM = 0.5, farM = 1500.0;
    auto t = std::make_unique<TileView>();
    t->g = groundView(w, h, fovDeg);
    t->projection = glm::perspectiveRH_ZO(glm::radians(fovDeg), t->g.aspect, nearM, farM);
    t->projection[1][1] = -t->projection[1][1];
    EXPECT_EQ(t->g.proj.p22, t->projection[2][2]);
    EXPECT_EQ(t->g.proj.p32, t->projection[3][2]);
    t->s.shadowDistanceM = 300.0;
    t->s.resolution = 1024;
    t->depth.emplace(uploadDepth(t->g.scene, w, h));
    t->input = {t->depth->view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, {w, h}, t->projection};
    return t;
  }
};

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
  EXPECT_FALSE(csm::vk::DepthRangeReducer::create(glue::shadowDeviceInfo(ctx()), 17, &status));
  EXPECT_NE(status.message().find("slots = 17"), std::string::npos) << status.message();
  reducer.reset();
}

TEST_F(DepthRangeTest, HistogramOfAnAnalyticGroundPlane) {
  constexpr std::uint32_t kW = 333, kH = 187;  // not multiples of the 16x16 tile
  const AnalyticDepth scene = groundPlane(kW, kH, 6.0, -12.0, 60.0, 0.1, 800.0);
  csm::vk::DepthProjection proj = scene.projection;
  proj.histogramNearM = 0.5f;
  proj.histogramFarM = 400.0f;  // the ground reaches ~585 m: the last bin holds the rest

  // Expected counts: every ground pixel binned by its view depth as the shader computes it
  // (float formula from the uploaded value); a pixel within 1e-3 of a bin edge may land in
  // either bin (the shader's float log), so each bin gets a [sure, possible] interval.
  const double binsPerLog = csm::kDepthHistogramBins / std::log(400.0 / 0.5);
  std::vector<std::uint32_t> sure(csm::kDepthHistogramBins), possible(csm::kDepthHistogramBins);
  std::vector<std::uint32_t> analytic(csm::kDepthHistogramBins);
  std::uint64_t ground = 0;
  for (std::size_t i = 0; i < scene.depth.size(); ++i) {
    if (scene.depth[i] == 1.0f) continue;
    ++ground;
    const float d = proj.p32 / (scene.depth[i] + proj.p22);
    const double u = std::log(double(d) / 0.5) * binsPerLog;
    const std::uint32_t b = csm::depthHistogramBin(0.5, 400.0, csm::kDepthHistogramBins, d);
    const std::uint32_t lo = csm::depthHistogramBin(0.5, 400.0, csm::kDepthHistogramBins,
                                                    0.5 * std::exp((u - 1e-3) / binsPerLog));
    const std::uint32_t hi = csm::depthHistogramBin(0.5, 400.0, csm::kDepthHistogramBins,
                                                    0.5 * std::exp((u + 1e-3) / binsPerLog));
    if (lo == hi) ++sure[b];
    for (std::uint32_t k = lo; k <= hi; ++k) ++possible[k];
    ++analytic[csm::depthHistogramBin(0.5, 400.0, csm::kDepthHistogramBins, scene.depthM[i])];
  }
  ASSERT_GT(ground, 20000u);

  const engine::Image depth = uploadDepth(scene, kW, kH);
  csm::vk::Status status;
  auto reducer = csm::vk::DepthRangeReducer::create(glue::shadowDeviceInfo(ctx()), 2, &status);
  ASSERT_TRUE(reducer) << status.message();
  ctx().submitAndWait([&](VkCommandBuffer cmd) {
    ASSERT_TRUE(
        reducer
            ->record(cmd, depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, {kW, kH}, proj, 0)
            .ok());
    // Slot 1 without a histogram range: a range with no histogram.
    ASSERT_TRUE(reducer
                    ->record(cmd, depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, {kW, kH},
                             scene.projection, 1)
                    .ok());
  });
  const auto range = reducer->read(0);
  ASSERT_TRUE(range.has_value());
  ASSERT_TRUE(range->histogram.present());
  EXPECT_EQ(range->histogram.nearM, 0.5);
  EXPECT_EQ(range->histogram.farM, 400.0);
  std::uint64_t total = 0, occupied = 0, differAnalytic = 0;
  for (std::uint32_t b = 0; b < csm::kDepthHistogramBins; ++b) {
    const std::uint32_t got = range->histogram.counts[b];
    total += got;
    occupied += got > 0 ? 1 : 0;
    EXPECT_GE(got, sure[b]) << "bin " << b;
    EXPECT_LE(got, possible[b]) << "bin " << b;
    differAnalytic += got > analytic[b] ? got - analytic[b] : analytic[b] - got;
  }
  EXPECT_EQ(total, ground);  // every ground pixel counted once, sky never
  // A row of the view sees one view depth (x does not change it): every bin holds whole rows
  // (83 of the bins are occupied by the 180-odd ground rows).
  for (std::uint32_t b = 0; b < csm::kDepthHistogramBins; ++b) {
    EXPECT_EQ(range->histogram.counts[b] % kW, 0u) << "bin " << b;
  }
  EXPECT_GT(occupied, 60u);
  EXPECT_GE(range->histogram.counts[csm::kDepthHistogramBins - 1], kW);  // beyond 400 m
  // Against the analytic depths (double): only pixels the depth buffer's precision moves
  // across a bin edge differ.
  EXPECT_LT(differAnalytic, ground / 100) << differAnalytic << " of " << ground;
  std::printf(
      "histogram: %llu ground pixels in %llu bins, %llu bin moves against the analytic "
      "depths\n",
      (unsigned long long)total, (unsigned long long)occupied, (unsigned long long)differAnalytic);
  const auto plain = reducer->read(1);
  ASSERT_TRUE(plain.has_value());
  EXPECT_FALSE(plain->histogram.present());

  // The histogram drives the splits.
  csm::ShadowSettings s;
  s.receiverSplitScheme = csm::ReceiverSplitScheme::kHistogram;
  csm::Camera cam;
  cam.farM = 800.0;
  auto f = csm::computeCascades(s, cam, csm::DirectionalLight{}, nullptr, nullptr, &*range);
  ASSERT_TRUE(f.ok());
  EXPECT_TRUE(f.value().histogramDriven);
  auto g = csm::computeCascades(s, cam, csm::DirectionalLight{}, nullptr, nullptr, &*plain);
  ASSERT_TRUE(g.ok());
  EXPECT_FALSE(g.value().histogramDriven);

  // A bad histogram range is refused by name.
  ctx().submitAndWait([&](VkCommandBuffer cmd) {
    csm::vk::DepthProjection bad = proj;
    bad.histogramFarM = 0.25f;
    const csm::vk::Status st = reducer->record(
        cmd, depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, {kW, kH}, bad, 0);
    EXPECT_EQ(st.code(), csm::vk::ErrorCode::kInvalidArgument);
    EXPECT_NE(st.message().find("histogramFarM = 0.25"), std::string::npos) << st.message();
  });
  reducer.reset();
}

}  // namespace

namespace {

// The receivers' light-space bounds per cascade from the reduction, against the same pixels
// reconstructed on the CPU in double (binned by the shader's float view depth, so only the
// float arithmetic differs), far from the origin; then the bounds drive the boxes.
TEST_F(DepthRangeTest, LightSpaceBoundsOfAnAnalyticGroundPlane) {
  constexpr std::uint32_t kW = 333, kH = 187;
  const GroundView view = groundView(kW, kH);
  const auto& [scene, proj, cam, tanY, aspect] = view;

  csm::ShadowSettings s;
  s.shadowDistanceM = 1200.0;  // the far ground is beyond the last cascade
  const csm::DirectionalLight light{glm::dvec3(0.45, -0.8, -0.35)};
  auto f = csm::computeCascades(s, cam, light);
  ASSERT_TRUE(f.ok());
  const csm::CascadeFrame& frame = f.value();

  // The CPU truth: each ground pixel at the shader's float view depth.
  const glm::dmat3 rot = glm::mat3_cast(cam.orientationWs);
  std::vector<glm::dvec3> pts;
  for (std::uint32_t y = 0; y < kH; ++y) {
    for (std::uint32_t x = 0; x < kW; ++x) {
      const float z = scene.depth[std::size_t(y) * kW + x];
      if (z == 1.0f) continue;
      const double d = double(proj.p32 / (z + proj.p22));
      const double vx = (2.0 * (x + 0.5) / kW - 1.0) * tanY * aspect;
      const double vy = -(2.0 * (y + 0.5) / kH - 1.0) * tanY;
      pts.push_back(cam.positionWs + rot * (glm::dvec3(vx, vy, -1.0) * d));
    }
  }
  const csm::ReceiverLightBounds truth = csm::receiverLightBounds(frame, cam, pts);

  const engine::Image depth = uploadDepth(scene, kW, kH);
  csm::vk::Status status;
  auto reducer = csm::vk::DepthRangeReducer::create(glue::shadowDeviceInfo(ctx()), 2, &status);
  ASSERT_TRUE(reducer) << status.message();
  ctx().submitAndWait([&](VkCommandBuffer cmd) {
    ASSERT_TRUE(reducer
                    ->record(cmd, depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, {kW, kH},
                             proj, 0, {&frame, &cam})
                    .ok());
    // Without bounds inputs: no bounds.
    ASSERT_TRUE(
        reducer
            ->record(cmd, depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, {kW, kH}, proj, 1)
            .ok());
  });
  const auto range = reducer->read(0);
  ASSERT_TRUE(range.has_value());
  EXPECT_FALSE(reducer->read(1)->lightBounds.present());
  const csm::ReceiverLightBounds& b = range->lightBounds;
  ASSERT_TRUE(b.present());
  ASSERT_EQ(b.cascadeCount, frame.cascadeCount);
  EXPECT_EQ(b.splitsM, frame.splitsM);
  EXPECT_EQ(b.lightBasisWs, frame.lightBasisWs);
  EXPECT_EQ(b.cameraPositionWs, cam.positionWs);
  int withReceivers = 0;
  for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
    ASSERT_EQ(b.hasReceivers(i), truth.hasReceivers(i)) << "cascade " << i;
    if (!truth.hasReceivers(i)) continue;
    ++withReceivers;
    // Float light-space positions relative to the camera: within 2e-6 of the view depth.
    const double tol = 2e-6 * frame.splitsM[i + 1] + 1e-5;
    for (int a = 0; a < 2; ++a) {
      EXPECT_NEAR(b.minLs[i][a], truth.minLs[i][a], tol) << "cascade " << i << " axis " << a;
      EXPECT_NEAR(b.maxLs[i][a], truth.maxLs[i][a], tol) << "cascade " << i << " axis " << a;
    }
    std::printf(
        "cascade %u: x [%.3f, %.3f] (truth [%.3f, %.3f]), y [%.3f, %.3f] m about the "
        "camera\n",
        i, b.minLs[i].x - glm::dot(b.lightBasisWs[0], cam.positionWs),
        b.maxLs[i].x - glm::dot(b.lightBasisWs[0], cam.positionWs),
        truth.minLs[i].x - glm::dot(b.lightBasisWs[0], cam.positionWs),
        truth.maxLs[i].x - glm::dot(b.lightBasisWs[0], cam.positionWs),
        b.minLs[i].y - glm::dot(b.lightBasisWs[1], cam.positionWs),
        b.maxLs[i].y - glm::dot(b.lightBasisWs[1], cam.positionWs));
  }
  EXPECT_GE(withReceivers, 2);

  // The bounds drive the boxes of the next frame: bounds taken by the GPU with the splits of a
  // receiver-driven frame (h0) fitted to this range, then used with the same range (h1).
  csm::ReceiverDepthRange withBounds = *range;
  withBounds.lightBounds = csm::ReceiverLightBounds{};
  auto h0 = csm::computeCascades(s, cam, light, nullptr, nullptr, &withBounds);
  ASSERT_TRUE(h0.ok());
  // Bounds taken with h0's splits, by the GPU, then used.
  ctx().submitAndWait([&](VkCommandBuffer cmd) {
    ASSERT_TRUE(reducer
                    ->record(cmd, depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, {kW, kH},
                             proj, 0, {&h0.value(), &cam})
                    .ok());
  });
  auto r2 = reducer->read(0);
  ASSERT_TRUE(r2.has_value());
  r2->minM = withBounds.minM;  // the same range as h0 (the GPU's is the same pixels' anyway)
  r2->maxM = withBounds.maxM;
  auto h1 = csm::computeCascades(s, cam, light, nullptr, nullptr, &*r2);
  ASSERT_TRUE(h1.ok());
  ASSERT_EQ(h1.value().splitsM, h0.value().splitsM);
  int fitted = 0;
  for (std::uint32_t i = 0; i < s.cascadeCount; ++i) {
    const csm::Cascade& c = h1.value().cascades[i];
    EXPECT_LE(c.halfExtentLs.x, h0.value().cascades[i].halfExtentLs.x);
    fitted += c.receiverFit ? 1 : 0;
  }
  EXPECT_GT(fitted, 0);
  for (const glm::dvec3& p : pts) {
    const double d = glm::dot(p - cam.positionWs, h1.value().cameraForwardWs);
    for (std::uint32_t i = 0; i < s.cascadeCount; ++i) {
      if (!(d >= h1.value().splitsM[i] && d < h1.value().splitsM[i + 1])) continue;
      const csm::Cascade& c = h1.value().cascades[i];
      const glm::dvec3 q = csm::toLightSpace(h1.value().lightBasisWs, c.boxCenterWs, p);
      EXPECT_LE(std::abs(q.x), c.halfExtentLs.x);
      EXPECT_LE(std::abs(q.y), c.halfExtentLs.y);
    }
  }
  std::printf("receiver-fitted cascades: %d of %u\n", fitted, s.cascadeCount);
}

// Receiver-marked tiles (ReceiverBoundsInputs::tiles): the GPU's marks of the analytic ground
// plane 3e6, 7e6 m from the origin against csm::markTileRect in double over the same 16x16
// pixel blocks, for several filters. Float positions about the camera round differently from double
// ones, so the GPU's marks must lie between the CPU's with the reach shrunk and grown by the float
// error (and depths near a split or band start, where float may choose the other cascade, only in
// the grown set); any tile missed or marked without a receiver near it fails.
TEST_F(DepthRangeTest, TilesTheReceiversSampleMatchTheCpuMarks) {
  constexpr std::uint32_t kW = 333, kH = 187;
  const GroundView view = groundView(kW, kH);
  const auto& [scene, proj, cam, tanY, aspect] = view;
  const csm::DirectionalLight light{glm::dvec3(0.45, -0.8, -0.35)};

  const engine::Image depth = uploadDepth(scene, kW, kH);
  csm::vk::Status status;
  auto reducer = csm::vk::DepthRangeReducer::create(glue::shadowDeviceInfo(ctx()), 2, &status);
  ASSERT_TRUE(reducer) << status.message();

  struct Case {
    const char* name;
    csm::PcfKernel kernel;
    bool worldSpaceKernel;
    std::uint32_t resolution;
  };
  const Case cases[] = {{"tent3x3", csm::PcfKernel::kTent3, false, 1024},
                        {"tent7x7 world-space", csm::PcfKernel::kTent7, true, 2048},
                        {"pcss", csm::PcfKernel::kPcss, false, 1024},
                        {"msm", csm::PcfKernel::kMsm, false, 512}};
  const glm::dmat3 rot = glm::mat3_cast(cam.orientationWs);
  for (const Case& k : cases) {
    SCOPED_TRACE(k.name);
    csm::ShadowSettings s;
    s.shadowDistanceM = 1200.0;
    s.kernel = k.kernel;
    s.worldSpaceKernel = k.worldSpaceKernel;
    s.resolution = k.resolution;
    auto f = csm::computeCascades(s, cam, light);
    ASSERT_TRUE(f.ok());
    const csm::CascadeFrame& frame = f.value();
    ctx().submitAndWait([&](VkCommandBuffer cmd) {
      ASSERT_TRUE(reducer
                      ->record(cmd, depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                               {kW, kH}, proj, 0, {&frame, &cam, &s})
                      .ok());
      ASSERT_TRUE(reducer
                      ->record(cmd, depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                               {kW, kH}, proj, 1, {&frame, &cam})
                      .ok());
    });
    const auto range = reducer->read(0);
    ASSERT_TRUE(range.has_value());
    EXPECT_FALSE(reducer->read(1)->tiles.present());  // not asked for
    const csm::ReceiverTileMarks& gpu = range->tiles;
    ASSERT_TRUE(gpu.present());
    ASSERT_EQ(gpu.cascadeCount, frame.cascadeCount);

    csm::ReceiverTileMarks inner = csm::emptyReceiverTileMarks(s, frame);
    csm::ReceiverTileMarks outer = inner;
    for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
      const double eps = 4e-6 * frame.splitsM[i + 1] + 1e-4;
      inner.reachM[i] = std::max(inner.reachM[i] - eps, 0.0);
      outer.reachM[i] += eps;
    }
    // The GPU marks per 16x16 block of pixels: the rectangle of the block's receivers per
    // cascade. The same blocks here, in double.
    const glm::dmat3 basisT = glm::transpose(frame.lightBasisWs);
    constexpr double kInf = std::numeric_limits<double>::infinity();
    for (std::uint32_t by = 0; by < kH; by += 16) {
      for (std::uint32_t bx = 0; bx < kW; bx += 16) {
        // [0]: the receivers a cascade shades, [1]: those of the blend band before it (the GPU
        // keeps the two rectangles apart).
        std::array<std::array<glm::dvec2, csm::kMaxCascades>, 2> inLo, inHi, outLo, outHi;
        for (int k = 0; k < 2; ++k) {
          inLo[k].fill(glm::dvec2(kInf));
          inHi[k].fill(glm::dvec2(-kInf));
        }
        outLo = inLo;
        outHi = inHi;
        auto grow = [](glm::dvec2& lo, glm::dvec2& hi, const glm::dvec2& v) {
          lo = glm::min(lo, v);
          hi = glm::max(hi, v);
        };
        for (std::uint32_t y = by; y < std::min(by + 16, kH); ++y) {
          for (std::uint32_t x = bx; x < std::min(bx + 16, kW); ++x) {
            const float z = scene.depth[std::size_t(y) * kW + x];
            if (z == 1.0f) continue;
            const double d = double(proj.p32 / (z + proj.p22));
            const double vx = (2.0 * (x + 0.5) / kW - 1.0) * tanY * aspect;
            const double vy = -(2.0 * (y + 0.5) / kH - 1.0) * tanY;
            const glm::dvec3 p = cam.positionWs + rot * (glm::dvec3(vx, vy, -1.0) * d);
            const glm::dvec3 q = basisT * p;
            const glm::dvec2 ls(q.x, q.y);
            // Depths within float error of a split or band start may go either way on the GPU:
            // both ways in the outer set, neither in the inner one.
            const double dd = 1e-6 * d;
            bool nearBoundary = false;
            for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
              nearBoundary = nearBoundary || std::abs(d - frame.splitsM[i + 1]) <= dd ||
                             std::abs(d - inner.blendStartM[i]) <= dd;
            }
            for (double e : {-dd, 0.0, dd}) {
              const auto [c, next] = csm::shadingCascades(outer, d + e);
              const auto ci = std::size_t(c), ni = std::size_t(next);
              if (c >= 0) grow(outLo[0][ci], outHi[0][ci], ls);
              if (next >= 0) grow(outLo[1][ni], outHi[1][ni], ls);
              if (e != 0.0 || nearBoundary) continue;
              if (c >= 0) grow(inLo[0][ci], inHi[0][ci], ls);
              if (next >= 0) grow(inLo[1][ni], inHi[1][ni], ls);
            }
          }
        }
        for (int k = 0; k < 2; ++k) {
          for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
            if (inLo[k][i].x <= inHi[k][i].x) csm::markTileRect(inner, i, inLo[k][i], inHi[k][i]);
            if (outLo[k][i].x <= outHi[k][i].x) {
              csm::markTileRect(outer, i, outLo[k][i], outHi[k][i]);
            }
          }
        }
      }
    }
    int partial = 0;
    for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
      for (std::uint32_t ty = 0; ty < csm::kTileGridSide; ++ty) {
        for (std::uint32_t tx = 0; tx < csm::kTileGridSide; ++tx) {
          if (inner.marked(i, tx, ty)) {
            EXPECT_TRUE(gpu.marked(i, tx, ty))
                << "missed: cascade " << i << " tile " << tx << "," << ty;
          }
          if (gpu.marked(i, tx, ty)) {
            EXPECT_TRUE(outer.marked(i, tx, ty))
                << "no receiver near: cascade " << i << " tile " << tx << "," << ty;
          }
        }
      }
      const std::uint32_t n = gpu.markedCount(i);
      partial += (n > 0 && n < csm::kTileGridSide * csm::kTileGridSide) ? 1 : 0;
      std::printf("%s cascade %u: %u of %u tiles marked (cpu %u..%u), reach %.3f m\n", k.name, i, n,
                  csm::kTileGridSide * csm::kTileGridSide, inner.markedCount(i),
                  outer.markedCount(i), gpu.reachM[i]);
    }
    EXPECT_GE(partial, 2);  // a ground plane seen at a grazing angle marks part of each grid
  }

  // Tiles need the frame they are marked on.
  csm::ShadowSettings s;
  ctx().submitAndWait([&](VkCommandBuffer cmd) {
    const csm::vk::Status refused =
        reducer->record(cmd, depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, {kW, kH}, proj,
                        0, {nullptr, nullptr, &s});
    EXPECT_FALSE(refused.ok());
    EXPECT_NE(refused.message().find("bounds.tiles"), std::string::npos) << refused.message();
  });
}

// The receiver fit as one switch of the view (RendererOptions::receiverFit): the host hands
// ShadowView::recordReceiverDepth its depth buffer and projection once a frame; the view keeps
// a slot per frame in flight, reads each slot when it fills it again, and the next compute()
// fits the splits and boxes to that range. Checked against a DepthRangeReducer driven by hand
// over the same frames, and against computeCascades given the range the view reports.
TEST_F(DepthRangeTest, ViewReceiverFitIsOneSwitchAndMatchesTheReducerByHand) {
  constexpr std::uint32_t kW = 333, kH = 187;
  const double fovDeg = 30.0, pitchDeg = -8.0, heightM = 20.0, nearM = 0.5, farM = 1500.0;
  const AnalyticDepth scene = groundPlane(kW, kH, heightM, pitchDeg, fovDeg, nearM, farM);
  const double aspect = double(kW) / kH;
  // The host's projection: Vulkan clip space, row 0 at the top (+y up: P[1][1] < 0).
  glm::mat4 projection(glm::perspectiveRH_ZO(glm::radians(fovDeg), aspect, nearM, farM));
  projection[1][1] = -projection[1][1];
  csm::vk::DepthProjection byHand = scene.projection;  // as the view must derive it
  byHand.p00 = projection[0][0];
  byHand.p11 = projection[1][1];
  ASSERT_EQ(byHand.p22, projection[2][2]);
  ASSERT_EQ(byHand.p32, projection[3][2]);

  const csm::Camera cam = yawedCamera(heightM, pitchDeg, fovDeg, aspect, nearM, farM);
  csm::ShadowSettings s;
  s.shadowDistanceM = 1200.0;
  byHand.histogramNearM = float(nearM);
  byHand.histogramFarM = float(s.shadowDistanceM);
  const csm::DirectionalLight light{glm::dvec3(0.45, -0.8, -0.35)};

  const engine::Image depth = uploadDepth(scene, kW, kH);
  const csm::vk::ReceiverDepthInput input{
      depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, {kW, kH}, projection};

  auto [view, reducer, slots] = makeViewAndReducer();
  ASSERT_TRUE(view && reducer);

  // Off (the default): refused by name, nothing recorded.
  ASSERT_TRUE(view->setSettings(s).ok());
  ctx().submitAndWait([&](VkCommandBuffer cmd) {
    ASSERT_TRUE(view->record(cmd, cam, light).ok());
    const csm::vk::Status off = view->recordReceiverDepth(cmd, input);
    EXPECT_EQ(off.code(), csm::vk::ErrorCode::kWrongOrder);
    EXPECT_NE(off.message().find("receiverFit = kOff"), std::string::npos) << off.message();
  });

  csm::vk::RendererOptions options = view->options();
  options.receiverFit = csm::vk::ReceiverFit::kSplitsAndBoxes;
  ASSERT_TRUE(view->setSettings(s, options).ok());
  EXPECT_EQ(view->options().receiverFit, csm::vk::ReceiverFit::kSplitsAndBoxes);
  // The same frames by hand: the history, and the range each frame's compute is given.
  csm::CascadeHistory history;
  std::optional<csm::ReceiverDepthRange> handRange;
  std::vector<std::optional<csm::ReceiverDepthRange>> recorded;  // by hand, per frame
  int fittedFrames = 0;
  // (The first frame with the fit on recomputes the history the view's earlier frame left.)
  ASSERT_TRUE(view->computeFrame(cam, light).ok());
  {
    csm::CascadeHistory h0;
    ASSERT_TRUE(csm::computeCascades(s, cam, light, nullptr, &h0).ok());
    history = h0;
  }
  for (std::uint32_t k = 0; k < 3 * slots; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    ASSERT_EQ(view->receiverDepthRange().has_value(), handRange.has_value());
    auto expected =
        csm::computeCascades(s, cam, light, nullptr, &history, handRange ? &*handRange : nullptr);
    ASSERT_TRUE(expected.ok());
    ctx().submitAndWait([&](VkCommandBuffer cmd) {
      ASSERT_TRUE(view->record(cmd, cam, light).ok());
      ASSERT_TRUE(view->recordReceiverDepth(cmd, input).ok());
      const std::uint32_t slot = k % slots;
      // By hand: read the slot this frame fills (its frame has completed), then fill it.
      handRange = reducer->read(slot);
      ASSERT_TRUE(reducer
                      ->record(cmd, depth.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                               {kW, kH}, byHand, slot, {&view->frame(), &cam})
                      .ok());
    });
    // The view's frame is what computeCascades makes of the same history and range.
    const csm::CascadeFrame& got = view->frame();
    EXPECT_EQ(got.splitsM, expected.value().splitsM);
    for (std::uint32_t i = 0; i < s.cascadeCount; ++i) {
      EXPECT_EQ(got.cascades[i].halfExtentLs, expected.value().cascades[i].halfExtentLs);
      EXPECT_EQ(got.cascades[i].receiverFit, expected.value().cascades[i].receiverFit);
    }
    if (got.cascades[0].receiverFit) ++fittedFrames;
    // The view's range for the next frame is the hand reducer's, field for field.
    const auto& r = view->receiverDepthRange();
    ASSERT_EQ(r.has_value(), handRange.has_value());
    ASSERT_EQ(r.has_value(), k >= slots);  // a slot's first result is read when it is refilled
    if (r) {
      EXPECT_EQ(r->minM, double(scene.minF));
      EXPECT_EQ(r->maxM, double(scene.maxF));
      EXPECT_EQ(r->minM, handRange->minM);
      EXPECT_EQ(r->maxM, handRange->maxM);
      EXPECT_EQ(r->histogram.counts, handRange->histogram.counts);
      EXPECT_TRUE(r->histogram.present());
      ASSERT_TRUE(r->lightBounds.present());
      EXPECT_EQ(r->lightBounds.splitsM, handRange->lightBounds.splitsM);
      EXPECT_EQ(r->lightBounds.minLs, handRange->lightBounds.minLs);
      EXPECT_EQ(r->lightBounds.maxLs, handRange->lightBounds.maxLs);
    }
  }
  // The frames after the first result fit the receivers: the first split near the nearest one.
  EXPECT_GE(fittedFrames, 1);
  EXPECT_GT(view->frame().splitsM[0], 0.5 * scene.minM);
  EXPECT_LE(view->frame().splitsM[0], scene.minM);

  // A camera cut: the range is gone, the next frame covers the full range from the near plane,
  // and the slots recorded before the cut give nothing.
  view->cameraCut();
  EXPECT_FALSE(view->receiverDepthRange().has_value());
  for (std::uint32_t k = 0; k < slots; ++k) {
    ctx().submitAndWait([&](VkCommandBuffer cmd) {
      ASSERT_TRUE(view->record(cmd, cam, light).ok());
      ASSERT_TRUE(view->recordReceiverDepth(cmd, input).ok());
    });
    EXPECT_EQ(view->frame().splitsM[0], nearM);
    EXPECT_FALSE(view->receiverDepthRange().has_value()) << "frame " << k << " after the cut";
  }
  ctx().submitAndWait([&](VkCommandBuffer cmd) {
    ASSERT_TRUE(view->record(cmd, cam, light).ok());
    ASSERT_TRUE(view->recordReceiverDepth(cmd, input).ok());
  });
  EXPECT_TRUE(view->receiverDepthRange().has_value());

  // Splits only: the range carries no light bounds.
  options.receiverFit = csm::vk::ReceiverFit::kSplits;
  ASSERT_TRUE(view->setSettings(s, options).ok());
  EXPECT_FALSE(view->receiverDepthRange().has_value());  // a change of the fit drops the range
  for (std::uint32_t k = 0; k <= slots; ++k) {
    ctx().submitAndWait([&](VkCommandBuffer cmd) {
      ASSERT_TRUE(view->record(cmd, cam, light).ok());
      ASSERT_TRUE(view->recordReceiverDepth(cmd, input).ok());
    });
  }
  ASSERT_TRUE(view->receiverDepthRange().has_value());
  EXPECT_FALSE(view->receiverDepthRange()->lightBounds.present());
  EXPECT_EQ(view->receiverDepthRange()->minM, double(scene.minF));

  // Bad input is refused by name and records nothing; a frame recorded without its camera
  // cannot give the boxes' bounds.
  options.receiverFit = csm::vk::ReceiverFit::kSplitsAndBoxes;
  ASSERT_TRUE(view->setSettings(s, options).ok());
  ctx().submitAndWait([&](VkCommandBuffer cmd) {
    ASSERT_TRUE(view->record(cmd, cam, light).ok());
    csm::vk::ReceiverDepthInput bad = input;
    bad.extent = {0, kH};
    EXPECT_EQ(view->recordReceiverDepth(cmd, bad).code(), csm::vk::ErrorCode::kInvalidArgument);
    bad = input;
    bad.layout = VK_IMAGE_LAYOUT_GENERAL;
    EXPECT_EQ(view->recordReceiverDepth(cmd, bad).code(), csm::vk::ErrorCode::kInvalidArgument);
    bad = input;
    bad.projection[3][2] = std::numeric_limits<float>::quiet_NaN();
    const csm::vk::Status nan = view->recordReceiverDepth(cmd, bad);
    EXPECT_EQ(nan.code(), csm::vk::ErrorCode::kInvalidArgument);
    EXPECT_NE(nan.message().find("p32"), std::string::npos) << nan.message();
    auto frame = view->computeFrame(cam, light);
    ASSERT_TRUE(frame.ok());
    ASSERT_TRUE(view->record(cmd, frame.value()).ok());
    const csm::vk::Status noCamera = view->recordReceiverDepth(cmd, input);
    EXPECT_EQ(noCamera.code(), csm::vk::ErrorCode::kWrongOrder);
    EXPECT_NE(noCamera.message().find("camera"), std::string::npos) << noCamera.message();
  });
  view.reset();
  reducer.reset();
}

// The receiver-marked tiles through the view (RendererOptions::tiles with the cache, the fit
// off): recordReceiverDepth marks the tiles each frame, and the frames after a result draw what
// it marked: each partial cascade's marks in the cache plan are the same tiles a reducer by hand
// marks from the same depth buffer, frame and settings. The fit stays off: the splits cover the
// full range and no receiver range is kept.
TEST_F(DepthRangeTest, ViewTilesAreOneSwitchAndTakeTheReducersMarks) {
  constexpr std::uint32_t kW = 333, kH = 187;
  const std::unique_ptr<TileView> t = tileView(kW, kH);
  [[maybe_unused]] const auto& [g, projection, light, s, depth, input] = *t;

  auto [view, reducer, slots] = makeViewAndReducer();
  ASSERT_TRUE(view && reducer);
  csm::vk::RendererOptions options;
  options.cache = true;
  options.tiles = true;
  ASSERT_TRUE(view->setSettings(s, options).ok());
  // Tiles with a prefiltered filter, or without the cache: refused by name.
  {
    csm::ShadowSettings msm = s;
    msm.kernel = csm::PcfKernel::kMsm;
    const csm::vk::Status bad = view->setSettings(msm, options);
    EXPECT_EQ(bad.code(), csm::vk::ErrorCode::kInvalidArgument);
    EXPECT_NE(bad.message().find("options.tiles"), std::string::npos) << bad.message();
    csm::vk::RendererOptions noCache = options;
    noCache.cache = false;
    const csm::vk::Status bad2 = view->setSettings(s, noCache);
    EXPECT_NE(bad2.message().find("options.cache"), std::string::npos) << bad2.message();
    EXPECT_TRUE(view->options().tiles);  // refused: nothing changed
  }
  auto full = csm::computeCascades(s, g.cam, light);
  ASSERT_TRUE(full.ok());
  std::optional<csm::ReceiverDepthRange> hand;  // read by hand the frame before
  std::uint32_t comparedCascades = 0, markedTiles = 0;
  for (std::uint32_t k = 0; k < 3 * slots; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    ctx().submitAndWait([&](VkCommandBuffer cmd) {
      ASSERT_TRUE(view->record(cmd, g.cam, light).ok());
      ASSERT_TRUE(view->recordReceiverDepth(cmd, input).ok());
      const csm::CachePlan& plan = view->renderer().cachePlan();
      const csm::CascadeFrame& f = view->frame();
      // What the view can sample of cascade i from view depth nearM on (csm::markFrustumTiles).
      auto viewTiles = [&](std::uint32_t i, double nearM) {
        csm::TileMask m;
        m.origin = plan.cascades[i].marked.origin;
        const double texel = f.cascades[i].texelSizeLs.x;
        EXPECT_TRUE(csm::markFrustumTiles(f, nearM, f.splitsM[i + 1], plan.cascades[i].basis, texel,
                                          s.resolution / csm::kTilesPerSide,
                                          csm::receiverSampleReachTexels(s, f, i) * texel, m));
        return m;
      };
      const std::uint32_t last = plan.cascadeCount - 1;
      if (k == 0) {
        // The view's first frame, without marks: every cascade whole (nothing falls back).
        for (std::uint32_t i = 0; i <= last; ++i) {
          EXPECT_FALSE(plan.cascades[i].partial) << "cascade " << i;
          EXPECT_TRUE(plan.cascades[i].full) << "cascade " << i;
        }
      } else {
        ASSERT_TRUE(plan.cascades[last].partial)
            << "the last cascade: drawn where the view samples";
        EXPECT_EQ(plan.cascades[last].marked, viewTiles(last, f.splitsM[0]));
      }
      for (std::uint32_t i = 0; i < last; ++i) {
        const csm::CacheCascadePlan& p = plan.cascades[i];
        if (!p.partial) continue;
        const csm::TileMask sampled = viewTiles(i, csm::cascadeReadFromM(f, i, f.blendBand));
        if (!hand || !hand->tiles.present()) {
          // After the first frame (whole), the frames without marks draw what the view samples.
          EXPECT_EQ(p.marked, sampled) << "cascade " << i << ": marks before any result";
          continue;
        }
        // The same frame every time: the same grid, the same tiles (where the view samples).
        ASSERT_EQ(p.marked.origin, hand->tiles.gridOrigin[i]) << "cascade " << i;
        for (std::uint32_t w = 0; w < csm::kTileWords; ++w) {
          EXPECT_EQ(p.marked.bits[w], hand->tiles.bits[i][w] & sampled.bits[w])
              << "cascade " << i << " word " << w;
        }
        markedTiles += p.marked.count();
        ++comparedCascades;
      }
      const std::uint32_t slot = k % slots;
      hand = reducer->read(slot);
      ASSERT_TRUE(reducer
                      ->record(cmd, depth->view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                               {kW, kH}, g.proj, slot, {&view->frame(), &g.cam, &s})
                      .ok());
    });
    EXPECT_EQ(view->frame().splitsM, full.value().splitsM) << "the fit is off";
    EXPECT_FALSE(view->receiverDepthRange().has_value());
  }
  EXPECT_GT(comparedCascades, 0u);
  EXPECT_GT(markedTiles, 0u);
  // What the partial cascades hold: every tile marked (drawn), and those the view's tiles drew
  // while no marks had arrived yet (nothing in them went stale since).
  std::uint32_t held = 0;
  const csm::CachePlan& plan = view->renderer().cachePlan();
  for (std::uint32_t i = 0; i + 1 < plan.cascadeCount; ++i) {
    const csm::CacheCascadePlan& p = plan.cascades[i];
    if (p.active && p.partial) {
      for (std::uint32_t w = 0; w < csm::kTileWords; ++w) {
        EXPECT_EQ(p.marked.bits[w] & ~p.tiles.bits[w], 0u) << i << " word " << w;
      }
      held += p.tiles.count();
    }
  }
  EXPECT_GT(held, 0u);
  view.reset();
  reducer.reset();
}

// After a cut the host may wait for the cut's frame and take its reduction at once
// (ShadowView::useLatestReceiverDepth): the next frame's partial cascades then draw that frame's
// marks instead of what the frustum can sample, and the reads of the older slots that follow do
// not replace them. Refused by name with the fit and the tiles off; after a cut with nothing
// recorded since, it changes nothing.
TEST_F(DepthRangeTest, ViewTakesTheLatestMarksAtOnceAfterACut) {
  constexpr std::uint32_t kW = 333, kH = 187;
  const std::unique_ptr<TileView> t = tileView(kW, kH);
  [[maybe_unused]] const auto& [g, projection, light, s, depth, input] = *t;
  auto [view, reducer, slots] = makeViewAndReducer();
  ASSERT_TRUE(view && reducer);
  ASSERT_GE(slots, 2u);
  ASSERT_TRUE(view->setSettings(s).ok());
  const csm::vk::Status off = view->useLatestReceiverDepth();
  EXPECT_EQ(off.code(), csm::vk::ErrorCode::kWrongOrder);
  EXPECT_NE(off.message().find("options.tiles = false"), std::string::npos) << off.message();
  csm::vk::RendererOptions options;
  options.cache = true;
  options.tiles = true;
  ASSERT_TRUE(view->setSettings(s, options).ok());

  // The marks a reducer by hand takes of the same depth buffer, frame and settings.
  std::optional<csm::ReceiverDepthRange> hand;
  // `whole`: the view's first frame without marks draws every cascade whole.
  auto partialMarks = [&](bool expectMarks, bool whole = false) {
    const csm::CachePlan& plan = view->renderer().cachePlan();
    std::uint32_t partial = 0, marked = 0;
    for (std::uint32_t i = 0; i + 1 < plan.cascadeCount; ++i) {
      const csm::CacheCascadePlan& p = plan.cascades[i];
      if (!p.partial) continue;
      ++partial;
      if (!expectMarks) {
        EXPECT_EQ(p.marked.count(), 0u) << "cascade " << i;
        continue;
      }
      EXPECT_TRUE(hand && hand->tiles.present());
      if (!hand || !hand->tiles.present()) continue;
      marked += p.marked.count();
      for (std::uint32_t w = 0; w < csm::kTileWords; ++w) {
        // Where the frustum can sample them (a superset here: the same view).
        EXPECT_EQ(p.marked.bits[w] & ~hand->tiles.bits[i][w], 0u) << "cascade " << i;
      }
    }
    EXPECT_EQ(partial > 0u, !whole);
    if (expectMarks) {
      EXPECT_GT(marked, 0u);
    }
  };
  for (int round = 0; round < 2; ++round) {
    SCOPED_TRACE(round == 0 ? "the start" : "after a cut");
    if (round == 1) {
      view->cameraCut();
      // Nothing recorded since the cut: nothing to take.
      ASSERT_TRUE(view->useLatestReceiverDepth().ok());
    }
    // The cut's frame: no marks, its partial cascades fall back (at the start: every cascade
    // whole); its reduction recorded.
    ctx().submitAndWait([&](VkCommandBuffer cmd) {
      ASSERT_TRUE(view->record(cmd, g.cam, light).ok());
      partialMarks(false, round == 0);
      ASSERT_TRUE(view->recordReceiverDepth(cmd, input).ok());
      ASSERT_TRUE(reducer
                      ->record(cmd, depth->view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                               {kW, kH}, g.proj, 0, {&view->frame(), &g.cam, &s})
                      .ok());
    });
    hand = reducer->read(0);
    // The host waited (submitAndWait): the next frame draws the cut's marks, and so do the
    // frames after it while the reads of the older slots find nothing newer.
    ASSERT_TRUE(view->useLatestReceiverDepth().ok());
    for (std::uint32_t k = 0; k < 2 * slots; ++k) {
      SCOPED_TRACE("frame " + std::to_string(k + 1));
      ctx().submitAndWait([&](VkCommandBuffer cmd) {
        ASSERT_TRUE(view->record(cmd, g.cam, light).ok());
        partialMarks(true);
        ASSERT_TRUE(view->recordReceiverDepth(cmd, input).ok());
      });
      const csm::CachePlan& plan = view->renderer().cachePlan();
      for (std::uint32_t i = 0; i + 1 < plan.cascadeCount; ++i) {
        if (plan.cascades[i].partial && k > 0) {
          EXPECT_EQ(plan.cascades[i].tilesDrawn, 0u) << "cascade " << i << ": held already";
        }
      }
    }
  }
  view.reset();
  reducer.reset();
}

}  // namespace
