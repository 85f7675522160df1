// csm_tradeoff: what each cascade setting costs and buys, measured. Flies a named path of the
// sample world (sample_world/) and, per configuration, measures on a few poses along it:
//   GPU ms of the shadow pass and of the lit pass (timestamp queries), CPU ms (cascade math,
//   culling, recording), shadow-map memory, triangles the shadow pass draws, misclassification
//   rate and mean |s - v| of every receiver pixel against Embree shadow rays (full-detail
//   triangles, also with caster LODs on), and stabilised shimmer at the receivers the first pose
//   sees, over a few frames of the path.
// Axes: cascade count 1..6 x resolution 512..8192 x caster LODs on/off (each cascade draws the
// sample world's simplified caster meshes at the fly-through's default LOD for it: 0, 1, 2, 2...),
// then split lambda, PCF kernel, blend band, depth format, box fit, size-ladder step (or off) and
// receiver-driven splits (range, or histogram: CSV receiver_splits 1 / 2) one at a time around
// the defaults (4 cascades, 2048^2, lambda 0.75,
// tent3x3, band 0.1, D32, LODs on, sphere box, ladder 2^(1/8), full split range).
// Timing per pose: one warm-up frame, then the fastest of two. Full mode: world of 8000 trees,
// 5 poses, 8 shimmer frames, timing view 640x360, accuracy view 320x180 (sized to finish in
// about 10 minutes on 2-core lavapipe). --quick: 3000 trees, 2 poses,
// 4 shimmer frames, 320x180 / 240x135, fewer counts and resolutions (under a minute).
// Writes a CSV, marks the Pareto front of (GPU ms, misclassification), draws it with gnuplot
// (default settings marked) and, with --budget-ms (repeatable), recommends the most accurate
// configuration that fits.
// Usage: csm_tradeoff [--quick] [--path NAME] [--out DIR] [--budget-ms X]... [--replot]
//                     [--width W --height H]
// --replot re-draws the table, plot and recommendations from DIR/tradeoff.csv without measuring.
#include <csm_measure/harness.hpp>
#include <csm_measure/metrics.hpp>
#include <csm_measure/raytracer.hpp>
#include <csm_measure/scene.hpp>
#include <csm_measure/world_scene.hpp>
#include <engine/camera.hpp>
#include <engine/errors.hpp>
#include <sample_world/paths.hpp>
#include <sample_world/settings.hpp>
#include <sample_world/world.hpp>

#include "receiver_histogram.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace {

struct Options {
  bool quick = false;
  std::string path = "forest";
  std::string out = "tradeoff";
  /// Re-draw the table, plot and recommendations from OUT/tradeoff.csv without measuring.
  bool replot = false;
  /// --fit-study: box fit and receiver-driven splits on the zoom and forest paths.
  bool fitStudy = false;
  std::vector<double> budgetsMs;  ///< --budget-ms (may be repeated)
  uint32_t width = 640, height = 360;
  /// --lod-study: only the default configuration, with several per-cascade LOD schedules.
  bool lodStudy = false;
};

struct Config {
  uint32_t cascades = 4;
  uint32_t resolution = 2048;
  double lambda = 0.75;
  csm::PcfKernel kernel = csm::PcfKernel::kTent3;
  double blendBand = 0.1;
  VkFormat format = VK_FORMAT_D32_SFLOAT;
  /// Caster LODs: cascade c draws each cluster's coarsest simplified mesh whose geometric error
  /// is at most maxErrorTexels of its texels (the module's default, RendererOptions::
  /// lodMaxErrorTexels), and at least the schedule's LOD.
  bool lods = true;
  /// Box fit, size ladder (rungs per octave, 0 = off) and receiver-driven splits (the range of
  /// the pose's full-range frame, as the depth reduction would report it).
  csm::BoxFit fit = csm::BoxFit::kSphere;
  double ladderSteps = 8.0;
  bool receivers = false;
  /// With `receivers`: the splits from the receivers' depth histogram (ReceiverSplitScheme::
  /// kHistogram) instead of the range's lambda splits.
  bool histogram = false;
  /// The LOD each cascade draws at least when `lods` (--lod-study varies it; empty: all 0).
  std::vector<uint32_t> schedule;
  /// RendererOptions::lodMaxErrorTexels when `lods` (0: the schedule alone).
  float maxErrorTexels = csm::vk::RendererOptions{}.lodMaxErrorTexels;
  /// The LODs column: on (the default), off, a schedule "0122" and/or an error budget "e0.25".
  [[nodiscard]] std::string lodLabel() const {
    if (!lods) return "off";
    std::string s;
    for (uint32_t l : schedule) s += std::to_string(l);
    if (maxErrorTexels != csm::vk::RendererOptions{}.lodMaxErrorTexels) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%se%.2g", s.empty() ? "" : " ", double(maxErrorTexels));
      if (maxErrorTexels != 0.0f) s += buf;
    }
    return s.empty() ? "on" : s;
  }
  [[nodiscard]] bool isDefault() const {
    const csm::ShadowSettings d;
    return cascades == d.cascadeCount && resolution == d.resolution && lambda == d.splitLambda &&
           kernel == csm::PcfKernel::kTent3 && blendBand == d.blendBand &&
           format == VK_FORMAT_D32_SFLOAT && lods && schedule.empty() &&
           maxErrorTexels == csm::vk::RendererOptions{}.lodMaxErrorTexels && fit == d.boxFit &&
           ladderSteps == d.ladderStepsPerOctave && !receivers;
  }
  [[nodiscard]] std::string fitLabel() const {
    std::string s;
    if (fit == csm::BoxFit::kTight) s += " tight";
    if (ladderSteps == 0.0) {
      s += " noLadder";
    } else if (ladderSteps != 8.0) {
      s += " ladder" + std::to_string(int(ladderSteps));
    }
    if (receivers) s += histogram ? " hist" : " rcv";
    return s;
  }
  /// The label without the fields at their default (for the plot).
  [[nodiscard]] std::string shortLabel() const {
    const csm::ShadowSettings d;
    char buf[160];
    std::snprintf(buf, sizeof buf, "c%u r%u", cascades, resolution);
    std::string s = buf;
    if (lambda != d.splitLambda) {
      std::snprintf(buf, sizeof buf, " l%.2f", lambda);
      s += buf;
    }
    if (kernel != csm::PcfKernel::kTent3) s += std::string(" ") + csm::kernelName(kernel);
    if (blendBand != d.blendBand) {
      std::snprintf(buf, sizeof buf, " b%.2f", blendBand);
      s += buf;
    }
    if (format == VK_FORMAT_D16_UNORM) s += " D16";
    if (!lods) s += " noLOD";
    if (lods && lodLabel() != "on") {
      s += " LOD ";
      s += lodLabel();
    }
    return s + fitLabel();
  }
  [[nodiscard]] std::string label() const {
    char buf[160];
    std::snprintf(buf, sizeof buf, "c%u r%u l%.2f %s b%.2f %s %s", cascades, resolution, lambda,
                  csm::kernelName(kernel), blendBand, format == VK_FORMAT_D16_UNORM ? "D16" : "D32",
                  lods ? "LOD" : "noLOD");
    std::string label = buf;
    if (lods && lodLabel() != "on") {
      label += ' ';
      label += lodLabel();
    }
    return label + fitLabel();
  }
};

