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
  uint32_t resolution;  ///< every configuration's shadow-map side
};

// The shadow settings of one configuration: the fly-through's, with its fit and scheme.
csm::ShadowSettings fitSettings(const FitPathContext& ctx, const FitConfig& fc) {
  csm::ShadowSettings s = ctx.app.shadow;
  s.boxFit = fc.fit;
  s.receiverSplitScheme = fc.scheme;
  s.resolution = ctx.resolution;
  return s;
}

// One pose: its timing and accuracy cameras, and the receivers of its first (full-range) frame.
struct FitPose {
  double t = 0.0;
  csm::Camera cam;
  csm::Camera accCam;
  std::optional<csm::ReceiverDepthRange> range;
  std::vector<glm::dvec3> receiverPosWs;  // the full-range frame's receiver pixels
  double medianDepthM = 0.0;
  // The first (full-range) configuration's misclassified pixels, to count the shared ones.
  std::optional<csm_measure::MissCauses> firstMisses;
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
                          const csm_measure::MissCauses& causes, double shadowMs) {
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
  j["misclassified_causes"] = causes.toJson();
  j["misclassified_shared_with_first"] =
      pose.firstMisses ? causes.sharedWith(*pose.firstMisses) : causes.total();
  j["receiver_pixels"] = acc.overall.pixels;
  j["shadow_gpu_ms"] = shadowMs;
  j["shadow_triangles"] = ctx.harness.shadowTriangles();
  j["device"] = ctx.harness.context().properties().deviceName;
  return j;
}

// The shadow pass of every configuration again, interleaved (3 rounds, fastest kept): the
// machine's load drifts over a sequential run, so the ms are compared within a round.
void retimeInterleaved(const FitPathContext& ctx, std::span<const FitConfig> configs,
                       std::span<const std::optional<csm::ReceiverDepthRange>> ranges,
                       const csm::Camera& cam, std::vector<nlohmann::json>& poseRows) {
  csm_measure::Harness& harness = ctx.harness;
  for (int round = 0; round < 3; ++round) {
    for (std::size_t k = 0; k < configs.size(); ++k) {
      if (!harness.configure(fitSettings(ctx, configs[k])).ok()) {
        throw std::runtime_error("configure failed");
      }
      harness.setReceiverRange(ranges[k]);
      csm::CascadeHistory h;
      harness.timeFrame(cam, ctx.light, h, ctx.timingView, ctx.app.shadow.kernel);
      const double ms =
          harness.timeFrame(cam, ctx.light, h, ctx.timingView, ctx.app.shadow.kernel).shadowGpuMs;
      poseRows[k]["shadow_gpu_ms"] = std::min(poseRows[k]["shadow_gpu_ms"].get<double>(), ms);
    }
  }
}

