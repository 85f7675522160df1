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
// receiver-driven splits one at a time around the defaults (4 cascades, 2048^2, lambda 0.75,
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

#include "tradeoff.hpp"

namespace tradeoff {

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
    for (int k = 0; k < 6; ++k) {
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
          double lo = 1e300, hi = 0.0;
          for (const csm_measure::PixelSample& p :
               harness.renderAccuracy(rc, fr, accuracyView, cfg.kernel)) {
            const double d = glm::dot(p.posWs - rc.positionWs, rc.forwardWs());
            lo = std::min(lo, d);
            hi = std::max(hi, d);
          }
          harness.setReceiverRange(hi >= lo ? std::optional<csm::ReceiverDepthRange>(
                                                  csm::ReceiverDepthRange{std::max(0.0, lo), hi})
                                            : std::nullopt);
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
                    c.receivers ? 1 : 0);
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

}  // namespace tradeoff

int main(int argc, char** argv) {
  return engine::runMain([&] { return tradeoff::run(argc, argv); });
}