struct Row {
  Config config;
  double shadowMs = 0, litMs = 0, cpuMs = 0;
  double memoryMiB = 0;
  double misclassification = 0, meanError = 0;
  double shimmerMean = 0, shimmerMax = 0;
  double triangles = 0;  ///< triangles the shadow pass draws per frame (mean over poses)
  uint64_t pixels = 0;
  bool pareto = false;
  [[nodiscard]] double gpuMs() const { return shadowMs + litMs; }
};

csm::Camera cameraAt(const world::CameraPose& p, double aspect) {
  engine::Camera e;
  e.positionWs = p.positionWs;
  e.setYawPitchRoll(p.yawRad, p.pitchRad);
  csm::Camera c;
  c.positionWs = p.positionWs;
  c.orientationWs = e.orientation;
  c.fovYRad = glm::radians(p.fovDeg);
  c.aspect = aspect;
  c.nearM = 0.1;
  c.farM = 5000.0;
  return c;
}

// Rows of a CSV this tool wrote (for --replot).
std::vector<Row> readCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("--replot: cannot read " + path);
  std::vector<Row> rows;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::vector<std::string> f;
    size_t p = 0;
    for (size_t q; (q = line.find(',', p)) != std::string::npos; p = q + 1) {
      f.push_back(line.substr(p, q - p));
    }
    f.push_back(line.substr(p));
    // 20 columns before the fit axes were added, 23 since.
    if (f.size() != 20 && f.size() != 23) {
      throw std::runtime_error("--replot: bad line in " + path + ": " + line);
    }
    Row r;
    r.config.cascades = uint32_t(std::stoul(f[0]));
    r.config.resolution = uint32_t(std::stoul(f[1]));
    r.config.lambda = std::stod(f[2]);
    bool known = false;
    for (csm::PcfKernel k :
         {csm::PcfKernel::k1Tap, csm::PcfKernel::kTent3, csm::PcfKernel::kTent5,
          csm::PcfKernel::kTent7, csm::PcfKernel::kPoisson16, csm::PcfKernel::kPcss}) {
      if (f[3] == csm::kernelName(k)) {
        r.config.kernel = k;
        known = true;
      }
    }
    if (!known) throw std::runtime_error("--replot: unknown kernel " + f[3]);
    r.config.blendBand = std::stod(f[4]);
    r.config.format = f[5] == "D16" ? VK_FORMAT_D16_UNORM : VK_FORMAT_D32_SFLOAT;
    r.config.lods = f[6] == "1";
    r.shadowMs = std::stod(f[7]);
    r.litMs = std::stod(f[8]);
    r.cpuMs = std::stod(f[10]);
    r.memoryMiB = std::stod(f[11]);
    r.misclassification = std::stod(f[12]);
    r.meanError = std::stod(f[13]);
    r.shimmerMean = std::stod(f[14]);
    r.shimmerMax = std::stod(f[15]);
    r.triangles = std::stod(f[16]);
    r.pixels = std::stoull(f[17]);
    if (f.size() == 23) {
      r.config.fit = f[20] == "tight" ? csm::BoxFit::kTight : csm::BoxFit::kSphere;
      r.config.ladderSteps = std::stod(f[21]);
      r.config.receivers = f[22] == "1" || f[22] == "2";
      r.config.histogram = f[22] == "2";
    }
    rows.push_back(r);
  }
  return rows;
}

