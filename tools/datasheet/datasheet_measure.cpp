// csm_datasheet's measurement: the rows' accuracy, bias and timings through csm_tradeoff's sweep
// on the sample world, then shimmer on the measurement test scene at three distances from the
// origin (csm_measure/motions.hpp).
#include "datasheet_measure.hpp"

#include <csm/names.hpp>
#include <csm_measure/harness.hpp>
#include <csm_measure/metrics.hpp>
#include <csm_measure/motions.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "datasheet.hpp"
#include "tradeoff.hpp"

namespace datasheet {

namespace {

// What the figures are measured on: the same in the full datasheet and the check.
constexpr int kPoses = 3;
constexpr uint32_t kShimmerReceivers = 1500;
constexpr int kShimmerFrames = 10;

// A figure rounded to 6 significant digits (the JSON stays readable; the check's tolerance is
// far wider).
double round6(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return std::stod(buf);
}

std::string cpuModel() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const size_t colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
    }
  }
  return "unknown";
}

tradeoff::Config configOf(const RowSpec& spec) {
  const csm::PresetConfig preset = csm::presetConfig(spec.preset);
  tradeoff::Config cfg;
  cfg.cascades = preset.settings.cascadeCount;
  cfg.resolution = preset.settings.resolution;
  cfg.kernel = spec.kernel;
  return cfg;
}

// Shimmer of every row: per distance (the scene set once), per row, per motion the fraction of
// stable receiver pairs that changed visibly and the mean change.
std::vector<nlohmann::json> measureShimmer(const std::vector<RowSpec>& specs,
                                           const std::function<double()>& elapsed) {
  std::vector<nlohmann::json> out(specs.size(), nlohmann::json::object());
  csm_measure::HarnessDesc hd;
  hd.validation = false;
  hd.appName = "csm_datasheet";
  csm_measure::Harness harness(hd);
  const csm::DirectionalLight light = csm_measure::testLight();
  size_t done = 0;
  const size_t total = std::size(kShimmerDistances) * specs.size();
  for (double distance : kShimmerDistances) {
    const glm::dvec3 origin = csm_measure::originAt(distance);
    const csm_measure::Scene scene = csm_measure::setShimmerScene(harness, distance);
    const std::vector<csm_measure::Receiver> receivers =
        csm_measure::viewReceivers(scene, kShimmerReceivers);
    for (size_t r = 0; r < specs.size(); ++r) {
      tradeoff::progress(done++, total,
                         "shimmer " + specs[r].name + " at " + csm_measure::distanceKey(distance),
                         elapsed());
      const tradeoff::Config cfg = configOf(specs[r]);
      // Through the cache: its layers (and a prefiltered filter's moments) are bit-identical to
      // a full render's (CacheWorld.*, every moment level), and it re-renders and re-resolves only
      // what each frame's motion exposed, which makes the prefiltered rows affordable in CI.
      csm::vk::RendererOptions ro = tradeoff::rendererOptionsOf(cfg);
      ro.cache = true;
      const csm::vk::Status st = harness.configure(tradeoff::settingsOf(cfg), ro);
      if (!st.ok()) throw std::runtime_error("shimmer: " + specs[r].name + ": " + st.message());
      csm::CascadeHistory h;
      const csm::CascadeFrame f0 = harness.computeFrame(csm_measure::baseCamera(origin), light, h);
      const double texel0 = f0.cascades[0].texelSizeM();
      const double texelLast = f0.cascades[f0.cascadeCount - 1].texelSizeM();
      for (const ShimmerMotion& m : kShimmerMotions) {
        const std::string motion = m.motion;
        const csm_measure::ShimmerRun run = csm_measure::measureShimmer(
            harness, receivers, light,
            [&](int f) { return csm_measure::motionCamera(motion, origin, texel0, texelLast, f); },
            kShimmerFrames, specs[r].kernel);
        // CSM_DATASHEET_SHIMMER_DEBUG=1: each visible change of a stable receiver, for diagnosis.
        if (std::getenv("CSM_DATASHEET_SHIMMER_DEBUG")) {
          for (const auto& c : run.visibleChanges) {
            const glm::dvec3 p = receivers[c.receiver].posWs - origin;
            std::fprintf(stderr,
                         "shimmer %s %s %s: frame %d receiver %zu (%.2f %.2f %.2f) cascade %d "
                         "%.5f -> %.5f depth gap %.3g m\n",
                         specs[r].name.c_str(), m.name, csm_measure::distanceKey(distance).c_str(),
                         c.frame, c.receiver, p.x, p.y, p.z, c.cascade, c.before, c.after,
                         c.depthGapM);
          }
        }
        out[r][m.name][csm_measure::distanceKey(distance)] = {
            {"visible", round6(run.total.stayed.visibleFraction())},
            {"mean", round6(run.total.stayed.mean())}};
      }
    }
  }
  tradeoff::progress(total, total, "done", elapsed());
  return out;
}

}  // namespace

