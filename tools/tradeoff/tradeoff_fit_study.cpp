// csm_tradeoff --fit-study: box fit and receiver-driven splits on the zoom and forest paths.
#include "tradeoff.hpp"

#include <csm/receiver_bounds.hpp>
#include <csm_measure/harness.hpp>
#include <csm_measure/metrics.hpp>
#include <csm_measure/raytracer.hpp>
#include <csm_measure/scene.hpp>
#include <csm_measure/world_scene.hpp>
#include <sample_world/settings.hpp>
#include <sample_world/world.hpp>

#include "receiver_histogram.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace tradeoff {

// --fit-study: what the tight box and receiver-driven splits buy where the sphere loses (the
// zoom path at 8 degrees) and what they cost where it does not (the forest path at 60 degrees),
// at the fly-through's shadow settings. Per pose and configuration: shadow-pass GPU ms (warm-up,
// fastest of 2, then 3 rounds with the configurations interleaved, fastest kept) and triangles,
// misclassified receiver pixels against Embree, and the texel size of the cascade
// that holds the median receiver depth (the town, on the zoom path). The receiver range is the
// min/max view depth (and the log-spaced histogram, camera near .. shadow distance) of the
// receiver pixels of the pose's full-range frame: what the depth reduction
// (csm::vk::DepthRangeReducer) returns for the frame before.
struct FitConfig {
  const char* name;
  csm::BoxFit fit;
  bool receivers;
  csm::ReceiverSplitScheme scheme = csm::ReceiverSplitScheme::kRange;
  // The boxes fitted to the receivers' light-space bounds too (ReceiverDepthRange::lightBounds).
  bool bounds = false;
};

// The shadow pass of every configuration again, interleaved (3 rounds, fastest kept): the
// machine's load drifts over a sequential run, so the ms are compared within a round.
void retimeInterleaved(csm_measure::Harness& harness, std::span<const FitConfig> configs,
                       const world::AppSettings& app,
                       std::span<const std::optional<csm::ReceiverDepthRange>> ranges,
                       const csm::Camera& cam, const csm::DirectionalLight& light, VkExtent2D view,
                       std::vector<nlohmann::json>& poseRows) {
  for (int round = 0; round < 3; ++round) {
    for (std::size_t k = 0; k < configs.size(); ++k) {
      csm::ShadowSettings s = app.shadow;
      s.boxFit = configs[k].fit;
      s.receiverSplitScheme = configs[k].scheme;
      if (!harness.configure(s).ok()) throw std::runtime_error("configure failed");
      harness.setReceiverRange(ranges[k]);
      csm::CascadeHistory h;
      harness.timeFrame(cam, light, h, view, app.kernel);
      const double ms = harness.timeFrame(cam, light, h, view, app.kernel).shadowGpuMs;
      poseRows[k]["shadow_gpu_ms"] = std::min(poseRows[k]["shadow_gpu_ms"].get<double>(), ms);
    }
  }
}

// One Markdown row of the study's table.
void printFitRow(const char* path, double t, double fovDeg, const nlohmann::json& j) {
  std::printf("| %s | t=%.1f, fov %.0f deg | %s | %.4f | %llu | %llu | %.2f | %llu |\n", path, t,
              fovDeg, j["configuration"].get<std::string>().c_str(),
              j["texel_of_median_cascade_m"].get<double>(),
              (unsigned long long)j["misclassified"].get<std::uint64_t>(),
              (unsigned long long)j["receiver_pixels"].get<std::uint64_t>(),
              j["shadow_gpu_ms"].get<double>(),
              (unsigned long long)j["shadow_triangles"].get<std::uint64_t>());
  std::fflush(stdout);
}

// The study's configurations; the first (the sphere over the full range) is the baseline whose
// frame gives the receivers the others are driven by.
const FitConfig kFitConfigs[] = {
    {"sphere, full range (before)", csm::BoxFit::kSphere, false},
    {"tight box", csm::BoxFit::kTight, false},
    {"receiver splits", csm::BoxFit::kSphere, true},
    {"tight box + receiver splits", csm::BoxFit::kTight, true},
    {"receiver histogram", csm::BoxFit::kSphere, true, csm::ReceiverSplitScheme::kHistogram},
    {"tight box + receiver histogram", csm::BoxFit::kTight, true,
     csm::ReceiverSplitScheme::kHistogram},
    {"receiver range splits + receiver bounds", csm::BoxFit::kSphere, true,
     csm::ReceiverSplitScheme::kRange, true},
    {"receiver histogram + receiver bounds", csm::BoxFit::kSphere, true,
     csm::ReceiverSplitScheme::kHistogram, true},
    {"tight box + receiver histogram + receiver bounds", csm::BoxFit::kTight, true,
     csm::ReceiverSplitScheme::kHistogram, true}};