void progress(size_t done, size_t total, const std::string& what, double elapsedS) {
  const int width = 30;
  const int filled = total ? int(width * done / total) : width;
  const double eta = done ? elapsedS / double(done) * double(total - done) : 0.0;
  std::fprintf(stderr, "\r[%.*s%*s] %zu/%zu  %-44s eta %4.0f s", filled,
               "##############################", width - filled, "", done, total, what.c_str(),
               eta);
  if (done == total) std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

void usage(std::FILE* out) {
  std::fprintf(
      out,
      "usage: csm_tradeoff [--quick] [--path NAME] [--out DIR] [--budget-ms X]... [--replot] "
      "[--width W --height H] [--lod-study]\n"
      "  --lod-study: only the default configuration, with per-cascade caster LOD schedules "
      "(0122 .. 0000) and without LODs.\n"
      "  --budget-ms X (repeatable): recommend the most accurate configuration whose GPU ms "
      "fits X.\n"
      "  --replot: re-draw table, plot and recommendations from DIR/tradeoff.csv, no "
      "measuring.\n"
      "  --fit-study: sphere vs tight box x full range vs receiver-driven splits on the zoom "
      "path\n  at 8 degrees and the forest path at 60 degrees; writes DIR/fit_study.json.\n"
      "  sweeps cascades 1..6 x resolution 512..8192 x caster LODs on/off, then split "
      "lambda,\n  PCF kernel, blend band and depth format around the defaults; writes "
      "DIR/tradeoff.csv and\n  DIR/tradeoff.png (Pareto front of GPU ms vs "
      "misclassification, defaults marked).\n"
      "  full mode: 5 poses, 640x360 timing view, 320x180 accuracy view (about 10 min "
      "on 2-core lavapipe);\n  --quick: 2 poses, 320x180 / 240x135, fewer counts "
      "and resolutions (under a minute).\n  paths:");
  for (const std::string& n : world::pathNames()) std::fprintf(out, " %s", n.c_str());
  std::fprintf(out, "\n");
}

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
};

