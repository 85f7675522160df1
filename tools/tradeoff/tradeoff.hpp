// csm_tradeoff's parts: the command line (tradeoff_cli.cpp), the sweep (tradeoff_sweep.cpp),
// the CSV, Pareto front, table, plot and advice (tradeoff_report.cpp) and the fit study
// (tradeoff_fit_study.cpp); csm_tradeoff.cpp runs the stages in order.
#pragma once

#include <csm/core.hpp>
#include <csm/gpu_layout.hpp>
#include <csm/vulkan/depth_format.hpp>
#include <csm/vulkan/shadow_renderer.hpp>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <optional>
#include <sample_world/paths.hpp>
#include <string>
#include <vector>

namespace tradeoff {

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
  /// --presets: only the module's quality tiers (csm::kAllPresets, cheapest first), each as
  /// csm::presetConfig sets it over the default configuration.
  bool presets = false;
  /// --timing-rounds N: after the sweep, N - 1 more rounds time every configuration again in
  /// the same order (interleaved), and each row's ms are the median over the N rounds, so no
  /// row is judged by where it fell in the run; [1, 20].
  int timingRounds = 1;
  /// --fit-resolution N: the fit study's shadow-map side for every configuration (0: the
  /// fly-through's, 2048); a power of two in [256, 16384].
  uint32_t fitResolution = 0;
  /// Acne and leaks (csm_measure's bias metrics) at each pose's accuracy pixels: Row::acne,
  /// Row::leak (csm_datasheet; off in the sweep, where the truth per configuration would double
  /// its time).
  bool bias = false;
  /// Time the configurations (shadow, lit and CPU ms); off: the accuracy columns alone (the
  /// datasheet's check), the ms columns 0.
  bool timing = true;
  /// Poses along the path (0: 5, or 2 with --quick).
  int poses = 0;
};

struct Config {
  uint32_t cascades = 4;
  uint32_t resolution = 2048;
  double lambda = 0.75;
  csm::PcfKernel kernel = csm::ShadowSettings{}.kernel;
  double blendBand = 0.1;
  /// ShadowSettings::fadeFraction: the fade to lit at the shadow distance (0: the hard cut).
  double fade = csm::ShadowSettings{}.fadeFraction;
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
  /// ShadowDiagnostics::cullClosedCasters: closed casters' faces turned away from the light culled
  /// in the depth pass (the default; the same map, fewer triangles rasterised).
  bool cullClosed = true;
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
           kernel == d.kernel && blendBand == d.blendBand && format == VK_FORMAT_D32_SFLOAT &&
           lods && schedule.empty() &&
           maxErrorTexels == csm::vk::RendererOptions{}.lodMaxErrorTexels && fit == d.boxFit &&
           ladderSteps == d.ladderStepsPerOctave && !receivers && cullClosed &&
           fade == d.fadeFraction;
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
    if (!cullClosed) s += " noCull";
    if (fade != csm::ShadowSettings{}.fadeFraction) {
      char buf[32];
      std::snprintf(buf, sizeof buf, " fade%.2g", fade);
      s += buf;
    }
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
    if (kernel != d.kernel) s += std::string(" ") + csm::kernelName(kernel);
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
                  csm::kernelName(kernel), blendBand, csm::vk::depthFormatName(format),
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
  double softError = -1;  ///< mean |s - v_soft| against a sun of 0.53 degrees; -1: not measured
  double shimmerMean = 0, shimmerMax = 0;
  /// With Options::bias: lit interior pixels facing the light shaded below 0.99
  /// (BiasStats::below099) and shadowed pixels next to a contact line shaded above 0.5
  /// (BiasStats::leaks), over every pose; -1: not measured.
  double acne = -1, leak = -1;
  double triangles = 0;  ///< triangles the shadow pass draws per frame (mean over poses)
  uint64_t pixels = 0;
  bool pareto = false;
  [[nodiscard]] double gpuMs() const { return shadowMs + litMs; }
};

// ---- The command line (tradeoff_cli.cpp)
void usage(std::FILE* out);
/// Reads the command line into `o`; returns the exit code when the program should stop (--help:
/// 0, an unknown argument: 2, with the usage printed).
std::optional<int> parseArgs(int argc, char** argv, Options& o);

/// The value of --timing-rounds: a whole number in [1, 20], else nothing (csm_tradeoff and
/// csm_datasheet print the refusal and exit 2).
std::optional<int> parseTimingRounds(const std::string& value);

// ---- The sweep (tradeoff_sweep.cpp)
csm::Camera cameraAt(const world::CameraPose& p, double aspect);
void progress(size_t done, size_t total, const std::string& what, double elapsedS);
/// The configurations to measure: cascade count x resolution x caster LODs, then one axis at a
/// time around the defaults (or the LOD study's schedules).
std::vector<Config> sweepConfigs(const Options& o);
/// Generates the world, measures every configuration on poses along the path and returns the
/// rows; `info` says what was measured where, `device` names the GPU.
std::vector<Row> runSweep(const Options& o, std::string& info, std::string& device,
                          const std::function<double()>& elapsed);
/// The same over the given configurations (csm_datasheet's rows).
std::vector<Row> runSweep(const Options& o, const std::vector<Config>& configs, std::string& info,
                          std::string& device, const std::function<double()>& elapsed);
/// The settings and renderer options of a configuration (what the sweep configures).
csm::ShadowSettings settingsOf(const Config& cfg);
csm::vk::RendererOptions rendererOptionsOf(const Config& cfg);

// ---- The CSV, the front, the table, the plot and the advice (tradeoff_report.cpp)
/// Rows of a CSV this tool wrote (for --replot).
std::vector<Row> readCsv(const std::string& path);
/// Marks the Pareto front of (GPU ms, misclassification).
void markParetoFront(std::vector<Row>& rows);
void writeCsv(const std::vector<Row>& rows, const std::string& csv);
/// The Markdown table on stdout, the front marked.
void printTable(const std::vector<Row>& rows, const std::string& info);
/// OUT/tradeoff_front.dat, OUT/tradeoff.gp and the gnuplot PNG OUT/tradeoff.png.
void writePlot(const std::vector<Row>& rows, const std::string& out, const std::string& csv,
               const std::string& info);
/// Per --budget-ms: the most accurate configuration that fits, and why.
void printAdvice(const std::vector<Row>& rows, const std::vector<double>& budgetsMs,
                 const std::string& device);

// ---- --fit-study (tradeoff_fit_study.cpp)
int runFitStudy(const Options& o);

}  // namespace tradeoff