// What every pose of one path shares: the path's harness (its world's casters) and Embree scene.
struct FitPathContext {
  const char* path;
  csm_measure::Harness& harness;
  const csm_measure::RayTracer& tracer;
  const world::AppSettings& app;
  const csm::DirectionalLight& light;
  VkExtent2D timingView;
  VkExtent2D accuracyView;
};

// One pose: its timing and accuracy cameras, and the receivers of its first (full-range) frame.
struct FitPose {
  double t = 0.0;
  csm::Camera cam;
  csm::Camera accCam;
  std::optional<csm::ReceiverDepthRange> range;
  std::vector<glm::dvec3> receiverPosWs;  // the full-range frame's receiver pixels
  double medianDepthM = 0.0;
};

FitPose makeFitPose(const world::FlightPath& path, double t, double aspect,
                    VkExtent2D accuracyView) {
  FitPose pose;
  pose.t = t;
  pose.cam = cameraAt(path.at(t), aspect);
  pose.cam.nearM = 0.5;  // as the fly-through
  pose.accCam = pose.cam;
  pose.accCam.aspect = double(accuracyView.width) / accuracyView.height;
  return pose;
}

// The receivers of the pose's (first, full-range) frame: their view depths, the range and
// histogram the fly-through's reduction builds (camera near .. shadow distance), their median
// depth and positions. Left unset when the frame has no receiver pixel.
void recordReceivers(FitPose& pose, const std::vector<csm_measure::PixelSample>& px,
                     double shadowDistanceM) {
  std::vector<double> depths;
  for (const csm_measure::PixelSample& p : px) {
    depths.push_back(glm::dot(p.posWs - pose.accCam.positionWs, pose.accCam.forwardWs()));
  }
  std::sort(depths.begin(), depths.end());
  if (depths.empty()) return;
  pose.range = receiverRangeOf(px, pose.accCam, pose.cam.nearM, shadowDistanceM);
  pose.medianDepthM = depths[depths.size() / 2];
  for (const csm_measure::PixelSample& p : px) pose.receiverPosWs.push_back(p.posWs);
}

// The study's JSON row of one configuration at one pose.
nlohmann::json fitRowJson(const FitPathContext& ctx, const FitConfig& fc, const FitPose& pose,
                          const csm::CascadeFrame& frame, const csm_measure::AccuracyStats& acc,
                          double shadowMs) {
  double texel = 0.0;
  for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
    if (pose.medianDepthM >= frame.splitsM[c] && pose.medianDepthM < frame.splitsM[c + 1]) {
      texel = frame.cascades[c].texelSizeM();
    }
  }
  nlohmann::json j;
  j["path"] = ctx.path;
  j["t"] = pose.t;
  j["fov_deg"] = glm::degrees(pose.cam.fovYRad);
  j["configuration"] = fc.name;
  j["receiver_range_m"] =
      pose.range ? nlohmann::json({pose.range->minM, pose.range->maxM}) : nullptr;
  j["median_receiver_depth_m"] = pose.medianDepthM;
  j["texel_of_median_cascade_m"] = texel;
  j["splits_m"] =
      std::vector<double>(frame.splitsM.begin(), frame.splitsM.begin() + frame.cascadeCount + 1);
  std::vector<double> texels;
  for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
    texels.push_back(frame.cascades[c].texelSizeM());
  }
  j["texel_m"] = texels;
  std::vector<bool> receiverFit;
  for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
    receiverFit.push_back(frame.cascades[c].receiverFit);
  }
  j["receiver_fit"] = receiverFit;
  j["misclassified"] = acc.overall.misclassified;
  j["accuracy"] = acc.toJson(frame.cascadeCount);
  j["receiver_pixels"] = acc.overall.pixels;
  j["shadow_gpu_ms"] = shadowMs;
  j["shadow_triangles"] = ctx.harness.shadowTriangles();
  j["device"] = ctx.harness.context().properties().deviceName;
  return j;
}