int runFitStudy(const Options& o) {
  std::filesystem::create_directories(o.out);
  world::WorldDesc wd;
  wd.treeCount = o.quick ? 3000 : 8000;
  wd.rockCount = 400;
  wd.buildingCount = 40;
  nlohmann::json report;
  const FitConfig configs[] = {
      {"sphere, full range (before)", csm::BoxFit::kSphere, false},
      {"tight box", csm::BoxFit::kTight, false},
      {"receiver splits", csm::BoxFit::kSphere, true},
      {"tight box + receiver splits", csm::BoxFit::kTight, true},
      {"receiver histogram", csm::BoxFit::kSphere, true, csm::ReceiverSplitScheme::kHistogram},
      {"tight box + receiver histogram", csm::BoxFit::kTight, true,
       csm::ReceiverSplitScheme::kHistogram}};
  struct Study {
    const char* path;
    std::vector<double> poses;
  };
  const Study studies[] = {{"zoom", {1.0}}, {"forest", {0.2, 0.5, 0.8}}};
  const VkExtent2D accuracyView = o.quick ? VkExtent2D{240, 135} : VkExtent2D{320, 180};
  const csm::DirectionalLight light{glm::normalize(glm::dvec3(0.45, -0.8, -0.35))};
  const double aspect = double(o.width) / double(o.height);
  std::printf(
      "| path | pose | configuration | texel of the median receiver's cascade (m) | "
      "misclassified pixels | of receiver pixels | shadow pass GPU ms | shadow triangles |\n"
      "|---|---|---|---|---|---|---|---|\n");
  for (const Study& st : studies) {
    wd.originWs = world::pathWorldOrigin(st.path, wd.sizeM);
    world::WorldError err;
    std::optional<world::World> w = world::generateWorld(wd, &err);
    if (!w) throw std::runtime_error("generateWorld: " + err.message);
    std::optional<world::FlightPath> path = world::FlightPath::make(st.path, *w, 60.0);
    if (!path) throw std::runtime_error(std::string("unknown path ") + st.path);
    const csm_measure::WorldScene worldScene = csm_measure::sceneFromWorld(*w);
    const csm_measure::RayTracer tracer(worldScene.scene);
    csm_measure::HarnessDesc hd;
    hd.validation = false;
    hd.appName = "csm_tradeoff";
    csm_measure::Harness harness(hd);
    harness.setScene(worldScene.scene);
    const world::AppSettings app;
    harness.setCasterLods(worldScene.lodMeshes, app.cascadeLod);
    for (double t : st.poses) {
      csm::Camera cam = cameraAt(path->at(t), aspect);
      cam.nearM = 0.5;  // as the fly-through
      csm::Camera accCam = cam;
      accCam.aspect = double(accuracyView.width) / accuracyView.height;
      std::optional<csm::ReceiverDepthRange> range;
      double medianDepthM = 0.0;
      std::vector<nlohmann::json> poseRows;
      for (const FitConfig& fc : configs) {
        csm::ShadowSettings s = app.shadow;
        s.boxFit = fc.fit;
        s.receiverSplitScheme = fc.scheme;
        if (!harness.configure(s).ok()) throw std::runtime_error("configure failed");
        harness.setReceiverRange(fc.receivers ? range : std::nullopt);
        csm::CascadeHistory h;
        harness.timeFrame(cam, light, h, {o.width, o.height}, app.kernel);
        double shadowMs = 1e30;
        for (int k = 0; k < 2; ++k) {
          shadowMs = std::min(
              shadowMs,
              harness.timeFrame(cam, light, h, {o.width, o.height}, app.kernel).shadowGpuMs);
        }
        csm::CascadeHistory ha;
        const csm::CascadeFrame frame = harness.computeFrame(accCam, light, ha);
        const std::vector<csm_measure::PixelSample> px =
            harness.renderAccuracy(accCam, frame, accuracyView, app.kernel);
        const csm_measure::AccuracyStats acc =
            csm_measure::measureAccuracy(px, frame, tracer, light);
        if (!range) {
          // The receivers of this (first, full-range) frame: their view depths.
          std::vector<double> depths;
          for (const csm_measure::PixelSample& p : px) {
            depths.push_back(glm::dot(p.posWs - accCam.positionWs, accCam.forwardWs()));
          }
          std::sort(depths.begin(), depths.end());
          if (!depths.empty()) {
            // With the histogram the fly-through's reduction builds (camera near .. shadow
            // distance).
            range = tradeoff::receiverRangeOf(px, accCam, cam.nearM, s.shadowDistanceM);
            medianDepthM = depths[depths.size() / 2];
          }
        }
        double texel = 0.0;
        for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
          if (medianDepthM >= frame.splitsM[c] && medianDepthM < frame.splitsM[c + 1]) {
            texel = frame.cascades[c].texelSizeM();
          }
        }
        nlohmann::json j;
        j["path"] = st.path;
        j["t"] = t;
        j["fov_deg"] = glm::degrees(cam.fovYRad);
        j["configuration"] = fc.name;
        j["receiver_range_m"] = range ? nlohmann::json({range->minM, range->maxM}) : nullptr;
        j["median_receiver_depth_m"] = medianDepthM;
        j["texel_of_median_cascade_m"] = texel;
        j["splits_m"] = std::vector<double>(frame.splitsM.begin(),
                                            frame.splitsM.begin() + frame.cascadeCount + 1);
        std::vector<double> texels;
        for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
          texels.push_back(frame.cascades[c].texelSizeM());
        }
        j["texel_m"] = texels;
        j["misclassified"] = acc.overall.misclassified;
        j["accuracy"] = acc.toJson(frame.cascadeCount);
        j["receiver_pixels"] = acc.overall.pixels;
        j["shadow_gpu_ms"] = shadowMs;
        j["shadow_triangles"] = harness.shadowTriangles();
        j["device"] = harness.context().properties().deviceName;
        poseRows.push_back(j);
      }
      // The shadow pass again, the configurations interleaved (3 rounds, fastest kept): the
      // machine's load drifts over a sequential run, so the ms are compared within a round.
      for (int round = 0; round < 3; ++round) {
        for (std::size_t k = 0; k < std::size(configs); ++k) {
          csm::ShadowSettings s = app.shadow;
          s.boxFit = configs[k].fit;
          s.receiverSplitScheme = configs[k].scheme;
          if (!harness.configure(s).ok()) throw std::runtime_error("configure failed");
          harness.setReceiverRange(configs[k].receivers ? range : std::nullopt);
          csm::CascadeHistory h;
          harness.timeFrame(cam, light, h, {o.width, o.height}, app.kernel);
          const double ms =
              harness.timeFrame(cam, light, h, {o.width, o.height}, app.kernel).shadowGpuMs;
          poseRows[k]["shadow_gpu_ms"] = std::min(poseRows[k]["shadow_gpu_ms"].get<double>(), ms);
        }
      }
      for (nlohmann::json& j : poseRows) {
        std::printf("| %s | t=%.1f, fov %.0f deg | %s | %.4f | %llu | %llu | %.2f | %llu |\n",
                    st.path, t, glm::degrees(cam.fovYRad),
                    j["configuration"].get<std::string>().c_str(),
                    j["texel_of_median_cascade_m"].get<double>(),
                    (unsigned long long)j["misclassified"].get<std::uint64_t>(),
                    (unsigned long long)j["receiver_pixels"].get<std::uint64_t>(),
                    j["shadow_gpu_ms"].get<double>(),
                    (unsigned long long)j["shadow_triangles"].get<std::uint64_t>());
        std::fflush(stdout);
        report["rows"].push_back(j);
      }
    }
  }
  report["what"] =
      "csm_tradeoff --fit-study: fly-through shadow settings (4 x 2048^2, 1500 m, lambda 0.8, "
      "near 0.5 m), accuracy view " +
      std::to_string(accuracyView.width) + "x" + std::to_string(accuracyView.height) +
      ", timing view " + std::to_string(o.width) + "x" + std::to_string(o.height);
  csm_measure::writeJson(o.out + "/fit_study.json", report);
  std::fprintf(stderr, "wrote %s/fit_study.json\n", o.out.c_str());
  return 0;
}

