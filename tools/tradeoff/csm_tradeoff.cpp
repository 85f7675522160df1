// csm_tradeoff: what each cascade setting costs and buys, measured. Flies a named path of the
// sample world (sample_world/) and, per configuration, measures on a few poses along it:
//   GPU ms of the shadow pass and of the lit pass (timestamp queries), CPU ms (cascade math,
//   culling, recording), shadow-map memory, misclassification rate and mean |s - v| of every
//   receiver pixel against Embree shadow rays (full-detail triangles), and stabilised shimmer
//   at the receivers the first pose sees, over a few frames of the path.
// Writes a CSV, marks the Pareto front of (GPU ms, misclassification), draws it with gnuplot
// (default settings marked) and, with --budget-ms, recommends the most accurate configuration
// that fits.
// Usage: csm_tradeoff [--quick] [--path NAME] [--out DIR] [--budget-ms X] [--width W --height H]
#include <csm_measure/harness.hpp>
#include <csm_measure/metrics.hpp>
#include <csm_measure/raytracer.hpp>
#include <csm_measure/scene.hpp>
#include <engine/camera.hpp>
#include <engine/errors.hpp>
#include <sample_world/paths.hpp>
#include <sample_world/world.hpp>

#include <algorithm>
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
  double budgetMs = -1.0;
  uint32_t width = 640, height = 360;
};

struct Config {
  uint32_t cascades = 4;
  uint32_t resolution = 2048;
  double lambda = 0.75;
  csm::PcfKernel kernel = csm::PcfKernel::kTent3;
  double blendBand = 0.1;
  VkFormat format = VK_FORMAT_D32_SFLOAT;
  [[nodiscard]] bool isDefault() const {
    const csm::ShadowSettings d;
    return cascades == d.cascadeCount && resolution == d.resolution && lambda == d.splitLambda &&
           kernel == csm::PcfKernel::kTent3 && blendBand == d.blendBand &&
           format == VK_FORMAT_D32_SFLOAT;
  }
  [[nodiscard]] std::string label() const {
    char buf[160];
    std::snprintf(buf, sizeof buf, "c%u r%u l%.2f %s b%.2f %s", cascades, resolution, lambda,
                  csm::kernelName(kernel), blendBand,
                  format == VK_FORMAT_D16_UNORM ? "D16" : "D32");
    return buf;
  }
};

struct Row {
  Config config;
  double shadowMs = 0, litMs = 0, cpuMs = 0;
  double memoryMiB = 0;
  double misclassification = 0, meanError = 0;
  double shimmerMean = 0, shimmerMax = 0;
  uint64_t pixels = 0;
  bool pareto = false;
  [[nodiscard]] double gpuMs() const { return shadowMs + litMs; }
};

