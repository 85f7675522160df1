// csm_tradeoff: what each cascade setting costs and buys, measured. Flies a named path of the
// sample world (sample_world/) and, per configuration, measures on a few poses along it:
//   GPU ms of the shadow pass and of the lit pass (timestamp queries), CPU ms (cascade math,
//   culling, recording), shadow-map memory, triangles the shadow pass draws, misclassification
//   rate and mean |s - v| of every receiver pixel against Embree shadow rays (full-detail
//   triangles, also with caster LODs on), mean |s - v_soft| against the sun as a 0.53 degree disk
//   (soft err: what PCSS is for), and stabilised shimmer at the receivers the first pose sees,
//   over a few frames of the path.
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

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "tradeoff.hpp"

namespace tradeoff {

int run(int argc, char** argv) {
  Options o;
  if (std::optional<int> exitCode = parseArgs(argc, argv, o)) return *exitCode;
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
    rows = runSweep(o, info, device, elapsed);
    std::ofstream(o.out + "/tradeoff_info.txt") << info << "\n";
  }
  markParetoFront(rows);
  const std::string csv = o.out + "/tradeoff.csv";
  writeCsv(rows, csv);
  printTable(rows, info);
  writePlot(rows, o.out, csv, info);
  std::printf("\nwrote %s and %s/tradeoff.png (%.0f s)\n", csv.c_str(), o.out.c_str(), elapsed());
  printAdvice(rows, o.budgetsMs, device);
  return 0;
}

}  // namespace tradeoff

int main(int argc, char** argv) {
  return engine::runMain([&] { return tradeoff::run(argc, argv); });
}
