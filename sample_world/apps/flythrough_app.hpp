// csm_flythrough's parts, one file each: the command line (flythrough_cli.cpp), the report
// (flythrough_report.cpp), the ImGui panels (flythrough_ui.cpp), camera control and input
// (flythrough_camera.cpp), the headless loop (flythrough_headless.cpp) and the windowed loop
// (flythrough_windowed.cpp); flythrough.cpp holds main, the dispatch and the world set-up.
#pragma once

#include <chrono>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "engine/engine.hpp"
#include "sample_world/key_state.hpp"
#include "sample_world/paths.hpp"
#include "sample_world/settings.hpp"
#include "sample_world/world.hpp"
#include "sample_world/world_renderer.hpp"

struct GLFWwindow;

namespace flythrough {

using Clock = std::chrono::steady_clock;
using nlohmann::json;
constexpr int kExitUsage = 2;

/// A refused command line, config or mesh: printed, exit 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Options {
  bool headless = false;
  bool window = false;  // --window: insist on a window (error when there is no display)
  int frames = -1;      // headless: default 120; windowed: run until closed
  std::string out = "out";
  std::string path = "forest";
  int shotEvery = 0;  // 0: first and last frame only
  bool smokeTest = false;
  bool validation = false;
  world::AppSettings settings;
  std::string meshPath;
};

// ---- The command line (flythrough_cli.cpp)
std::string usage();
Options parse(int argc, char** argv);

// ---- The report (flythrough_report.cpp)
json finiteOrNull(double v);
/// Fraction of geometry pixels (grey in the shadow-factor debug view; the sky is blue) whose
/// shadow factor is below one half, and the fraction of the image that is geometry.
std::pair<double, double> shadowedFraction(const engine::CpuImage& img);
json cascadesJson(const world::FrameStats& st);
/// A measured frame's entry of per_frame (without wall_ms and gpu_ms, added later).
json frameJson(int i, double t, const engine::Camera& cam, const world::FrameStats& st,
               double cpuMs);
/// Adds gpu_ms (every scope the timer measured, "shadow" and "lit" always) to every frame.
void addGpuMs(std::vector<json>& framesJson,
              const std::vector<std::map<std::string, double>>& gpuByFrame);
/// Means and medians over the measured frames (those not followed by screenshot renders).
json summaryJson(const std::vector<json>& framesJson, const world::AppSettings& settings,
                 const world::FrameStats& lastStats);
/// The world's seed, size, origin, hash, object counts and caster triangles per LOD.
json worldJson(const world::World& w, const world::WorldRenderer& renderer,
               const std::string& meshPath);
/// Writes OUT/report.json (atomically) and prints the summary.
void writeReport(const json& report, const std::string& out);

// ---- The ImGui panels (flythrough_ui.cpp)
void keepOnScreen();
/// A GPU scope's time in `gpu` (the timer's results), or nothing where none was measured (yet):
/// the first frames, a scope that did not run, no timestamp support.
std::optional<double> gpuScopeMs(const std::map<std::string, double>& gpu,
                                 const std::string& scope);
/// What the statistics window showed: where (pixels, its size as laid out this frame), in which
/// text size, and the GPU time of each scope it printed (nothing: printed "-").
struct StatsPanel {
  float x = 0.0f, y = 0.0f, width = 0.0f, height = 0.0f;
  float fontPixels = 0.0f;
  std::map<std::string, std::optional<double>> gpuMs;
};
StatsPanel cascadeStatsWindow(const world::FrameStats& st, const engine::GpuTimer& timer,
                              const std::map<std::string, double>& gpu, double cpuFrameMs,
                              std::uint64_t validationMessages, bool pinned);
bool settingsPanel(world::AppSettings& s, const std::string& error);

// ---- Camera control and input (flythrough_camera.cpp)
void poseCamera(engine::Camera& cam, const world::CameraPose& pose, double aspect,
                const world::AppSettings& s);
struct Input {
  double scroll = 0.0;
  world::KeyState keys;
};
extern Input* gInput;
void onScroll(GLFWwindow*, double, double dy);
void onKey(GLFWwindow*, int key, int, int action, int);
void onFocus(GLFWwindow*, int focused);

/// The windowed flight's camera: LMB drag rotates, RMB drag pans, the wheel zooms, WASD/QE fly
/// (Shift faster), R returns to the path's start, F1 toggles the overlay.
class FlyCamera {
 public:
  FlyCamera(const world::CameraPose& start, GLFWwindow* win);
  /// One frame of input (mouse ignored while ImGui wants it, keys while it wants the keyboard).
  void update(GLFWwindow* win, Input& input, const world::World& w, double dt,
              world::AppSettings& live);
  /// The camera to render this frame with.
  [[nodiscard]] engine::Camera camera(const world::AppSettings& live, VkExtent2D extent) const;
  /// Jumps to `pose` (a camera cut on the `cut` path); R then returns there.
  void cutTo(const world::CameraPose& pose);

 private:
  world::CameraPose start_;
  glm::dvec3 pos_;
  double yaw_, pitch_;
  double lastX_ = 0, lastY_ = 0;
};

// ---- The world (flythrough.cpp) and the two loops
world::World makeWorld(const Options& o, const std::string& pathName);
int runHeadless(const Options& o, const std::string& why);  // flythrough_headless.cpp
int runWindowed(Options o);                                 // flythrough_windowed.cpp

}  // namespace flythrough
