// csm_flythrough: the headless loop along a named path (screenshots and report.json).
#include "flythrough_app.hpp"

#include <imgui.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "imgui_layer.hpp"
#include "sample_world/output_dir.hpp"

namespace flythrough {

namespace {

void savePng(const std::string& file, const engine::CpuImage& img) {
  if (auto e = world::writePngAtomically(file, img)) throw std::runtime_error(*e);
}

/// The statistics panel of an overlay screenshot: its rectangle (pixels), its text size and the
/// GPU times it printed (null where it printed "-": no measurement yet).
json panelJson(const StatsPanel& p) {
  json gpu = json::object();
  for (const auto& [scope, ms] : p.gpuMs) gpu[scope] = ms ? json(*ms) : json(nullptr);
  return {{"x", p.x},
          {"y", p.y},
          {"width", p.width},
          {"height", p.height},
          {"font_px", p.fontPixels},
          {"gpu_ms", gpu}};
}

/// The headless flight's GPU objects, and what it remembers between frames: which frame each
/// in-flight slot's timestamps belong to, the GPU times per frame, and the last frame's numbers
/// (the overlay of a screenshot shows them).
class HeadlessFlight {
 public:
  HeadlessFlight(engine::Context& ctx, const Options& o, const world::World& w, int frames)
      : o_(o),
        target_(ctx, {{o.settings.width, o.settings.height}, VK_FORMAT_D32_SFLOAT}),
        renderer_(ctx, w, target_.colorFormat(), target_.depthFormat()),
        gpuByFrame_(static_cast<std::size_t>(frames)) {
    if (auto e = renderer_.apply(o.settings)) throw UsageError(*e);
    timer_.emplace(ctx, 32);
    imgui_.emplace(ctx, target_.colorFormat(), nullptr);
    owner_.fill(-1);
  }

  const world::WorldRenderer& renderer() const { return renderer_; }
  const world::FrameStats& lastStats() const { return lastStats_; }

  /// Renders frame i of the flight (the measured frame) and returns its report entry.
  json renderFrame(int i, double t, const world::FlightPath& path, world::FrameStats& st) {
    const double aspect = double(o_.settings.width) / double(o_.settings.height);
    // The `day` and `cut` paths run in simulated time: kHeadlessFrameS a frame.
    const double seconds = i * world::kHeadlessFrameS;
    const int shot = path.shotAt(seconds);
    const bool cut = i > 0 && shot != shot_;
    shot_ = shot;
    const std::optional<world::SunPose> sun = path.sunAt(seconds);
    if (sun) {
      if (auto e = renderer_.setSun(*sun))
        throw std::runtime_error("frame " + std::to_string(i) + ": " + *e);
    }
    if (cut) renderer_.cameraCut();
    // The frame after a cut draws the cut's marks (and fits its range): one wait for it.
    if (renderer_.wantsLatestReceivers()) {
      target_.waitIdle();
      renderer_.takeLatestReceivers();
    }
    engine::Camera cam;
    poseCamera(cam, path.at(t, seconds), aspect, o_.settings);
    const auto cpu0 = Clock::now();
    if (auto e = renderer_.prepare(cam, st))
      throw std::runtime_error("frame " + std::to_string(i) + ": " + *e);
    std::optional<engine::Frame> f = target_.beginFrame();
    if (!f) throw std::runtime_error("headless target gave no frame");
    timer_->beginFrame(f->cmd, f->slot);
    takeGpu(f->slot);
    owner_[f->slot] = i;
    renderer_.record(*f, *timer_, false, st);
    const double cpuMs = std::chrono::duration<double, std::milli>(Clock::now() - cpu0).count();
    target_.endFrame();
    lastStats_ = st;
    lastCpuFrameMs_ = cpuMs;
    if (!timer_->results().empty()) lastGpu_ = timer_->results();
    json fj = frameJson(i, t, cam, st, cpuMs);
    fj["seconds"] = seconds;
    if (sun) fj["sun_deg"] = {{"azimuth", sun->azimuthDeg}, {"elevation", sun->elevationDeg}};
    if (path.cuts()) fj["shot"] = shot;
    if (cut) fj["camera_cut"] = true;
    if (st.cascades.lightStepped) fj["light_stepped"] = true;
    return fj;
  }

  /// Writes frame i's screenshots (plain, shadow factor, overlay) and returns their entry.
  json screenshots(int i, const world::FrameStats& st) {
    char name[64];
    std::snprintf(name, sizeof(name), "frame_%04d", i);
    const std::string base = (std::filesystem::path(o_.out) / name).string();
    engine::CpuImage plain = target_.readback();
    savePng(base + ".png", plain);
    const engine::CpuImage shadowView = renderVariant(false, csm::DebugMode::kShadowFactor, st);
    const auto [fraction, coverage] = shadowedFraction(shadowView);
    savePng(base + "_shadow.png", shadowView);
    const engine::CpuImage overlayImg = renderVariant(true, o_.settings.debug, st);
    savePng(base + "_overlay.png", overlayImg);
    return {{"frame", i},
            {"file", std::string(name) + ".png"},
            {"overlay_file", std::string(name) + "_overlay.png"},
            {"shadow_file", std::string(name) + "_shadow.png"},
            {"shadowed_fraction", fraction},
            {"geometry_coverage", coverage},
            {"overlay_panel", panelJson(panel_)}};
  }

  /// Waits for the GPU and returns the GPU times of every frame.
  const std::vector<std::map<std::string, double>>& finish() {
    target_.waitIdle();
    for (std::uint32_t s = 0; s < engine::kFramesInFlight; ++s) {
      if (owner_[s] >= 0) {
        timer_->collect(s);
        takeGpu(s);
      }
    }
    return gpuByFrame_;
  }