// One configuration at one pose: shadow-pass GPU ms (warm-up, fastest of 2) and accuracy against
// Embree. Appends the receiver range it drew with to `ranges` (for retimeInterleaved); the first
// configuration records the pose's receivers for the ones after it.
nlohmann::json measureFitConfig(const FitPathContext& ctx, const FitConfig& fc, FitPose& pose,
                                std::vector<std::optional<csm::ReceiverDepthRange>>& ranges) {
  csm_measure::Harness& harness = ctx.harness;
  csm::ShadowSettings s = ctx.app.shadow;
  s.boxFit = fc.fit;
  s.receiverSplitScheme = fc.scheme;
  if (!harness.configure(s).ok()) throw std::runtime_error("configure failed");
  std::optional<csm::ReceiverDepthRange> cfgRange = fc.receivers ? pose.range : std::nullopt;
  if (fc.bounds && cfgRange) {
    // The bounds as the GPU reduction would return them for the frame before: that
    // frame's receiver pixels binned by the splits this configuration draws with.
    harness.setReceiverRange(cfgRange);
    csm::CascadeHistory hb;
    const csm::CascadeFrame splitFrame = harness.computeFrame(pose.accCam, ctx.light, hb);
    cfgRange->lightBounds = csm::receiverLightBounds(splitFrame, pose.accCam, pose.receiverPosWs);
  }
  ranges.push_back(cfgRange);
  harness.setReceiverRange(cfgRange);
  csm::CascadeHistory h;
  harness.timeFrame(pose.cam, ctx.light, h, ctx.timingView, ctx.app.kernel);
  double shadowMs = 1e30;
  for (int k = 0; k < 2; ++k) {
    shadowMs = std::min(
        shadowMs,
        harness.timeFrame(pose.cam, ctx.light, h, ctx.timingView, ctx.app.kernel).shadowGpuMs);
  }
  csm::CascadeHistory ha;
  const csm::CascadeFrame frame = harness.computeFrame(pose.accCam, ctx.light, ha);
  const std::vector<csm_measure::PixelSample> px =
      harness.renderAccuracy(pose.accCam, frame, ctx.accuracyView, ctx.app.kernel);
  const csm_measure::AccuracyStats acc =
      csm_measure::measureAccuracy(px, frame, ctx.tracer, ctx.light);
  if (!pose.range) recordReceivers(pose, px, s.shadowDistanceM);
  return fitRowJson(ctx, fc, pose, frame, acc, shadowMs);
}

// One path of the study: its world, Embree scene and harness, then at each pose every
// configuration, re-timed interleaved; the rows are printed and appended to report["rows"].
void studyFitPath(const char* pathName, const std::vector<double>& poses, world::WorldDesc wd,
                  const Options& o, VkExtent2D accuracyView, nlohmann::json& report) {
  wd.originWs = world::pathWorldOrigin(pathName, wd.sizeM);
  world::WorldError err;
  std::optional<world::World> w = world::generateWorld(wd, &err);
  if (!w) throw std::runtime_error("generateWorld: " + err.message);
  std::optional<world::FlightPath> path = world::FlightPath::make(pathName, *w, 60.0);
  if (!path) throw std::runtime_error(std::string("unknown path ") + pathName);
  const csm_measure::WorldScene worldScene = csm_measure::sceneFromWorld(*w);
  const csm_measure::RayTracer tracer(worldScene.scene);
  csm_measure::HarnessDesc hd;
  hd.validation = false;
  hd.appName = "csm_tradeoff";
  csm_measure::Harness harness(hd);
  harness.setScene(worldScene.scene);
  const world::AppSettings app;
  harness.setCasterLods(worldScene.lodMeshes, app.cascadeLod);
  const csm::DirectionalLight light{glm::normalize(glm::dvec3(0.45, -0.8, -0.35))};
  const FitPathContext ctx{pathName,    harness, tracer, app, light, {o.width, o.height},
                           accuracyView};
  const double aspect = double(o.width) / double(o.height);
  for (double t : poses) {
    FitPose pose = makeFitPose(*path, t, aspect, accuracyView);
    std::vector<std::optional<csm::ReceiverDepthRange>> ranges;
    std::vector<nlohmann::json> poseRows;
    for (const FitConfig& fc : kFitConfigs) {
      poseRows.push_back(measureFitConfig(ctx, fc, pose, ranges));
    }
    retimeInterleaved(harness, kFitConfigs, app, ranges, pose.cam, light, ctx.timingView, poseRows);
    for (nlohmann::json& j : poseRows) {
      printFitRow(pathName, t, glm::degrees(pose.cam.fovYRad), j);
      report["rows"].push_back(j);
    }
  }
}

int runFitStudy(const Options& o) {
  std::filesystem::create_directories(o.out);
  world::WorldDesc wd;
  wd.treeCount = o.quick ? 3000 : 8000;
  wd.rockCount = 400;
  wd.buildingCount = 40;
  const VkExtent2D accuracyView = o.quick ? VkExtent2D{240, 135} : VkExtent2D{320, 180};
  std::printf(
      "| path | pose | configuration | texel of the median receiver's cascade (m) | "
      "misclassified pixels | of receiver pixels | shadow pass GPU ms | shadow triangles |\n"
      "|---|---|---|---|---|---|---|---|\n");
  nlohmann::json report;
  studyFitPath("zoom", {1.0}, wd, o, accuracyView, report);
  studyFitPath("forest", {0.2, 0.5, 0.8}, wd, o, accuracyView, report);
  report["what"] =
      "csm_tradeoff --fit-study: fly-through shadow settings (4 x 2048^2, 1500 m, lambda 0.8, "
      "near 0.5 m), accuracy view " +
      std::to_string(accuracyView.width) + "x" + std::to_string(accuracyView.height) +
      ", timing view " + std::to_string(o.width) + "x" + std::to_string(o.height);
  csm_measure::writeJson(o.out + "/fit_study.json", report);
  std::fprintf(stderr, "wrote %s/fit_study.json\n", o.out.c_str());
  return 0;
}

}  // namespace tradeoff