// The sample world's caster clusters (terrain chunks and merged objects) as a measurement scene:
// full-detail meshes (LOD 0), the same triangles for the rasteriser and the ray tracer.
csm_measure::Scene sceneFromWorld(const world::World& w) {
  csm_measure::Scene scene;
  auto convert = [](const world::MeshData& m, const std::string& name) {
    csm_measure::MeshData out;
    out.name = name;
    out.vertices.reserve(m.positions.size());
    for (size_t i = 0; i < m.positions.size(); ++i) {
      out.vertices.push_back(
          {m.positions[i], i < m.normals.size() ? m.normals[i] : glm::vec3(0, 1, 0)});
    }
    out.indices = m.indices;
    return out;
  };
  std::vector<int32_t> assetMesh(w.meshes.size(), -1);
  for (const world::CasterCluster& c : w.clusters) {
    uint32_t mesh = 0;
    glm::mat3 linear(1.0f);
    glm::dvec3 translation = c.originWs;
    if (c.asset >= 0) {
      if (assetMesh[size_t(c.asset)] < 0) {
        assetMesh[size_t(c.asset)] = int32_t(scene.addMesh(
            convert(w.meshes[size_t(c.asset)].lods[0], w.meshes[size_t(c.asset)].name)));
      }
      mesh = uint32_t(assetMesh[size_t(c.asset)]);
      // Terrain chunk assets are placed by the object that uses them.
      for (const world::Object& o : w.objects) {
        if (o.mesh == uint32_t(c.asset)) {
          translation = o.translationWs;
          linear = o.linear;
          break;
        }
      }
    } else {
      if (c.lods[0].indices.empty()) continue;
      mesh = scene.addMesh(convert(c.lods[0], c.name));
    }
    scene.addInstance(
        {mesh,
         translation,
         linear,
         {0.6f, 0.65f, 0.5f, 1.0f},
         c.asset >= 0 ? csm_measure::InstanceKind::kGround : csm_measure::InstanceKind::kBuilding});
  }
  return scene;
}

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
    } else if (a == "--path") {
      o.path = next();
    } else if (a == "--out") {
      o.out = next();
    } else if (a == "--budget-ms") {
      o.budgetMs = std::stod(next());
    } else if (a == "--width") {
      o.width = uint32_t(std::stoul(next()));
    } else if (a == "--height") {
      o.height = uint32_t(std::stoul(next()));
    } else {
      std::fprintf(stderr,
                   "usage: csm_tradeoff [--quick] [--path NAME] [--out DIR] [--budget-ms X] "
                   "[--width W --height H]\n  paths:");
      for (const std::string& n : world::pathNames()) std::fprintf(stderr, " %s", n.c_str());
      std::fprintf(stderr, "\n");
      return 2;
    }
  }
  if (o.quick) {
    o.width = 320;
    o.height = 180;
  }
  std::filesystem::create_directories(o.out);
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };

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
  const csm_measure::Scene scene = sceneFromWorld(*w);
  std::fprintf(stderr, "world: %zu caster clusters, %llu triangles; path %s (%.1f s)\n",
               scene.instances().size(), (unsigned long long)scene.triangleCount(), o.path.c_str(),
               elapsed());
  const csm_measure::RayTracer tracer(scene);

  csm_measure::HarnessDesc hd;
  hd.validation = false;
  hd.appName = "csm_tradeoff";
  csm_measure::Harness harness(hd);
  harness.setScene(scene);
  const std::string device = harness.context().properties().deviceName;

  // Configurations: cascade count x resolution at the other defaults, then one axis at a time
  // around the defaults (split lambda, kernel, blend band, depth format).
  std::vector<Config> configs;
  const std::vector<uint32_t> counts =
      o.quick ? std::vector<uint32_t>{1, 2, 4} : std::vector<uint32_t>{1, 2, 3, 4, 5, 6};
  const std::vector<uint32_t> resolutions =
      o.quick ? std::vector<uint32_t>{512, 1024, 2048}
              : std::vector<uint32_t>{512, 1024, 2048, 4096, 8192};
  for (uint32_t c : counts) {
    for (uint32_t r : resolutions) {
      Config cfg;
      cfg.cascades = c;
      cfg.resolution = r;
      configs.push_back(cfg);
    }
  }
  for (double l : {0.0, 0.5, 1.0}) {
    Config cfg;
    cfg.lambda = l;
    configs.push_back(cfg);
  }
  for (csm::PcfKernel k : {csm::PcfKernel::k1Tap, csm::PcfKernel::kTent5, csm::PcfKernel::kTent7,
                           csm::PcfKernel::kPoisson16}) {
    Config cfg;
    cfg.kernel = k;
    configs.push_back(cfg);
  }
  for (double b : {0.0, 0.25}) {
    Config cfg;
    cfg.blendBand = b;
    configs.push_back(cfg);
  }
  {
    Config cfg;
    cfg.format = VK_FORMAT_D16_UNORM;
    configs.push_back(cfg);
  }

  const int poses = o.quick ? 2 : 5;
  const int shimmerFrames = o.quick ? 4 : 8;
  const VkExtent2D accuracyView = o.quick ? VkExtent2D{240, 135} : VkExtent2D{320, 180};
  const csm::DirectionalLight light{glm::normalize(glm::dvec3(0.45, -0.8, -0.35))};
  const double aspect = double(o.width) / double(o.height);

  std::vector<Row> rows;
  for (size_t ci = 0; ci < configs.size(); ++ci) {
    const Config& cfg = configs[ci];
    progress(ci, configs.size(), cfg.label(), elapsed());
    csm::ShadowSettings s;
    s.cascadeCount = cfg.cascades;
    s.resolution = cfg.resolution;
    s.splitLambda = cfg.lambda;
    s.blendBand = cfg.blendBand;
    csm::vk::RendererOptions ro;
    ro.depthFormat = cfg.format;
    const csm::vk::Status st = harness.configure(s, ro);
    if (!st.ok()) {
      std::fprintf(stderr, "\nskipping %s: %s\n", cfg.label().c_str(), st.message().c_str());
      continue;
    }
    Row row;
    row.config = cfg;
    row.memoryMiB = double(harness.shadowMapBytes()) / (1024.0 * 1024.0);
    csm_measure::AccuracyStats acc;
    for (int p = 0; p < poses; ++p) {
      const double t = (p + 0.5) / poses;
      const csm::Camera cam = cameraAt(path->at(t), aspect);
      csm::CascadeHistory h;
      // Timing: one warm-up frame, then the measured one.
      harness.timeFrame(cam, light, h, {o.width, o.height}, cfg.kernel);
      const csm_measure::FrameTimings ft =
          harness.timeFrame(cam, light, h, {o.width, o.height}, cfg.kernel);
      row.shadowMs += ft.shadowGpuMs / poses;
      row.litMs += ft.litGpuMs / poses;
      row.cpuMs += ft.cpuMs / poses;
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
    f << "cascades,resolution,lambda,kernel,blend_band,format,shadow_gpu_ms,lit_gpu_ms,"
         "gpu_ms,cpu_ms,memory_mib,misclassification,mean_abs_error,shimmer_mean,shimmer_max,"
         "pixels,pareto,default\n";
    for (const Row& r : rows) {
      const Config& c = r.config;
      char line[512];
      std::snprintf(
          line, sizeof line,
          "%u,%u,%.2f,%s,%.2f,%s,%.3f,%.3f,%.3f,%.3f,%.1f,%.5f,%.5f,%.3e,%.4f,%llu,%d,%d\n",
          c.cascades, c.resolution, c.lambda, csm::kernelName(c.kernel), c.blendBand,
          c.format == VK_FORMAT_D16_UNORM ? "D16" : "D32", r.shadowMs, r.litMs, r.gpuMs(), r.cpuMs,
          r.memoryMiB, r.misclassification, r.meanError, r.shimmerMean, r.shimmerMax,
          (unsigned long long)r.pixels, r.pareto ? 1 : 0, c.isDefault() ? 1 : 0);
      f << line;
    }
  }
  // Table on stdout (Markdown), Pareto rows marked.
  std::printf("device: %s; path %s, %d pose(s), view %ux%u (timing), %ux%u (accuracy)\n\n",
              device.c_str(), o.path.c_str(), poses, o.width, o.height, accuracyView.width,
              accuracyView.height);
  std::printf(
      "| config | shadow ms | lit ms | CPU ms | MiB | misclassified | mean err | "
      "shimmer max | front |\n|---|---:|---:|---:|---:|---:|---:|---:|---|\n");
  for (const Row& r : rows) {
    std::printf("| %s%s | %.2f | %.2f | %.2f | %.0f | %.3f%% | %.4f | %.4f | %s |\n",
                r.config.label().c_str(), r.config.isDefault() ? " (default)" : "", r.shadowMs,
                r.litMs, r.cpuMs, r.memoryMiB, 100.0 * r.misclassification, r.meanError,
                r.shimmerMax, r.pareto ? "yes" : "");
  }
  // The plot: every configuration, the front (sorted by time) as a line, the defaults circled.
  {
    std::vector<const Row*> front;
    for (const Row& r : rows)
      if (r.pareto) front.push_back(&r);
    std::sort(front.begin(), front.end(),
              [](const Row* a, const Row* b) { return a->gpuMs() < b->gpuMs(); });
    std::ofstream f(o.out + "/tradeoff_front.dat");
    for (const Row* r : front) f << r->gpuMs() << "," << 100.0 * r->misclassification << "\n";
  }
  std::string gp =
      "set terminal pngcairo size 1100,700 font 'sans,10'\nset output '" + o.out +
      "/tradeoff.png'\nset termoption noenhanced\nset title 'csm_tradeoff on " + device +
      ", path " + o.path +
      ": GPU ms (shadow + lit pass) vs misclassified receiver pixels'\n"
      "set xlabel 'GPU ms per frame (shadow pass + lit pass)'\nset ylabel 'misclassified (%)'\n"
      "set logscale x\nset yrange [0:*]\nset grid\nset key top right\n"
      "plot '" +
      csv +
      "' every ::1 u 9:($12*100) w p pt 7 ps 0.8 lc rgb '#999999' t 'configuration' "
      "noenhanced, '" +
      o.out +
      "/tradeoff_front.dat' u 1:2 w lp pt 7 ps 1.2 lw 2 lc rgb '#1f77b4' "
      "t 'Pareto front', '" +
      csv +
      "' every ::1 u ($18==1?$9:1/0):($12*100) w p pt 6 ps 3 lw 3 "
      "lc rgb '#d62728' t 'default settings'\n";
  // The CSV's header line is skipped by 'every ::1'; columns: 9 gpu_ms, 12 misclassification.
  std::string prelude = "set datafile separator ','\n";
  gp = prelude + gp;
  csm_measure::runGnuplot(o.out + "/tradeoff.gp", gp);
  std::printf("\nwrote %s and %s/tradeoff.png (%.0f s)\n", csv.c_str(), o.out.c_str(), elapsed());

  if (o.budgetMs > 0.0) {
    const Row* best = nullptr;
    for (const Row& r : rows) {
      if (r.gpuMs() <= o.budgetMs &&
          (!best || r.misclassification < best->misclassification ||
           (r.misclassification == best->misclassification && r.gpuMs() < best->gpuMs()))) {
        best = &r;
      }
    }
    if (!best) {
      std::printf("\n--budget-ms %.2f: no configuration fits; the fastest measured costs %.2f ms\n",
                  o.budgetMs,
                  std::min_element(rows.begin(), rows.end(), [](const Row& a, const Row& b) {
                    return a.gpuMs() < b.gpuMs();
                  })->gpuMs());
    } else {
      size_t fits = 0;
      for (const Row& r : rows) fits += r.gpuMs() <= o.budgetMs;
      std::printf(
          "\n--budget-ms %.2f: recommend %s\n  why: of the %zu measured configurations that fit "
          "(GPU shadow + lit pass <= %.2f ms on %s), it misclassifies the fewest receiver pixels "
          "against the ray-traced truth (%.3f%%, mean error %.4f) at %.2f ms (shadow %.2f, lit "
          "%.2f), %.0f MiB of shadow maps, CPU %.2f ms, stabilised shimmer max %.4f.\n",
          o.budgetMs, best->config.label().c_str(), fits, o.budgetMs, device.c_str(),
          100.0 * best->misclassification, best->meanError, best->gpuMs(), best->shadowMs,
          best->litMs, best->memoryMiB, best->cpuMs, best->shimmerMax);
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return engine::runMain([&] { return run(argc, argv); });
}