int run(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--quick") {
      o.quick = true;
    } else if (a == "--replot") {
      o.replot = true;
    } else if (a == "--fit-study") {
      o.fitStudy = true;
    } else if (a == "--path") {
      o.path = next();
    } else if (a == "--out") {
      o.out = next();
    } else if (a == "--budget-ms") {
      o.budgetsMs.push_back(std::stod(next()));
    } else if (a == "--width") {
      o.width = uint32_t(std::stoul(next()));
    } else if (a == "--height") {
      o.height = uint32_t(std::stoul(next()));
    } else if (a == "--lod-study") {
      o.lodStudy = true;
    } else if (a == "--help" || a == "-h") {
      usage(stdout);
      return 0;
    } else {
      usage(stderr);
      return 2;
    }
  }
  if (o.quick) {
    o.width = 320;
    o.height = 180;
  }
  if (o.fitStudy) return runFitStudy(o);
  std::filesystem::create_directories(o.out);
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };

  std::vector<Row> rows;
  std::string info;  // what was measured where: device, path, poses, views
  std::string device;
  if (o.replot) {
    rows = readCsv(o.out + "/tradeoff.csv");
    std::ifstream in(o.out + "/tradeoff_info.txt");
    if (!std::getline(in, info)) info = "device: unknown;";
    device = info.substr(std::min(info.size(), size_t(8)),
                         info.find(';') - std::min(info.size(), size_t(8)));
  } else {
    // The world: small enough to generate in seconds, the path's origin (10^7 m for "far").
    world::WorldDesc wd;
    wd.treeCount = o.quick ? 3000 : 8000;
    wd.rockCount = 400;
    wd.buildingCount = 40;
    wd.originWs = world::pathWorldOrigin(o.path, wd.sizeM);
    world::WorldError err;
    std::optional<world::World> w = world::generateWorld(wd, &err);
    if (!w) throw std::runtime_error("generateWorld: " + err.message);
    std::optional<world::FlightPath> path = world::FlightPath::make(o.path, *w, 60.0);
    if (!path) throw std::runtime_error("unknown path " + o.path);
    const csm_measure::WorldScene worldScene = csm_measure::sceneFromWorld(*w);
    const csm_measure::Scene& scene = worldScene.scene;
    std::fprintf(stderr, "world: %zu caster clusters, %llu triangles; path %s (%.1f s)\n",
                 scene.instances().size(), (unsigned long long)scene.triangleCount(),
                 o.path.c_str(), elapsed());
    const csm_measure::RayTracer tracer(scene);

    csm_measure::HarnessDesc hd;
    hd.validation = false;
    hd.appName = "csm_tradeoff";
    csm_measure::Harness harness(hd);
    harness.setScene(scene);
    const std::array<uint32_t, csm::kMaxCascades> cascadeLod = world::AppSettings().cascadeLod;
    device = harness.context().properties().deviceName;

    // Configurations: cascade count x resolution x caster LODs on/off at the other defaults, then
    // one axis at a time around the defaults (split lambda, kernel, blend band, depth format).
    std::vector<Config> configs;
    const std::vector<uint32_t> counts =
        o.quick ? std::vector<uint32_t>{1, 2, 4} : std::vector<uint32_t>{1, 2, 3, 4, 5, 6};
    const std::vector<uint32_t> resolutions =
        o.quick ? std::vector<uint32_t>{512, 1024, 2048}
                : std::vector<uint32_t>{512, 1024, 2048, 4096, 8192};
    if (o.lodStudy) {
      // The default configuration with error-bounded LODs at several budgets (the default: half
      // a texel), then explicit per-cascade schedules alone (the former default 0,1,2,2 first).
      for (float e : {0.5f, 2.0f, 8.0f, 32.0f, 64.0f}) {
        Config cfg;
        cfg.maxErrorTexels = e;
        configs.push_back(cfg);
      }
      for (const std::vector<uint32_t>& schedule :
           std::vector<std::vector<uint32_t>>{{0, 1, 2, 2}, {0, 0, 0, 1}, {0, 0, 0, 0}}) {
        Config cfg;
        cfg.schedule = schedule;
        cfg.maxErrorTexels = 0.0f;
        configs.push_back(cfg);
      }
      Config none;
      none.lods = false;
      configs.push_back(none);
    }
    for (bool lods : {true, false}) {
      if (o.lodStudy) break;
      for (uint32_t c : counts) {
        for (uint32_t r : resolutions) {
          Config cfg;
          cfg.cascades = c;
          cfg.resolution = r;
          cfg.lods = lods;
          configs.push_back(cfg);
        }
      }
    }
    for (double l : {0.0, 0.5, 1.0}) {
      if (o.lodStudy) break;
      Config cfg;
      cfg.lambda = l;
      configs.push_back(cfg);
    }
    for (csm::PcfKernel k : {csm::PcfKernel::k1Tap, csm::PcfKernel::kTent5, csm::PcfKernel::kTent7,
                             csm::PcfKernel::kPoisson16, csm::PcfKernel::kPcss}) {
      if (o.lodStudy) break;
      Config cfg;
      cfg.kernel = k;
      configs.push_back(cfg);
    }
    for (double b : {0.0, 0.25}) {
      if (o.lodStudy) break;
      Config cfg;
      cfg.blendBand = b;
      configs.push_back(cfg);
    }
    if (!o.lodStudy) {
      Config cfg;
      cfg.format = VK_FORMAT_D16_UNORM;
      configs.push_back(cfg);
    }
    // The fit axes (issue 10): box fit, ladder step (0 = off), receiver-driven splits.
    for (int k = 0; k < 8; ++k) {
      if (o.lodStudy) break;
      Config cfg;
      if (k == 0) cfg.fit = csm::BoxFit::kTight;
      if (k == 1) cfg.ladderSteps = 0.0;
      if (k == 2) cfg.ladderSteps = 4.0;
      if (k == 3) cfg.ladderSteps = 16.0;
      if (k == 4) cfg.receivers = true;
      if (k == 5) {
        cfg.fit = csm::BoxFit::kTight;
        cfg.receivers = true;
      }
      if (k >= 6) {  // histogram-driven splits (sphere, tight)
        cfg.fit = k == 7 ? csm::BoxFit::kTight : csm::BoxFit::kSphere;
        cfg.receivers = cfg.histogram = true;
      }
      configs.push_back(cfg);
    }

    const int poses = o.quick ? 2 : 5;
    const int shimmerFrames = o.quick ? 4 : 8;
    const int kTimedFrames = 2;
    const VkExtent2D accuracyView = o.quick ? VkExtent2D{240, 135} : VkExtent2D{320, 180};
    const csm::DirectionalLight light{glm::normalize(glm::dvec3(0.45, -0.8, -0.35))};
    const double aspect = double(o.width) / double(o.height);

    for (size_t ci = 0; ci < configs.size(); ++ci) {
      const Config& cfg = configs[ci];
      progress(ci, configs.size(), cfg.label(), elapsed());
      csm::ShadowSettings s;
      s.cascadeCount = cfg.cascades;
      s.resolution = cfg.resolution;
      s.splitLambda = cfg.lambda;
      s.blendBand = cfg.blendBand;
      s.boxFit = cfg.fit;
      s.receiverSplitScheme =
          cfg.histogram ? csm::ReceiverSplitScheme::kHistogram : csm::ReceiverSplitScheme::kRange;
      s.sizeLadder = cfg.ladderSteps > 0.0;
      if (cfg.ladderSteps > 0.0) s.ladderStepsPerOctave = cfg.ladderSteps;
      harness.setReceiverRange(std::nullopt);
      csm::vk::RendererOptions ro;
      ro.depthFormat = cfg.format;
      ro.lodMaxErrorTexels = cfg.lods ? cfg.maxErrorTexels : 0.0f;
      const csm::vk::Status st = harness.configure(s, ro);
      if (!st.ok()) {
        std::fprintf(stderr, "\nskipping %s: %s\n", cfg.label().c_str(), st.message().c_str());
        continue;
      }
      std::array<uint32_t, csm::kMaxCascades> lodOfCascade = cascadeLod;
      for (size_t c = 0; c < cfg.schedule.size() && c < csm::kMaxCascades; ++c) {
        lodOfCascade[c] = cfg.schedule[c];
      }
      harness.setCasterLods(cfg.lods ? worldScene.lodMeshes : std::vector<std::vector<uint32_t>>{},
                            lodOfCascade,
                            cfg.lods ? worldScene.lodErrorM : std::vector<std::vector<float>>{});
      Row row;
      row.config = cfg;
      row.memoryMiB = double(harness.shadowMapBytes()) / (1024.0 * 1024.0);
      csm_measure::AccuracyStats acc;
      for (int p = 0; p < poses; ++p) {
        const double t = (p + 0.5) / poses;
        const csm::Camera cam = cameraAt(path->at(t), aspect);
        if (cfg.receivers) {
          // The receiver range of this pose's full-range frame (what the depth reduction reports
          // for the frame before).
          harness.setReceiverRange(std::nullopt);
          csm::Camera rc = cam;
          rc.aspect = double(accuracyView.width) / accuracyView.height;
          csm::CascadeHistory hr;
          const csm::CascadeFrame fr = harness.computeFrame(rc, light, hr);
          harness.setReceiverRange(
              tradeoff::receiverRangeOf(harness.renderAccuracy(rc, fr, accuracyView, cfg.kernel),
                                        rc, rc.nearM, std::max(s.shadowDistanceM, 2.0 * rc.nearM)));
        }
        csm::CascadeHistory h;
        // Timing: one warm-up frame, then the fastest of kTimedFrames (lavapipe's timings vary by
        // tens of percent from frame to frame with the host's scheduling; the minimum is stable).
        harness.timeFrame(cam, light, h, {o.width, o.height}, cfg.kernel);
        csm_measure::FrameTimings best{1e30, 1e30, 1e30};
        for (int k = 0; k < kTimedFrames; ++k) {
          const csm_measure::FrameTimings ft =
              harness.timeFrame(cam, light, h, {o.width, o.height}, cfg.kernel);
          best.shadowGpuMs = std::min(best.shadowGpuMs, ft.shadowGpuMs);
          best.litGpuMs = std::min(best.litGpuMs, ft.litGpuMs);
          best.cpuMs = std::min(best.cpuMs, ft.cpuMs);
        }
        row.shadowMs += best.shadowGpuMs / poses;
        row.litMs += best.litGpuMs / poses;
        row.cpuMs += best.cpuMs / poses;
        row.triangles += double(harness.shadowTriangles()) / poses;
        csm::Camera accCam = cam;
        accCam.aspect = double(accuracyView.width) / accuracyView.height;
        csm::CascadeHistory ha;
        const csm::CascadeFrame frame = harness.computeFrame(accCam, light, ha);
        const std::vector<csm_measure::PixelSample> px =
            harness.renderAccuracy(accCam, frame, accuracyView, cfg.kernel);
        acc.merge(csm_measure::measureAccuracy(px, frame, tracer, light));
        if (p == 0) {
          // Shimmer at what the first pose sees, over a few frames of the path.
          std::vector<csm_measure::Receiver> rcv;
          const size_t step = std::max<size_t>(1, px.size() / 2000);
          for (size_t i = 0; i < px.size(); i += step) {
            rcv.push_back({px[i].posWs, px[i].normalWs, csm_measure::InstanceKind::kGround});
          }
          const csm_measure::ShimmerRun sh = csm_measure::measureShimmer(
              harness, rcv, light,
              [&](int f) {
                csm::Camera c = cameraAt(path->at(t + 2e-4 * f), aspect);
                c.aspect = accCam.aspect;
                return c;
              },
              shimmerFrames, cfg.kernel);
          row.shimmerMean = sh.total.stayed.mean();
          row.shimmerMax = sh.total.stayed.max;
        }
      }
      row.misclassification = acc.overall.rate();
      row.meanError = acc.overall.meanAbsError();
      row.pixels = acc.overall.pixels;
      rows.push_back(row);
    }
    progress(configs.size(), configs.size(), "done", elapsed());
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "device: %s; path %s, %d pose(s), view %ux%u (timing), %ux%u (accuracy)",
                  device.c_str(), o.path.c_str(), poses, o.width, o.height, accuracyView.width,
                  accuracyView.height);
    info = buf;
    std::ofstream(o.out + "/tradeoff_info.txt") << info << "\n";
  }

  // Pareto front of (GPU ms, misclassification): no other row is at least as fast and as
  // accurate and strictly better in one.
  for (Row& r : rows) {
    r.pareto = std::none_of(rows.begin(), rows.end(), [&](const Row& q) {
      return q.gpuMs() <= r.gpuMs() && q.misclassification <= r.misclassification &&
             (q.gpuMs() < r.gpuMs() || q.misclassification < r.misclassification);
    });
  }
  const std::string csv = o.out + "/tradeoff.csv";
  {
    std::ofstream f(csv);
    f << "cascades,resolution,lambda,kernel,blend_band,format,lods,shadow_gpu_ms,lit_gpu_ms,"
         "gpu_ms,cpu_ms,memory_mib,misclassification,mean_abs_error,shimmer_mean,shimmer_max,"
         "shadow_triangles,pixels,pareto,default,box_fit,ladder_steps,receiver_splits\n";
    for (const Row& r : rows) {
      const Config& c = r.config;
      char line[512];
      std::snprintf(line, sizeof line,
                    "%u,%u,%.2f,%s,%.2f,%s,%d,%.3f,%.3f,%.3f,%.3f,%.1f,%.5f,%.5f,%.3e,%.4f,%.0f,"
                    "%llu,%d,%d,%s,%.0f,%d\n",
                    c.cascades, c.resolution, c.lambda, csm::kernelName(c.kernel), c.blendBand,
                    c.format == VK_FORMAT_D16_UNORM ? "D16" : "D32", c.lods ? 1 : 0, r.shadowMs,
                    r.litMs, r.gpuMs(), r.cpuMs, r.memoryMiB, r.misclassification, r.meanError,
                    r.shimmerMean, r.shimmerMax, r.triangles, (unsigned long long)r.pixels,
                    r.pareto ? 1 : 0, c.isDefault() ? 1 : 0,
                    c.fit == csm::BoxFit::kTight ? "tight" : "sphere", c.ladderSteps,
                    c.receivers ? (c.histogram ? 2 : 1) : 0);
      f << line;
    }
  }
  // Table on stdout (Markdown), Pareto rows marked.
  std::printf("%s\n\n", info.c_str());
  std::printf(
      "| cascades | resolution | lambda | kernel | band | format | LODs | shadow ms | lit ms | "
      "CPU ms | MiB | misclassified | mean err | shimmer max | shadow tris | fit | front |\n"
      "|---:|---:|---:|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|\n");
  for (const Row& r : rows) {
    const Config& c = r.config;
    std::printf(
        "| %u | %u | %.2f | %s | %.2f | %s | %s | %.2f | %.2f | %.2f | %.0f | %.3f%% | %.4f | "
        "%.4f | %.0f | %s | %s |\n",
        c.cascades, c.resolution, c.lambda, csm::kernelName(c.kernel), c.blendBand,
        c.format == VK_FORMAT_D16_UNORM ? "D16" : "D32", c.lodLabel().c_str(), r.shadowMs, r.litMs,
        r.cpuMs, r.memoryMiB, 100.0 * r.misclassification, r.meanError, r.shimmerMax, r.triangles,
        c.fitLabel().empty() ? "-" : c.fitLabel().c_str() + 1,
        r.pareto ? (c.isDefault() ? "yes (default)" : "yes") : (c.isDefault() ? "(default)" : ""));
  }
  // The plot: every configuration (LODs on filled, off hollow), the front (sorted by time) as a
  // labelled line, the defaults circled.
  {
    std::vector<const Row*> front;
    for (const Row& r : rows)
      if (r.pareto) front.push_back(&r);
    std::sort(front.begin(), front.end(),
              [](const Row* a, const Row* b) { return a->gpuMs() < b->gpuMs(); });
    std::ofstream f(o.out + "/tradeoff_front.dat");
    for (const Row* r : front) {
      f << r->gpuMs() << "," << 100.0 * r->misclassification << "," << r->config.shortLabel()
        << "\n";
    }
  }
  // CSV columns: 7 lods, 10 gpu_ms, 13 misclassification, 20 default; 'every ::1' skips the
  // header line.
  const std::string gp =
      "set datafile separator ','\nset terminal pngcairo size 1000,680 font 'sans,10'\n"
      "set output '" +
      o.out +
      "/tradeoff.png'\nset termoption noenhanced\n"
      "set title \"csm_tradeoff: GPU time vs misclassified receiver pixels (Embree truth)\\n" +
      info +
      "\"\nset xlabel 'GPU ms per frame (shadow pass + lit pass), log scale'\n"
      "set ylabel 'misclassified receiver pixels (%), log scale'\n"
      "set logscale xy\nset grid\nset key below horizontal\n"
      "plot '" +
      csv +
      "' every ::1 u ($7==1?$10:1/0):($13*100) w p pt 7 ps 0.8 lc rgb '#999999' "
      "t 'caster LODs on', '" +
      csv +
      "' every ::1 u ($7==0?$10:1/0):($13*100) w p pt 6 ps 0.8 lc rgb '#555555' "
      "t 'caster LODs off', '" +
      o.out +
      "/tradeoff_front.dat' u 1:2 w lp pt 7 ps 1.2 lw 2 lc rgb '#1f77b4' t 'Pareto front', '" +
      o.out +
      "/tradeoff_front.dat' u 1:2:(int($0)%2==0?stringcolumn(3):'') w labels left offset 0.8,0.6 "
      "font 'sans,8' tc rgb '#1f4f7f' notitle, '" +
      o.out +
      "/tradeoff_front.dat' u 1:2:(int($0)%2==1?stringcolumn(3):'') w labels right offset "
      "-0.8,-0.6 font 'sans,8' tc rgb '#1f4f7f' notitle, '" +
      csv +
      "' every ::1 u ($20==1?$10:1/0):($13*100) w p pt 6 ps 3 lw 3 lc rgb '#d62728' "
      "t 'default: c4 r2048 l0.75 tent3x3 b0.10 D32 LODs on'\n";
  csm_measure::runGnuplot(o.out + "/tradeoff.gp", gp);
  std::printf("\nwrote %s and %s/tradeoff.png (%.0f s)\n", csv.c_str(), o.out.c_str(), elapsed());

  const Row* defaultRow = nullptr;
  for (const Row& r : rows)
    if (r.config.isDefault()) defaultRow = &r;
  for (const double budget : o.budgetsMs) {
    const Row* best = nullptr;
    for (const Row& r : rows) {
      if (r.gpuMs() <= budget &&
          (!best || r.misclassification < best->misclassification ||
           (r.misclassification == best->misclassification && r.gpuMs() < best->gpuMs()))) {
        best = &r;
      }
    }
    if (!best) {
      std::printf("\n--budget-ms %.2f: no configuration fits; the fastest measured costs %.2f ms\n",
                  budget,
                  std::min_element(rows.begin(), rows.end(), [](const Row& a, const Row& b) {
                    return a.gpuMs() < b.gpuMs();
                  })->gpuMs());
      continue;
    }
    size_t fits = 0;
    for (const Row& r : rows) fits += r.gpuMs() <= budget;
    std::printf(
        "\n--budget-ms %.2f: recommend %s\n  why: of the %zu measured configurations that fit "
        "(GPU shadow + lit pass <= %.2f ms on %s), it misclassifies the fewest receiver pixels "
        "against the ray-traced truth (%.3f%%, mean error %.4f) at %.2f ms (shadow %.2f, lit "
        "%.2f), %.0f MiB of shadow maps, %.0f shadow triangles, CPU %.2f ms, stabilised shimmer "
        "max %.4f.\n",
        budget, best->config.label().c_str(), fits, budget, device.c_str(),
        100.0 * best->misclassification, best->meanError, best->gpuMs(), best->shadowMs,
        best->litMs, best->memoryMiB, best->triangles, best->cpuMs, best->shimmerMax);
    // What more accuracy would cost: the cheapest configuration that beats it.
    const Row* better = nullptr;
    for (const Row& r : rows) {
      if (r.misclassification < best->misclassification &&
          (!better || r.gpuMs() < better->gpuMs())) {
        better = &r;
      }
    }
    if (better) {
      std::printf("  more accuracy: %s misclassifies %.3f%% but costs %.2f ms (%.2f ms over).\n",
                  better->config.label().c_str(), 100.0 * better->misclassification,
                  better->gpuMs(), better->gpuMs() - budget);
    } else {
      std::printf("  it is the most accurate configuration measured.\n");
    }
    if (defaultRow && defaultRow != best) {
      std::printf("  the default (%s) costs %.2f ms and misclassifies %.3f%%%s.\n",
                  defaultRow->config.label().c_str(), defaultRow->gpuMs(),
                  100.0 * defaultRow->misclassification,
                  defaultRow->gpuMs() > budget ? ": it does not fit" : "");
    } else if (defaultRow) {
      std::printf("  it is the default.\n");
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return engine::runMain([&] { return run(argc, argv); });
}
