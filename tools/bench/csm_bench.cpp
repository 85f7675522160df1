// CPU benchmarks of the cascade math: per-frame setup, per-cascade culling and moving casters.
//   build/bin/csm_bench [--benchmark_filter=...]
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <map>
#include <random>

#include "csm/core.hpp"

namespace {

csm::Camera flyingCamera(int frame) {
  csm::Camera cam;
  cam.positionWs = {0.37 * frame, 30.0, -0.21 * frame};
  const double yaw = 0.01 * frame;
  cam.orientationWs =
      glm::angleAxis(yaw, glm::dvec3(0, 1, 0)) * glm::angleAxis(-0.15, glm::dvec3(1, 0, 0));
  cam.farM = 5000.0;
  return cam;
}

// Per-frame setup of 4 cascades: validation, splits, spheres, snapped matrices, depth ranges.
void BM_CascadeSetup(benchmark::State& state) {
  csm::ShadowSettings s;
  s.cascadeCount = static_cast<std::uint32_t>(state.range(0));
  const csm::DirectionalLight light{{0.3, -0.8, 0.2}};
  const csm::AabbWs scene{{-2000, -50, -2000}, {2000, 400, 2000}};
  csm::CascadeHistory history;
  int frame = 0;
  for (auto _ : state) {
    auto r = csm::computeCascades(s, flyingCamera(frame++ & 1023), light, &scene, &history);
    benchmark::DoNotOptimize(r);
  }
}
BENCHMARK(BM_CascadeSetup)->Arg(1)->Arg(4)->Arg(8);

// A world of `count` casters whose visible set does not depend on the world's size: the same
// casters lie around the camera in both, and every other caster is placed (by rejection)
// where it touches no cascade, spread over a square `scale` times as wide.
struct World {
  csm::CasterSet casters;
  csm::CascadeFrame frame;
};

World makeWorld(std::size_t count, double scale) {
  World w;
  csm::ShadowSettings s;
  s.cascadeCount = 4;
  s.shadowDistanceM = 400.0;
  csm::Camera cam;
  cam.positionWs = {0, 30, 0};
  cam.orientationWs = glm::angleAxis(-0.15, glm::dvec3(1, 0, 0));
  w.frame = csm::computeCascades(s, cam, csm::DirectionalLight{{0.3, -0.8, 0.2}}).value();

  std::mt19937_64 nearRng(1), farRng(2);
  const double baseHalfM = 0.5 * std::sqrt(static_cast<double>(count)) * 20.0;  // 20 m spacing
  const double nearHalfM = 500.0;
  const std::size_t nearCount = static_cast<std::size_t>(
      static_cast<double>(count) * (nearHalfM * nearHalfM) / (baseHalfM * baseHalfM));
  std::uniform_real_distribution<double> nearPos(-nearHalfM, nearHalfM), size(0.5, 6.0),
      farPos(-baseHalfM * scale, baseHalfM * scale);
  w.casters.reserve(count);
  for (std::size_t i = 0; i < nearCount && i < count; ++i) {
    (void)w.casters.addSphere({nearPos(nearRng), size(nearRng), nearPos(nearRng)}, size(nearRng));
  }
  csm::CasterSet probe;
  csm::CullResult probeOut;
  while (w.casters.size() < count) {
    const glm::dvec3 c(farPos(farRng), size(farRng), farPos(farRng));
    const double r = size(farRng);
    if (std::abs(c.x) < nearHalfM && std::abs(c.z) < nearHalfM) continue;
    probe.clear();
    (void)probe.addSphere(c, r);
    csm::cullCastersBruteForce(probe, w.frame, 0.0f, probeOut);
    bool visible = false;
    for (auto& v : probeOut.visible) visible = visible || !v.empty();
    if (!visible) (void)w.casters.addSphere(c, r);
  }
  w.casters.build();
  return w;
}

void BM_Cull(benchmark::State& state) {
  const auto count = static_cast<std::size_t>(state.range(0));
  const double scale = static_cast<double>(state.range(1));
  static std::map<std::pair<std::size_t, double>, World> cache;
  auto it = cache.find({count, scale});
  if (it == cache.end()) it = cache.emplace(std::pair{count, scale}, makeWorld(count, scale)).first;
  const World& w = it->second;
  csm::CullResult out;
  for (auto _ : state) {
    csm::cullCasters(w.casters, w.frame, 0.0f, out);
    benchmark::DoNotOptimize(out);
  }
  std::size_t visible = 0;
  for (auto& v : out.visible) visible += v.size();
  state.counters["visible"] = static_cast<double>(visible);
  state.counters["nodes"] = static_cast<double>(out.nodesVisited);
  state.counters["ns_per_caster"] =
      benchmark::Counter(static_cast<double>(count), benchmark::Counter::kIsIterationInvariantRate |
                                                         benchmark::Counter::kInvert);
}
BENCHMARK(BM_Cull)
    ->ArgsProduct({{10000, 100000, 1000000}, {1, 10}})
    ->ArgNames({"casters", "world"})
    ->Unit(benchmark::kMicrosecond);

void BM_CullBruteForce(benchmark::State& state) {
  const auto count = static_cast<std::size_t>(state.range(0));
  const World w = makeWorld(count, 1.0);
  csm::CullResult out;
  for (auto _ : state) {
    csm::cullCastersBruteForce(w.casters, w.frame, 0.0f, out);
    benchmark::DoNotOptimize(out);
  }
  state.counters["ns_per_caster"] =
      benchmark::Counter(static_cast<double>(count), benchmark::Counter::kIsIterationInvariantRate |
                                                         benchmark::Counter::kInvert);
}
BENCHMARK(BM_CullBruteForce)
    ->Arg(10000)
    ->Arg(100000)
    ->ArgName("casters")
    ->Unit(benchmark::kMicrosecond);

// Moving casters at what they cost (target: 10^5 static casters with 10^3 of them moved every
// frame, update + cull + plan in at most 0.3 ms): each frame moves `moved` casters of the world,
// spread over all of it (vehicles drive everywhere), by a metre along x (they return every 64
// frames, so the hierarchy's refitted nodes stay what a steady flow of traffic makes of them),
// plans the cached frame (csm::planCacheFrame: windows, stale texels, the budget; with `plan` 1)
// and culls the four cascades once, each in the plan's light basis.
void BM_MoveCasters(benchmark::State& state) {
  const auto count = static_cast<std::size_t>(state.range(0));
  const auto moved = static_cast<std::uint32_t>(state.range(1));
  const bool plan = state.range(2) != 0;
  World w = makeWorld(count, 1.0);
  std::vector<csm::AabbWs> home(count);
  for (std::uint32_t i = 0; i < count; ++i) home[i] = w.casters.bounds(i);
  const std::uint32_t stride = static_cast<std::uint32_t>(count) / moved;
  csm::CullResult out;
  csm::CacheState cache;
  std::array<glm::dmat3, csm::kMaxCascades> bases;
  std::uint64_t frame = 0;
  for (auto _ : state) {
    const glm::dvec3 d(static_cast<double>(frame++ % 64), 0.0, 0.0);
    for (std::uint32_t k = 0; k < moved; ++k) {
      const std::uint32_t i = k * stride;
      (void)w.casters.setBox(i, home[i].minWs + d, home[i].maxWs + d);
    }
    if (!plan) {
      csm::cullCasters(w.casters, w.frame, 0.0f, out);
      benchmark::DoNotOptimize(out);
      continue;
    }
    csm::CascadeFrame f = w.frame;
    const csm::CachePlan p =
        csm::planCacheFrame(f, cache, f.resolution, std::uint64_t(f.resolution) * f.resolution, 1);
    for (std::uint32_t c = 0; c < f.cascadeCount; ++c) bases[c] = p.cascades[c].basis;
    csm::cullCasters(w.casters, f, 0.0f, out, std::span(bases.data(), f.cascadeCount));
    csm::markCacheRecorded(p, cache);
    benchmark::DoNotOptimize(out);
  }
  std::size_t visible = 0;
  for (auto& v : out.visible) visible += v.size();
  state.counters["visible"] = static_cast<double>(visible);
  state.counters["nodes"] = static_cast<double>(out.nodesVisited);
}
BENCHMARK(BM_MoveCasters)
    ->Args({100000, 1000, 0})
    ->Args({100000, 1000, 1})
    ->Args({100000, 100, 1})
    ->Args({1000000, 1000, 1})
    ->ArgNames({"casters", "moved", "plan"})
    ->Unit(benchmark::kMicrosecond);

// The cache's plan of one frame alone (csm::planCacheFrame: 4 cascades of 2048^2, a camera
// flying 0.43 m a frame, so the boxes move and stale rows and columns are counted), on frames
// computed beforehand.
void BM_PlanCacheFrame(benchmark::State& state) {
  csm::ShadowSettings s;
  s.cascadeCount = 4;
  std::vector<csm::CascadeFrame> frames;
  for (int f = 0; f < 256; ++f) {
    frames.push_back(
        csm::computeCascades(s, flyingCamera(f), csm::DirectionalLight{{0.3, -0.8, 0.2}}).value());
  }
  csm::CacheState cache;
  std::size_t k = 0;
  std::uint64_t stale = 0;
  for (auto _ : state) {
    csm::CascadeFrame f = frames[k++ % frames.size()];
    const csm::CachePlan p = csm::planCacheFrame(f, cache, s.resolution, 0, 1);
    csm::markCacheRecorded(p, cache);
    stale += p.cascades[0].staleTexels;
    benchmark::DoNotOptimize(f);
  }
  state.counters["stale_c0"] =
      benchmark::Counter(static_cast<double>(stale), benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_PlanCacheFrame)->Unit(benchmark::kMicrosecond);

void BM_BuildHierarchy(benchmark::State& state) {
  World w = makeWorld(static_cast<std::size_t>(state.range(0)), 1.0);
  for (auto _ : state) w.casters.build();
}
BENCHMARK(BM_BuildHierarchy)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
