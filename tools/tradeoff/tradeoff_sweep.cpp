// csm_tradeoff: the sweep (configurations measured on poses along a path).
#include "tradeoff.hpp"

#include <csm/names.hpp>
#include <csm/presets.hpp>
#include <csm_measure/bias_metrics.hpp>
#include <csm_measure/harness.hpp>
#include <csm_measure/metrics.hpp>
#include <csm_measure/raytracer.hpp>
#include <csm_measure/scene.hpp>
#include <csm_measure/soft_truth.hpp>
#include <csm_measure/world_scene.hpp>
#include <engine/camera.hpp>
#include <glue/camera.hpp>
#include <sample_world/settings.hpp>
#include <sample_world/world.hpp>

#include "receiver_histogram.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace tradeoff {

csm::Camera cameraAt(const world::CameraPose& p, double aspect) {
  return glue::toCsmCamera(world::poseCamera(p, aspect, 0.1, 5000.0));
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

std::vector<Config> sweepConfigs(const Options& o) {
  // Configurations: cascade count x resolution x caster LODs on/off at the other defaults, then
  // one axis at a time around the defaults (split lambda, kernel, blend band, depth format).
  std::vector<Config> configs;
  const std::vector<uint32_t> counts =
      o.quick ? std::vector<uint32_t>{1, 2, 4} : std::vector<uint32_t>{1, 2, 3, 4, 5, 6};
  const std::vector<uint32_t> resolutions =
      o.quick ? std::vector<uint32_t>{512, 1024, 2048}
              : std::vector<uint32_t>{512, 1024, 2048, 4096, 8192};
  if (o.presets) {
    // The quality tiers, cheapest first: what csm::presetConfig sets (cascades, resolution,
    // kernel) over the default configuration.
    for (csm::Preset p : csm::kAllPresets) {
      const csm::PresetConfig preset = csm::presetConfig(p);
      Config cfg;
      cfg.cascades = preset.settings.cascadeCount;
      cfg.resolution = preset.settings.resolution;
      cfg.kernel = preset.settings.kernel;
      configs.push_back(cfg);
    }
    return configs;
  }
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
    // The default with closed casters drawn whole (both faces), for the culling's cost.
    Config noCull;
    noCull.cullClosed = false;
    configs.push_back(noCull);
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
  // Every filter of the module other than the default's: the percentage-closer kernels and the
  // prefiltered filters (their moments resolved from the depth layers). --quick leaves the
  // prefiltered ones out: uncached, every frame resolves their moments (about 1.5 s a frame on
  // lavapipe at 4 x 2048^2).
  for (csm::PcfKernel k : csm::kAllFilters) {
    if (o.lodStudy) break;
    if (k == Config{}.kernel || (o.quick && csm::isPrefiltered(k))) continue;
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
    // The hard end of the shadows (no fade), as every sweep before the fade measured.
    Config cfg;
    cfg.fade = 0.0;
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
  return configs;
}

std::optional<int> parseTimingRounds(const std::string& value) {
  char* end = nullptr;
  errno = 0;
  const long n = std::strtol(value.c_str(), &end, 10);
  if (value.empty() || *end != '\0' || errno == ERANGE || n < 1 || n > 20) return std::nullopt;
  return int(n);
}

csm::ShadowSettings settingsOf(const Config& cfg) {
  csm::ShadowSettings s;
  s.cascadeCount = cfg.cascades;
  s.resolution = cfg.resolution;
  s.splitLambda = cfg.lambda;
  s.blendBand = cfg.blendBand;
  s.fadeFraction = cfg.fade;
  // A prefiltered filter is the settings' own (the renderer resolves its moments); the
  // percentage-closer kernels keep the settings' default and are chosen per render.
  if (csm::isPrefiltered(cfg.kernel)) s.kernel = cfg.kernel;
  s.boxFit = cfg.fit;
  s.receiverSplitScheme =
      cfg.histogram ? csm::ReceiverSplitScheme::kHistogram : csm::ReceiverSplitScheme::kRange;
  s.diagnostics.sizeLadder = cfg.ladderSteps > 0.0;
  s.diagnostics.cullClosedCasters = cfg.cullClosed;
  if (cfg.ladderSteps > 0.0) s.ladderStepsPerOctave = cfg.ladderSteps;
  return s;
}

csm::vk::RendererOptions rendererOptionsOf(const Config& cfg) {
  csm::vk::RendererOptions ro;
  ro.depthFormat = cfg.format;
  ro.lodMaxErrorTexels = cfg.lods ? cfg.maxErrorTexels : 0.0f;
  return ro;
}

namespace {

/// What every configuration of the sweep is measured with.
struct SweepRig {
  const Options& o;
  const csm_measure::WorldScene& worldScene;
  const csm_measure::RayTracer& tracer;
  csm_measure::Harness& harness;
  const world::FlightPath& path;
  int poses;
  int shimmerFrames;
  int kTimedFrames;
  VkExtent2D accuracyView;
  csm::DirectionalLight light;
  double aspect;
  std::array<uint32_t, csm::kMaxCascades> cascadeLod;
  /// Soft truth (sun 0.53 degrees, 256 rays per pixel) of each pose's receivers and a sample of
  /// their positions: they do not depend on the shadow settings, so it is traced once per pose.
  std::vector<std::vector<float>>& softTruth;
  std::vector<std::vector<glm::dvec3>>& softPositions;
};

/// Applies `cfg` to the rig's harness (settings, renderer options, caster LODs); returns the
/// settings, or nothing when the harness refuses them (printed).
std::optional<csm::ShadowSettings> configure(const SweepRig& rig, const Config& cfg) {
  csm_measure::Harness& harness = rig.harness;
  const csm::ShadowSettings s = settingsOf(cfg);
  harness.setReceiverRange(std::nullopt);
  const csm::vk::Status st = harness.configure(s, rendererOptionsOf(cfg));
  if (!st.ok()) {
    std::fprintf(stderr, "\nskipping %s: %s\n", cfg.label().c_str(), st.message().c_str());
    return std::nullopt;
  }
  std::array<uint32_t, csm::kMaxCascades> lodOfCascade = rig.cascadeLod;
  for (size_t c = 0; c < cfg.schedule.size() && c < csm::kMaxCascades; ++c) {
    lodOfCascade[c] = cfg.schedule[c];
  }
  harness.setCasterLods(cfg.lods ? rig.worldScene.lodMeshes : std::vector<std::vector<uint32_t>>{},
                        lodOfCascade,
                        cfg.lods ? rig.worldScene.lodErrorM : std::vector<std::vector<float>>{});
  return s;
}

/// The soft-shadow error of pose `p`'s accuracy pixels against the pose's soft truth (traced
/// on first use, and again when the receivers moved).
csm_measure::SoftErrorStats softErrorOfPose(const SweepRig& rig, int p,
                                            const std::vector<csm_measure::PixelSample>& px) {
  std::vector<float>& st = rig.softTruth[size_t(p)];
  std::vector<glm::dvec3>& sp = rig.softPositions[size_t(p)];
  bool same = st.size() == px.size();
  for (size_t i = 0; same && i < px.size(); i += 97) same = px[i].posWs == sp[i / 97];
  if (!same) {
    st = csm_measure::softTruthOfReceivers(px, rig.tracer, rig.light, 0.53);
    sp.clear();
    for (size_t i = 0; i < px.size(); i += 97) sp.push_back(px[i].posWs);
  }
  std::vector<float> compared = st;
  for (size_t i = 0; i < px.size(); ++i) {
    if (px[i].cascade < 0) compared[i] = -1.0f;
  }
  return csm_measure::measureSoftError(px, compared);
}

/// Shimmer at what a pose (path time `t`, accuracy pixels `px`) sees, over a few frames of the
/// path from there.
csm_measure::ShimmerRun shimmerFromPose(const SweepRig& rig, const Config& cfg, double t,
                                        double accuracyAspect,
                                        const std::vector<csm_measure::PixelSample>& px) {
  std::vector<csm_measure::Receiver> rcv;
  const size_t step = std::max<size_t>(1, px.size() / 2000);
  for (size_t i = 0; i < px.size(); i += step) {
    rcv.push_back({px[i].posWs, px[i].normalWs, csm_measure::InstanceKind::kGround});
  }
  return csm_measure::measureShimmer(
      rig.harness, rcv, rig.light,
      [&](int f) {
        csm::Camera c = cameraAt(rig.path.at(t + 2e-4 * f), rig.aspect);
        c.aspect = accuracyAspect;
        return c;
      },
      rig.shimmerFrames, cfg.kernel);
}

/// With `cfg.receivers`: the receiver range of pose `cam`'s full-range frame, as the depth
/// reduction reports it for the frame before, set on the harness.
void setPoseReceiverRange(const SweepRig& rig, const Config& cfg, const csm::ShadowSettings& s,
                          const csm::Camera& cam) {
  if (!cfg.receivers) return;
  csm_measure::Harness& harness = rig.harness;
  const VkExtent2D accuracyView = rig.accuracyView;
  harness.setReceiverRange(std::nullopt);
  csm::Camera rc = cam;
  rc.aspect = double(accuracyView.width) / accuracyView.height;
  csm::CascadeHistory hr;
  const csm::CascadeFrame fr = harness.computeFrame(rc, rig.light, hr);
  harness.setReceiverRange(receiverRangeOf(harness.renderAccuracy(rc, fr, accuracyView, cfg.kernel),
                                           rc, rc.nearM,
                                           std::max(s.shadowDistanceM, 2.0 * rc.nearM)));
}

/// Pose `cam`'s timings in the configured harness (the receiver range first, see
/// setPoseReceiverRange); then one warm-up frame and the fastest of kTimedFrames (lavapipe's
/// timings vary by tens of percent from frame to frame with the host's scheduling; the minimum
/// is stable).
csm_measure::FrameTimings timePose(const SweepRig& rig, const Config& cfg,
                                   const csm::ShadowSettings& s, const csm::Camera& cam) {
  csm_measure::Harness& harness = rig.harness;
  setPoseReceiverRange(rig, cfg, s, cam);
  csm::CascadeHistory h;
  const VkExtent2D view{rig.o.width, rig.o.height};
  harness.timeFrame(cam, rig.light, h, view, cfg.kernel);
  csm_measure::FrameTimings best{1e30, 1e30, 1e30};
  for (int k = 0; k < rig.kTimedFrames; ++k) {
    const csm_measure::FrameTimings ft = harness.timeFrame(cam, rig.light, h, view, cfg.kernel);
    best.shadowGpuMs = std::min(best.shadowGpuMs, ft.shadowGpuMs);
    best.litGpuMs = std::min(best.litGpuMs, ft.litGpuMs);
    best.cpuMs = std::min(best.cpuMs, ft.cpuMs);
  }
  return best;
}

/// One more round of `cfg`'s timings over every pose (averaged like measureConfig's), or
/// nothing when the harness refuses it.
std::optional<csm_measure::FrameTimings> timeConfig(const SweepRig& rig, const Config& cfg) {
  const std::optional<csm::ShadowSettings> settings = configure(rig, cfg);
  if (!settings) return std::nullopt;
  csm_measure::FrameTimings sum{0.0, 0.0, 0.0};
  for (int p = 0; p < rig.poses; ++p) {
    const csm::Camera cam = cameraAt(rig.path.at((p + 0.5) / rig.poses), rig.aspect);
    const csm_measure::FrameTimings t = timePose(rig, cfg, *settings, cam);
    sum.shadowGpuMs += t.shadowGpuMs / rig.poses;
    sum.litGpuMs += t.litGpuMs / rig.poses;
    sum.cpuMs += t.cpuMs / rig.poses;
  }
  return sum;
}

/// The row of one configuration, or nothing when the harness refuses it (printed).
std::optional<Row> measureConfig(const SweepRig& rig, const Config& cfg) {
  const csm_measure::RayTracer& tracer = rig.tracer;
  csm_measure::Harness& harness = rig.harness;
  const world::FlightPath* path = &rig.path;
  const int poses = rig.poses;
  const VkExtent2D accuracyView = rig.accuracyView;
  const csm::DirectionalLight light = rig.light;
  const double aspect = rig.aspect;
  const std::optional<csm::ShadowSettings> settings = configure(rig, cfg);
  if (!settings) return std::nullopt;
  const csm::ShadowSettings& s = *settings;
  Row row;
  row.config = cfg;
  row.memoryMiB = double(harness.shadowMapBytes()) / (1024.0 * 1024.0);
  csm_measure::AccuracyStats acc;
  csm_measure::SoftErrorStats soft;
  csm_measure::BiasStats bias;
  for (int p = 0; p < poses; ++p) {
    const double t = (p + 0.5) / poses;
    const csm::Camera cam = cameraAt(path->at(t), aspect);
    if (rig.o.timing) {
      const csm_measure::FrameTimings best = timePose(rig, cfg, s, cam);
      row.shadowMs += best.shadowGpuMs / poses;
      row.litMs += best.litGpuMs / poses;
      row.cpuMs += best.cpuMs / poses;
    } else {
      setPoseReceiverRange(rig, cfg, s, cam);
    }
    csm::Camera accCam = cam;
    accCam.aspect = double(accuracyView.width) / accuracyView.height;
    csm::CascadeHistory ha;
    const csm::CascadeFrame frame = harness.computeFrame(accCam, light, ha);
    const std::vector<csm_measure::PixelSample> px =
        harness.renderAccuracy(accCam, frame, accuracyView, cfg.kernel);
    row.triangles += double(harness.shadowTriangles()) / poses;
    acc.merge(csm_measure::measureAccuracy(px, frame, tracer, light));
    if (rig.o.bias) {
      // The prefiltered filters average over the pixel's footprint (its mip): a lit pixel within
      // that reach of a shadow reads part of it by design, not by acne.
      csm_measure::BiasTruthDesc bd;
      bd.footprintRadii = csm::isPrefiltered(cfg.kernel) ? csm_measure::kMipFootprintRadii : 0.0;
      const csm_measure::BiasTruth truth = csm_measure::computeBiasTruth(
          px, accuracyView.width, accuracyView.height, frame, tracer, light, bd);
      const csm_measure::BiasStats b = csm_measure::scoreBias(px, truth, light);
      bias.litInterior += b.litInterior;
      bias.litInteriorBelow099 += b.litInteriorBelow099;
      bias.contact += b.contact;
      bias.contactLit += b.contactLit;
    }
    const csm_measure::SoftErrorStats se = softErrorOfPose(rig, p, px);
    soft.pixels += se.pixels;
    soft.absErrorSum += se.absErrorSum;
    if (p == 0) {
      // Shimmer at what the first pose sees, over a few frames of the path.
      const csm_measure::ShimmerRun sh = shimmerFromPose(rig, cfg, t, accCam.aspect, px);
      row.shimmerMean = sh.total.stayed.mean();
      row.shimmerMax = sh.total.stayed.max;
    }
  }
  row.misclassification = acc.overall.rate();
  row.meanError = acc.overall.meanAbsError();
  row.softError = soft.meanAbsError();
  row.pixels = acc.overall.pixels;
  if (rig.o.bias) {
    row.acne = bias.below099();
    row.leak = bias.leaks();
  }
  return row;
}

/// `rounds` - 1 more timing rounds of `rows`, interleaved (every row again, in order); each row
/// keeps the median of its rounds (the sweep's own measurement is the first), and each round's
/// shadow ms go to stderr.
void retimeInRounds(const SweepRig& rig, std::vector<Row>& rows, int rounds,
                    const std::function<double()>& elapsed) {
  std::vector<std::array<std::vector<double>, 3>> ms(rows.size());
  for (size_t r = 0; r < rows.size(); ++r) {
    ms[r] = {{{rows[r].shadowMs}, {rows[r].litMs}, {rows[r].cpuMs}}};
  }
  const size_t total = rows.size() * size_t(rounds - 1);
  for (int round = 1; round < rounds; ++round) {
    for (size_t r = 0; r < rows.size(); ++r) {
      progress(size_t(round - 1) * rows.size() + r, total,
               "timing round " + std::to_string(round + 1) + ": " + rows[r].config.label(),
               elapsed());
      if (const std::optional<csm_measure::FrameTimings> t = timeConfig(rig, rows[r].config)) {
        ms[r][0].push_back(t->shadowGpuMs);
        ms[r][1].push_back(t->litGpuMs);
        ms[r][2].push_back(t->cpuMs);
      }
    }
  }
  progress(total, total, "done", elapsed());
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  };
  for (size_t r = 0; r < rows.size(); ++r) {
    rows[r].shadowMs = median(ms[r][0]);
    rows[r].litMs = median(ms[r][1]);
    rows[r].cpuMs = median(ms[r][2]);
    std::fprintf(stderr, "%-52s shadow ms per round:", rows[r].config.label().c_str());
    for (double v : ms[r][0]) std::fprintf(stderr, " %.2f", v);
    std::fprintf(stderr, "\n");
  }
}

}  // namespace

std::vector<Row> runSweep(const Options& o, std::string& info, std::string& device,
                          const std::function<double()>& elapsed) {
  return runSweep(o, sweepConfigs(o), info, device, elapsed);
}

std::vector<Row> runSweep(const Options& o, const std::vector<Config>& configs, std::string& info,
                          std::string& device, const std::function<double()>& elapsed) {
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
               scene.instances().size(), (unsigned long long)scene.triangleCount(), o.path.c_str(),
               elapsed());
  const csm_measure::RayTracer tracer(scene);

  csm_measure::HarnessDesc hd;
  hd.validation = false;
  hd.appName = "csm_tradeoff";
  // The prefiltered filters read the mip of each pixel's footprint, as the sample world's lit
  // pass does (the percentage-closer kernels read the same either way).
  hd.implicitLod = true;
  csm_measure::Harness harness(hd);
  harness.setScene(scene);
  const std::array<uint32_t, csm::kMaxCascades> cascadeLod = world::AppSettings().cascadeLod;
  device = harness.context().properties().deviceName;

  const int poses = o.poses > 0 ? o.poses : (o.quick ? 2 : 5);
  const int shimmerFrames = o.quick ? 4 : 8;
  const int kTimedFrames = 2;
  const VkExtent2D accuracyView = o.quick ? VkExtent2D{240, 135} : VkExtent2D{320, 180};
  const csm::DirectionalLight light{glm::normalize(glm::dvec3(0.45, -0.8, -0.35))};
  const double aspect = double(o.width) / double(o.height);
  std::vector<std::vector<float>> softTruth(static_cast<size_t>(poses));
  std::vector<std::vector<glm::dvec3>> softPositions(static_cast<size_t>(poses));
  const SweepRig rig{.o = o,
                     .worldScene = worldScene,
                     .tracer = tracer,
                     .harness = harness,
                     .path = *path,
                     .poses = poses,
                     .shimmerFrames = shimmerFrames,
                     .kTimedFrames = kTimedFrames,
                     .accuracyView = accuracyView,
                     .light = light,
                     .aspect = aspect,
                     .cascadeLod = cascadeLod,
                     .softTruth = softTruth,
                     .softPositions = softPositions};
  std::vector<Row> rows;
  for (size_t ci = 0; ci < configs.size(); ++ci) {
    progress(ci, configs.size(), configs[ci].label(), elapsed());
    if (std::optional<Row> row = measureConfig(rig, configs[ci])) rows.push_back(*row);
  }
  progress(configs.size(), configs.size(), "done", elapsed());
  if (o.timing && o.timingRounds > 1) retimeInRounds(rig, rows, o.timingRounds, elapsed);
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "device: %s; path %s, %d pose(s), view %ux%u (timing, median of %d round(s)), "
                "%ux%u (accuracy)",
                device.c_str(), o.path.c_str(), poses, o.width, o.height, o.timingRounds,
                accuracyView.width, accuracyView.height);
  info = buf;
  return rows;
}

}  // namespace tradeoff
