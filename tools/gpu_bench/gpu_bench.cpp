// csm_gpu_bench: GPU milliseconds of the shadow pass and of the lit pass (timestamp queries) on
// a fixed synthetic scene (a plane with a 16 x 16 grid of spheres and boxes), for shadow-map
// resolutions 1024 / 2048 / 4096, cascade counts 1..4, every PCF kernel and per-layer vs layered
// rendering. The shadow pass does not depend on the kernel and the lit pass hardly depends on
// the resolution, so two tables are printed instead of the full cross product:
//   1. shadow pass (and lit pass with tent3x3) per resolution x cascade count x render mode;
//   2. lit pass per kernel x cascade count at 2048.
// Usage: csm_gpu_bench [--quick] [--frames N] [--width W --height H] [--kernel-cost ROUNDS]
// --kernel-cost prints only the lit pass of tent 3x3 / 5x5 / 7x7 and PCSS (4 cascades of 2048^2),
// measured in ROUNDS interleaved rounds (each round measures every kernel once), as the median
// and as a ratio to tent 3x3: a comparison that the machine's drift cannot bias.
#include <csm/core.hpp>
#include <csm/gpu_layout.hpp>
#include <csm/names.hpp>
#include <csm/vulkan/shadow_renderer.hpp>
#include <csm/vulkan/shadow_view.hpp>
#include <engine/camera.hpp>
#include <engine/context.hpp>
#include <engine/errors.hpp>
#include <engine/gpu_timer.hpp>
#include <engine/headless_target.hpp>
#include <engine/lit_pass.hpp>
#include <engine/mesh_store.hpp>
#include <sample_world/shadow_host.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

struct Options {
  bool quick = false;
  int frames = 3;
  uint32_t width = 1280;
  uint32_t height = 720;
};