 private:
  void takeGpu(std::uint32_t slot) {
    if (owner_[slot] >= 0) {
      gpuByFrame_[static_cast<std::size_t>(owner_[slot])] = timer_->results();
    }
    owner_[slot] = -1;
  }

  // Renders the prepared frame once more (a screenshot variant), not counted in the report.
  engine::CpuImage renderVariant(bool overlay, csm::DebugMode debug, world::FrameStats stats) {
    world::AppSettings s = o_.settings;
    s.debug = debug;
    if (auto e = renderer_.apply(s)) throw std::runtime_error(*e);
    std::optional<engine::Frame> f = target_.beginFrame();
    if (!f) throw std::runtime_error("headless target gave no frame");
    timer_->beginFrame(f->cmd, f->slot);
    takeGpu(f->slot);
    renderer_.record(*f, *timer_, overlay, stats);
    if (overlay) {
      // An auto-sized ImGui window is measured in its first frame and drawn from the second.
      for (int warm = 0; warm < 2; ++warm) {
        if (warm == 1) imgui_->endFrame();
        imgui_->newFrame(f->extent, 1.0 / 30.0);
        panel_ = cascadeStatsWindow(lastStats_, *timer_, lastGpu_, lastCpuFrameMs_,
                                    engine::validationMessageCount(), true);
      }
      imgui_->endFrame();
      imgui_->record(*f);
    }
    target_.endFrame();
    engine::CpuImage img = target_.readback();
    if (auto e = renderer_.apply(o_.settings)) throw std::runtime_error(*e);
    return img;
  }

  const Options& o_;
  engine::HeadlessTarget target_;
  world::WorldRenderer renderer_;
  std::optional<engine::GpuTimer> timer_;  // created after the settings are applied
  std::optional<ImGuiLayer> imgui_;
  std::array<int, engine::kFramesInFlight> owner_{};
  int shot_ = 0;  // the `cut` path's shot of the last frame
  std::vector<std::map<std::string, double>> gpuByFrame_;
  std::map<std::string, double> lastGpu_;
  world::FrameStats lastStats_;
  double lastCpuFrameMs_ = 0.0;
  StatsPanel panel_;  // what the last overlay screenshot's statistics panel showed
};

}  // namespace

int runHeadless(const Options& o, const std::string& why) {
  if (!why.empty()) std::printf("%s\n", why.c_str());
  const int frames = o.frames > 0 ? o.frames : 120;
  // Order: the output folder is checked (nothing created), then the device is found, and only
  // then the folder is created and locked and the world built: no driver, no side effects.
  if (auto e = world::checkOutputDir(o.out)) throw UsageError(*e);
  engine::ContextDesc desc;
  desc.appName = "csm_flythrough";
  desc.validation = o.validation;
  engine::Context ctx(desc);
  world::OutputDirLock lock;
  if (auto e = lock.acquire(o.out)) throw UsageError(*e);
  const world::World w = makeWorld(o, o.path);
  const std::optional<world::FlightPath> path =
      world::FlightPath::make(o.path, w, o.settings.fovDeg, o.settings.clock);
  std::printf("device: %s, validation %s, %ux%u, %d frames along '%s'\n",
              ctx.properties().deviceName, ctx.validationEnabled() ? "on" : "off", o.settings.width,
              o.settings.height, frames, o.path.c_str());
  json report;
  std::vector<json> framesJson, shots;
  {
    HeadlessFlight flight(ctx, o, w, frames);
    auto prev = Clock::now();
    for (int i = 0; i < frames; ++i) {
      const double t = frames > 1 ? double(i) / double(frames - 1) : 0.0;
      world::FrameStats st;
      // The wall time of a frame runs from the end of the previous one to the end of this one.
      json fj = flight.renderFrame(i, t, *path, st);
      const auto now = Clock::now();
      fj["wall_ms"] = std::chrono::duration<double, std::milli>(now - prev).count();
      prev = now;
      framesJson.push_back(std::move(fj));
      const bool shot = (o.shotEvery > 0 ? i % o.shotEvery == 0 : i == 0) || i == frames - 1;
      if (shot) {
        shots.push_back(flight.screenshots(i, st));
        prev = Clock::now();
        framesJson.back()["screenshot"] = true;
      }
    }
    addGpuMs(framesJson, flight.finish());
    report["summary"] = summaryJson(framesJson, o.settings, flight.lastStats());
    // What makes the worst frames on the day and cut paths: camera cuts and light steps.
    int cuts = 0, steps = 0;
    for (const json& f : framesJson) {
      cuts += f.value("camera_cut", false) ? 1 : 0;
      steps += f.value("light_stepped", false) ? 1 : 0;
    }
    report["summary"]["camera_cuts"] = cuts;
    report["summary"]["light_steps"] = steps;
    report["world"] = worldJson(w, flight.renderer(), o.meshPath);
  }
  ctx.shutdown();
  const engine::ValidationCounts counts = engine::validationCounts();
  report["app"] = "csm_flythrough";
  report["device"] = ctx.properties().deviceName;
  report["path"] = o.path;
  report["frames"] = frames;
  report["view"] = {{"width", o.settings.width}, {"height", o.settings.height}};
  report["settings"] = world::settingsJson(o.settings);
  report["validation"] = {{"enabled", ctx.validationEnabled()},
                          {"messages", counts.warnings + counts.errors},
                          {"warnings", counts.warnings},
                          {"errors", counts.errors}};
  report["screenshots"] = shots;
  report["per_frame"] = framesJson;
  writeReport(report, o.out);
  return counts.warnings + counts.errors == 0 ? 0 : 1;
}

}  // namespace flythrough