std::vector<RowSpec> rowSpecs() {
  std::vector<RowSpec> specs;
  for (csm::Preset p : csm::kAllPresets) {
    specs.push_back({csm::presetName(p), p, csm::presetConfig(p).settings.kernel});
  }
  const csm::PcfKernel own = csm::presetConfig(csm::Preset::kHigh).settings.kernel;
  for (csm::PcfKernel k : csm::kAllFilters) {
    if (k == own) continue;
    specs.push_back({std::string(csm::presetName(csm::Preset::kHigh)) + " " + csm::kernelName(k),
                     csm::Preset::kHigh, k});
  }
  return specs;
}

nlohmann::json measure(const MeasureOptions& o, const std::function<double()>& elapsed) {
  std::vector<RowSpec> specs;
  for (const RowSpec& s : rowSpecs()) {
    if (o.onlyRows.empty() ||
        std::find(o.onlyRows.begin(), o.onlyRows.end(), s.name) != o.onlyRows.end()) {
      specs.push_back(s);
    }
  }
  for (const std::string& name : o.onlyRows) {
    if (std::none_of(specs.begin(), specs.end(),
                     [&](const RowSpec& s) { return s.name == name; })) {
      std::string all;
      for (const RowSpec& s : rowSpecs()) all += (all.empty() ? "" : ", ") + s.name;
      throw std::invalid_argument("--rows: no row '" + name + "' (rows: " + all + ")");
    }
  }
  std::vector<tradeoff::Config> configs;
  for (const RowSpec& s : specs) configs.push_back(configOf(s));

  tradeoff::Options to;
  to.path = "forest";
  to.bias = true;
  to.timing = o.timing;
  to.timingRounds = o.timingRounds;
  to.poses = kPoses;
  std::string info, device;
  std::vector<tradeoff::Row> rows = tradeoff::runSweep(to, configs, info, device, elapsed);
  if (rows.size() != specs.size()) throw std::runtime_error("a row's configuration was refused");
  if (o.timing) tradeoff::markParetoFront(rows);
  const std::vector<nlohmann::json> shimmer = measureShimmer(specs, elapsed);

  nlohmann::json sheet;
  sheet["command"] = o.command;
  sheet["machine"] = {{"device", device},
                      {"cpu", cpuModel()},
                      {"cores", std::max(1u, std::thread::hardware_concurrency())}};
  char shimmerWhat[400];
  std::snprintf(shimmerWhat, sizeof shimmerWhat,
                "the test scene (terrain and buildings) at 0, 1e6 and 1e7 m from the origin, %u "
                "receivers over the view, %d frames of each motion: translate 0.3 texel of "
                "cascade 0 a frame, rotate (yaw) 0.35° a frame, zoom 0.25° of field of view a "
                "frame; each row's own settings and filter, drawn through the cache (its "
                "layers are a full render's, bit for bit).",
                kShimmerReceivers, kShimmerFrames);
  sheet["measured"] = {{"path", to.path},
                       {"poses", kPoses},
                       {"accuracy_view", "320x180"},
                       {"timing_view", std::to_string(to.width) + "x" + std::to_string(to.height)},
                       {"timing_rounds", o.timing ? o.timingRounds : 0},
                       {"shimmer", shimmerWhat}};
  sheet["tolerance"] = {{"relative", kRelativeTolerance}, {"absolute", kAbsoluteTolerance}};
  nlohmann::json out = nlohmann::json::array();
  const csm::PcfKernel defaultKernel = csm::presetConfig(csm::Preset::kHigh).settings.kernel;
  for (size_t r = 0; r < specs.size(); ++r) {
    const tradeoff::Row& row = rows[r];
    nlohmann::json j;
    j["name"] = specs[r].name;
    j["preset"] = csm::presetName(specs[r].preset);
    j["filter"] = csm::kernelName(specs[r].kernel);
    j["cascades"] = row.config.cascades;
    j["resolution"] = row.config.resolution;
    j["default"] = specs[r].preset == csm::Preset::kHigh && specs[r].kernel == defaultKernel;
    j["figures"] = {{"memory_mib", round6(row.memoryMiB)},
                    {"misclassification", round6(row.misclassification)},
                    {"mean_abs_error", round6(row.meanError)},
                    {"mean_abs_error_soft", round6(row.softError)},
                    {"acne", round6(row.acne)},
                    {"leak", round6(row.leak)},
                    {"shimmer", shimmer[r]}};
    if (o.timing) {
      j["timing"] = {{"shadow_ms", round6(row.shadowMs)},
                     {"lit_ms", round6(row.litMs)},
                     {"cpu_ms", round6(row.cpuMs)},
                     {"front", row.pareto}};
    }
    out.push_back(j);
  }
  sheet["rows"] = out;
  return sheet;
}

}  // namespace datasheet