void makeSphere(std::vector<engine::Vertex>& v, std::vector<uint32_t>& idx, int seg, int rings) {
  v.clear();
  idx.clear();
  for (int r = 0; r <= rings; ++r) {
    const double phi = glm::pi<double>() * r / rings;
    for (int s = 0; s <= seg; ++s) {
      const double th = 2.0 * glm::pi<double>() * s / seg;
      const glm::vec3 n(std::sin(phi) * std::cos(th), std::cos(phi), std::sin(phi) * std::sin(th));
      v.push_back({n, n});
    }
  }
  const uint32_t row = uint32_t(seg + 1);
  for (uint32_t r = 0; r < uint32_t(rings); ++r) {
    for (uint32_t s = 0; s < uint32_t(seg); ++s) {
      const uint32_t a = r * row + s, b = a + row;
      idx.insert(idx.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
  }
}

glm::mat3 scaleMat(const glm::dvec3& s) {
  return glm::mat3(glm::vec3(float(s.x), 0, 0), glm::vec3(0, float(s.y), 0),
                   glm::vec3(0, 0, float(s.z)));
}

class Bench {
 public:
  explicit Bench(const Options& o) : opt_(o) {
    engine::ContextDesc desc;
    desc.appName = "csm_gpu_bench";
    desc.validation = false;
    ctx_ = std::make_unique<engine::Context>(desc);
    engine::HeadlessDesc hd;
    hd.extent = {o.width, o.height};
    target_ = std::make_unique<engine::HeadlessTarget>(*ctx_, hd);
    timer_ = std::make_unique<engine::GpuTimer>(*ctx_, 8);
    meshes_ = std::make_unique<engine::MeshStore>(*ctx_, 1 << 18, 1 << 20, "bench meshes");

    view_ = world::createShadowView(*ctx_);
    buildScene();
    camera_.positionWs = {3.0, 12.0, 20.0};
    camera_.lookAt({0.0, 0.0, -60.0});
    camera_.aspect = double(o.width) / double(o.height);
    camera_.nearM = 0.1;
    camera_.farM = 1000.0;
    light_.directionWs = glm::normalize(glm::dvec3(0.5, -1.0, -0.3));
  }

  ~Bench() {
    ctx_->waitIdle();
    lit_.clear();
    view_.reset();
    meshes_.reset();
    timer_.reset();
    target_.reset();
    ctx_->shutdown();
  }

  bool layeredSupported() const { return ctx_->features().shaderOutputLayer; }
  std::string deviceName() const { return ctx_->properties().deviceName; }

  /// Average GPU ms of {shadow pass, lit pass} over opt_.frames frames after one warm-up.
  std::pair<double, double> measure(uint32_t resolution, uint32_t cascades, csm::PcfKernel kernel,
                                    csm::vk::RenderMode mode) {
    csm::ShadowSettings settings;
    settings.resolution = resolution;
    settings.cascadeCount = cascades;
    settings.shadowDistanceM = 200.0;
    csm::vk::RendererOptions options;
    options.renderMode = mode;
    const csm::vk::Status st = view_->setSettings(settings, options);
    if (!st.ok()) throw std::runtime_error("update: " + st.message());
    auto& lit = lit_[uint32_t(kernel)];
    if (!lit) {
      engine::LitPassDesc desc;
      desc.colorFormat = target_->colorFormat();
      desc.depthFormat = target_->depthFormat();
      desc.shadowSetLayout = view_->lightingSetLayout();
      desc.specialization = {{CSM_SPEC_KERNEL, uint32_t(kernel)}, {CSM_SPEC_BLEND, 1u}};
      lit = std::make_unique<engine::LitPass>(*ctx_, desc);
    }
    csm::Camera cam;
    cam.positionWs = camera_.positionWs;
    cam.orientationWs = camera_.orientation;
    cam.fovYRad = camera_.fovYRad;
    cam.aspect = camera_.aspect;
    cam.nearM = camera_.nearM;
    cam.farM = camera_.farM;
    view_->resetHistory();
    double shadowMs = 0.0, litMs = 0.0;
    for (int f = 0; f <= opt_.frames; ++f) {
      std::optional<engine::Frame> fr = target_->beginFrame();
      if (!fr) throw std::runtime_error("no frame");
      timer_->beginFrame(fr->cmd, fr->slot);
      timer_->begin(fr->cmd, "shadow");
      const csm::vk::Status s = view_->record(fr->cmd, cam, light_);
      if (!s.ok()) throw std::runtime_error("record: " + s.message());
      timer_->end(fr->cmd, "shadow");
      engine::LitFrame lf;
      lf.viewProjCr = camera_.viewProjectionCr();
      lf.cameraPositionWs = camera_.positionWs;
      lf.lightDirectionWs = glm::vec3(light_.directionWs);
      lit->prepare(fr->cmd, lf);
      timer_->begin(fr->cmd, "lit");
      engine::beginRendering(*fr, VkClearColorValue{{0.1f, 0.1f, 0.15f, 1.0f}});
      lit->draw(fr->cmd, *meshes_, view_->lightingSet(), litDraws_, fr->extent);
      vkCmdEndRendering(fr->cmd);
      timer_->end(fr->cmd, "lit");
      const uint32_t slot = fr->slot;
      target_->endFrame();
      target_->waitIdle();
      timer_->collect(slot);
      if (f == 0) continue;  // warm-up
      shadowMs += timer_->results().at("shadow");
      litMs += timer_->results().at("lit");
    }
    return {shadowMs / opt_.frames, litMs / opt_.frames};
  }

 private:
  void buildScene() {
    std::vector<engine::Vertex> v;
    std::vector<uint32_t> idx;
    v = {{{-1, 0, -1}, {0, 1, 0}},
         {{1, 0, -1}, {0, 1, 0}},
         {{1, 0, 1}, {0, 1, 0}},
         {{-1, 0, 1}, {0, 1, 0}}};
    idx = {0, 2, 1, 0, 3, 2};
    const engine::MeshRange plane = meshes_->upload(v, idx);
    makeSphere(v, idx, 32, 16);
    const engine::MeshRange sphere = meshes_->upload(v, idx);
    engine::makeCube(v, idx);
    const engine::MeshRange cube = meshes_->upload(v, idx);
    for (const engine::MeshRange& m : {plane, sphere, cube}) {
      csm::vk::MeshDraw d;
      d.vertexBuffer = meshes_->vertexBuffer();
      d.indexBuffer = meshes_->indexBuffer();
      d.firstIndex = m.firstIndex;
      d.indexCount = m.indexCount;
      d.vertexOffset = m.vertexOffset;
      casterMeshes_.push_back(d);
    }
    auto check = [](const csm::Result<uint32_t>& r) {
      if (!r.ok()) throw std::runtime_error(r.error().message());
    };
    const double half = 200.0;
    casters_.push_back({0, {0.0, 0.0, -100.0}, scaleMat({half, 1.0, half})});
    litDraws_.push_back(
        {plane, {0.0, 0.0, -100.0}, scaleMat({half, 1.0, half}), {0.8f, 0.8f, 0.8f, 1.0f}});
    check(casterSet_.addBox({-half, 0.0, -100.0 - half}, {half, 0.0, -100.0 + half}));
    for (int i = 0; i < 16; ++i) {
      for (int j = 0; j < 16; ++j) {
        const glm::dvec3 p(-90.0 + 12.0 * i, 0.0, 10.0 - 12.0 * j);
        if ((i + j) % 2 == 0) {
          const glm::dvec3 c = p + glm::dvec3(0.0, 2.5, 0.0);
          casters_.push_back({1, c, scaleMat(glm::dvec3(1.5))});
          litDraws_.push_back({sphere, c, scaleMat(glm::dvec3(1.5)), {0.9f, 0.3f, 0.2f, 1.0f}});
          check(casterSet_.addSphere(c, 1.5));
        } else {
          const glm::dvec3 size(2.0, 4.0, 2.0);
          const glm::dvec3 c = p + glm::dvec3(0.0, 2.0, 0.0);
          casters_.push_back({2, c, scaleMat(size)});
          litDraws_.push_back({cube, c, scaleMat(size), {0.2f, 0.4f, 0.9f, 1.0f}});
          check(casterSet_.addBox(c - 0.5 * size, c + 0.5 * size));
        }
      }
    }
    casterSet_.build();
    const csm::AabbWs bounds{{-half, 0.0, -100.0 - half}, {half, 6.0, -100.0 + half}};
    csm::vk::Status s = view_->setCasters(casterMeshes_, casters_, casterSet_);
    if (s.ok()) s = view_->setSceneBounds(&bounds);
    if (!s.ok()) throw std::runtime_error("ShadowView: " + s.message());
  }

  Options opt_;
  std::unique_ptr<engine::Context> ctx_;
  std::unique_ptr<engine::HeadlessTarget> target_;
  std::unique_ptr<engine::GpuTimer> timer_;
  std::unique_ptr<engine::MeshStore> meshes_;
  std::unique_ptr<csm::vk::ShadowView> view_;
  std::map<uint32_t, std::unique_ptr<engine::LitPass>> lit_;
  std::vector<csm::vk::MeshDraw> casterMeshes_;
  std::vector<csm::vk::CasterInstance> casters_;
  std::vector<engine::LitDraw> litDraws_;
  csm::CasterSet casterSet_;
  engine::Camera camera_;
  csm::DirectionalLight light_;
};

// Lit pass of the wide kernels against PCSS, interleaved (see the file comment).
int kernelCost(Bench& bench, int rounds) {
  const std::vector<csm::PcfKernel> kernels = {csm::PcfKernel::kTent3, csm::PcfKernel::kTent5,
                                               csm::PcfKernel::kTent7, csm::PcfKernel::kPcss};
  std::vector<std::vector<double>> ms(kernels.size());
  for (int r = 0; r < rounds; ++r) {
    for (size_t k = 0; k < kernels.size(); ++k) {
      ms[k].push_back(bench.measure(2048, 4, kernels[k], csm::vk::RenderMode::kPerLayer).second);
    }
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  };
  std::printf("lit pass, 4 cascades of 2048^2, %d interleaved rounds\n", rounds);
  std::printf(
      "| kernel | median lit ms | / tent3x3 (median of per-round ratios) |\n|---|---:|---:|\n");
  for (size_t k = 0; k < kernels.size(); ++k) {
    std::vector<double> ratio;
    for (int r = 0; r < rounds; ++r) ratio.push_back(ms[k][size_t(r)] / ms[0][size_t(r)]);
    std::printf("| %s | %.2f | %.2f |\n", csm::kernelName(kernels[k]), median(ms[k]),
                median(ratio));
  }
  return 0;
}

int run(int argc, char** argv) {
  Options o;
  int kernelCostRounds = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      o.quick = true;
    } else if (a == "--frames" && i + 1 < argc) {
      o.frames = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--width" && i + 1 < argc) {
      o.width = uint32_t(std::atoi(argv[++i]));
    } else if (a == "--height" && i + 1 < argc) {
      o.height = uint32_t(std::atoi(argv[++i]));
    } else if (a == "--kernel-cost" && i + 1 < argc) {
      kernelCostRounds = std::max(1, std::atoi(argv[++i]));
    } else {
      std::fprintf(stderr,
                   "usage: csm_gpu_bench [--quick] [--frames N] [--width W --height H] "
                   "[--kernel-cost ROUNDS]\n");
      return 2;
    }
  }
  if (o.quick) {
    o.frames = 1;
    o.width = 320;
    o.height = 180;
  }
  Bench bench(o);
  if (kernelCostRounds > 0) return kernelCost(bench, kernelCostRounds);
  const std::vector<uint32_t> resolutions =
      o.quick ? std::vector<uint32_t>{1024} : std::vector<uint32_t>{1024, 2048, 4096};
  const std::vector<uint32_t> counts =
      o.quick ? std::vector<uint32_t>{1, 4} : std::vector<uint32_t>{1, 2, 3, 4};
  std::vector<csm::vk::RenderMode> modes = {csm::vk::RenderMode::kPerLayer};
  if (bench.layeredSupported()) modes.push_back(csm::vk::RenderMode::kLayered);

  std::printf(
      "device: %s; view %ux%u; %d frame(s) averaged after 1 warm-up; GPU ms from "
      "timestamp queries\n\n",
      bench.deviceName().c_str(), o.width, o.height, o.frames);
  std::printf("1. shadow pass per resolution, cascades and render mode (lit pass: tent3x3)\n");
  std::printf(
      "| resolution | cascades | shadow ms per-layer | shadow ms layered | layered / "
      "per-layer | lit ms |\n|---:|---:|---:|---:|---:|---:|\n");
  for (uint32_t res : resolutions) {
    for (uint32_t c : counts) {
      double ms[2] = {0.0, 0.0};
      double litMs = 0.0;
      for (size_t m = 0; m < modes.size(); ++m) {
        const auto [s, l] = bench.measure(res, c, csm::PcfKernel::kTent3, modes[m]);
        ms[m] = s;
        litMs = l;
      }
      if (modes.size() > 1) {
        std::printf("| %u | %u | %.2f | %.2f | %.2f | %.2f |\n", res, c, ms[0], ms[1],
                    ms[1] / ms[0], litMs);
      } else {
        std::printf("| %u | %u | %.2f | n/a | n/a | %.2f |\n", res, c, ms[0], litMs);
      }
      std::fflush(stdout);
    }
  }
  const uint32_t litRes = o.quick ? 1024 : 2048;
  std::printf("\n2. lit pass per PCF kernel and cascades (shadow maps %u, per-layer)\n", litRes);
  std::printf("| kernel |");
  for (uint32_t c : counts) std::printf(" %u cascade(s) ms |", c);
  std::printf("\n|---|");
  for (size_t i = 0; i < counts.size(); ++i) std::printf("---:|");
  std::printf("\n");
  for (csm::PcfKernel k : csm::kAllKernels) {
    std::printf("| %s |", csm::kernelName(k));
    for (uint32_t c : counts) {
      std::printf(" %.2f |", bench.measure(litRes, c, k, csm::vk::RenderMode::kPerLayer).second);
      std::fflush(stdout);
    }
    std::printf("\n");
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return engine::runMain([&] { return run(argc, argv); });
}