// One configuration at one pose: shadow-pass GPU ms (warm-up, fastest of 2) and accuracy against
// Embree. Appends the receiver range it drew with to `ranges` (for retimeInterleaved); the first
// configuration records the pose's receivers for the ones after it.
nlohmann::json measureFitConfig(const FitPathContext& ctx, const FitConfig& fc, FitPose& pose,
                                std::vector<std::optional<csm::ReceiverDepthRange>>& ranges) {
  csm_measure::Harness& harness = ctx.harness;
  const csm::ShadowSettings s = fitSettings(ctx, fc);
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
  harness.timeFrame(pose.cam, ctx.light, h, ctx.timingView, ctx.app.shadow.kernel);
  double shadowMs = 1e30;
  for (int k = 0; k < 2; ++k) {
    shadowMs = std::min(
        shadowMs, harness.timeFrame(pose.cam, ctx.light, h, ctx.timingView, ctx.app.shadow.kernel)
                      .shadowGpuMs);
  }
  csm::CascadeHistory ha;
  const csm::CascadeFrame frame = harness.computeFrame(pose.accCam, ctx.light, ha);
  const std::vector<csm_measure::PixelSample> px =
      harness.renderAccuracy(pose.accCam, frame, ctx.accuracyView, ctx.app.shadow.kernel);
  const csm_measure::AccuracyStats acc =
      csm_measure::measureAccuracy(px, frame, ctx.tracer, ctx.light);
  if (!pose.range) recordReceivers(pose, px, s.shadowDistanceM);
  const csm_measure::MissCauses causes =
      csm_measure::classifyMisses(px, frame, ctx.tracer, ctx.light, pose.accCam.positionWs);
  if (causes.total() != acc.overall.misclassified) {
    throw std::logic_error("classifyMisses counted other pixels than measureAccuracy");
  }
  nlohmann::json row = fitRowJson(ctx, fc, pose, frame, acc, causes, shadowMs);
  if (!pose.firstMisses) pose.firstMisses = causes;
  return row;
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
  const FitPathContext ctx{pathName,     harness,
                           tracer,       app,
                           light,        {o.width, o.height},
                           accuracyView, o.fitResolution ? o.fitResolution : app.shadow.resolution};
  const double aspect = double(o.width) / double(o.height);
  for (double t : poses) {
    FitPose pose = makeFitPose(*path, t, aspect, accuracyView);
    std::vector<std::optional<csm::ReceiverDepthRange>> ranges;
    std::vector<nlohmann::json> poseRows;
    for (const FitConfig& fc : kFitConfigs) {
      poseRows.push_back(measureFitConfig(ctx, fc, pose, ranges));
    }
    retimeInterleaved(ctx, kFitConfigs, ranges, pose.cam, poseRows);
    for (nlohmann::json& j : poseRows) {
      printFitRow(pathName, t, glm::degrees(pose.cam.fovYRad), j);
      report["rows"].push_back(j);
    }
  }
}

// The second table: why each configuration's misclassified pixels are wrong
// (csm_measure::classifyMisses), and how many of them the first configuration of the pose
// (the sphere over the full range) gets wrong too.
void printCausesTable(const nlohmann::json& rows) {
  std::printf(
      "\n| path | pose | configuration | misclassified | also misclassified by the first row | "
      "facing away geometrically | false shadow | missed: thin occluder | missed: contact | "
      "missed: far |\n|---|---|---|---|---|---|---|---|---|---|\n");
  for (const nlohmann::json& j : rows) {
    const nlohmann::json& c = j["misclassified_causes"];
    auto n = [](const nlohmann::json& v) { return (unsigned long long)v.get<std::uint64_t>(); };
    std::printf(
        "| %s | t=%.1f, fov %.0f deg | %s | %llu | %llu | %llu | %llu | %llu | %llu | %llu |\n",
        j["path"].get<std::string>().c_str(), j["t"].get<double>(), j["fov_deg"].get<double>(),
        j["configuration"].get<std::string>().c_str(), n(c["total"]),
        n(j["misclassified_shared_with_first"]), n(c["facing_away_geometrically"]),
        n(c["false_shadow"]), n(c["missed_thin_occluder"]), n(c["missed_contact"]),
        n(c["missed_far"]));
  }
  std::fflush(stdout);
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
  printCausesTable(report["rows"]);
  const uint32_t res = o.fitResolution ? o.fitResolution : world::AppSettings{}.shadow.resolution;
  report["what"] = "csm_tradeoff --fit-study: fly-through shadow settings (4 x " +
                   std::to_string(res) + "^2, 1500 m, lambda 0.8, near 0.5 m), accuracy view " +
                   std::to_string(accuracyView.width) + "x" + std::to_string(accuracyView.height) +
                   ", timing view " + std::to_string(o.width) + "x" + std::to_string(o.height);
  csm_measure::writeJson(o.out + "/fit_study.json", report);
  std::fprintf(stderr, "wrote %s/fit_study.json\n", o.out.c_str());
  return 0;
}

}  // namespace tradeoff
