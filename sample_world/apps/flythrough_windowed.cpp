// csm_flythrough: the windowed loop (GLFW + Dear ImGui, mouse and keyboard flight).
#include "flythrough_app.hpp"

#include <GLFW/glfw3.h>
#include <imgui.h>

#include <algorithm>
#include <cstdio>
#include <optional>
#include <string>

#include "imgui_layer.hpp"

namespace flythrough {

namespace {

/// --smoke-test: resizes, minimises, restores, shrinks to 1x1 and restores the window at fixed
/// points of the run.
void smokeTestWindow(GLFWwindow* win, const Options& o, int rendered, int attempts) {
  if (rendered == o.frames / 3)
    glfwSetWindowSize(win, int(o.settings.width) + 160, int(o.settings.height) + 90);
  if (rendered == o.frames / 2 && attempts % 4 == 0) glfwIconifyWindow(win);
  if (rendered == o.frames / 2 && attempts % 4 == 2) glfwRestoreWindow(win);
  // Down to 1x1 and back: the panels must stay on screen (keepOnScreen).
  if (rendered == (2 * o.frames) / 3) glfwSetWindowSize(win, 1, 1);
  if (rendered == (5 * o.frames) / 6)
    glfwSetWindowSize(win, int(o.settings.width), int(o.settings.height));
}

}  // namespace

int runWindowed(Options o) {
  engine::ContextDesc desc;
  desc.appName = "csm_flythrough";
  desc.validation = o.validation;
  engine::WindowTarget::prepareContext(desc);
  engine::Context ctx(desc);  // no device: found before the world is built
  const world::World w = makeWorld(o, o.path);
  const std::optional<world::FlightPath> path =
      world::FlightPath::make(o.path, w, o.settings.fovDeg, o.settings.clock);
  std::printf("device: %s, validation %s\n", ctx.properties().deviceName,
              ctx.validationEnabled() ? "on" : "off");
  {
    engine::WindowTarget target(
        ctx, engine::WindowDesc{"csm_flythrough", int(o.settings.width), int(o.settings.height),
                                true, VK_FORMAT_D32_SFLOAT});
    Input input;
    gInput = &input;
    glfwSetScrollCallback(target.window(), onScroll);  // before ImGui, which chains to them
    glfwSetKeyCallback(target.window(), onKey);
    glfwSetWindowFocusCallback(target.window(), onFocus);
    world::WorldRenderer renderer(ctx, w, target.colorFormat(), target.depthFormat());
    if (auto e = renderer.apply(o.settings)) throw UsageError(*e);
    engine::GpuTimer timer(ctx, 32);
    ImGuiLayer imgui(ctx, target.colorFormat(), target.window());
    world::AppSettings live = o.settings;
    std::string error;

    FlyCamera fly(path->at(0.0), target.window());
    std::uint32_t generation = target.swapchainGeneration();
    world::FrameStats st;
    std::map<std::string, double> gpu;
    double cpuFrameMs = 0.0;
    int rendered = 0, attempts = 0;
    auto prev = Clock::now();
    // The `day` and `cut` paths run on the wall clock: the sun moves, the camera cuts.
    double seconds = 0.0;
    int shot = 0;
    while (!target.shouldClose()) {
      if (o.frames > 0 && (rendered >= o.frames || attempts++ > o.frames * 50)) break;
      target.pollEvents();
      GLFWwindow* win = target.window();
      if (input.keys.active(GLFW_KEY_ESCAPE)) break;
      if (o.smokeTest && o.frames > 0) smokeTestWindow(win, o, rendered, attempts);
      const auto now = Clock::now();
      const double dt = std::min(0.25, std::chrono::duration<double>(now - prev).count());
      prev = now;

      // ---- Input (ignored while ImGui wants it) ------------------------------------------------
      fly.update(win, input, w, dt, live);
      seconds += dt;
      if (path->cuts() && path->shotAt(seconds) != shot) {
        shot = path->shotAt(seconds);
        fly.cutTo(path->at(0.0, seconds));
        renderer.cameraCut();
      }
      if (const std::optional<world::SunPose> sun = path->sunAt(seconds)) {
        live.lightAzimuthDeg = sun->azimuthDeg;
        live.lightElevationDeg = sun->elevationDeg;
        if (auto e = renderer.setSun(*sun)) throw std::runtime_error(*e);
      }

      // ---- UI ----------------------------------------------------------------------------------
      imgui.newFrame(target.extent(), dt);
      const world::AppSettings before = live;
      if (settingsPanel(live, error) || live.overlay != before.overlay) {
        if (auto e = renderer.apply(live)) {
          error = *e;
          live = before;
        } else {
          error.clear();
        }
      }
      if (live.overlay)
        cascadeStatsWindow(st, timer, gpu, cpuFrameMs, engine::validationMessageCount(), false);
      imgui.endFrame();

      // The frame after a cut draws the cut's marks: wait for it (before this frame's slot is
      // begun, whose fence is reset then).
      if (renderer.wantsLatestReceivers()) {
        target.waitIdle();
        renderer.takeLatestReceivers();
      }
      std::optional<engine::Frame> f = target.beginFrame();
      if (target.swapchainGeneration() != generation) {
        target.waitIdle();
        imgui.releaseFramebuffers();
        generation = target.swapchainGeneration();
      }
      if (!f) {
        glfwWaitEventsTimeout(0.01);
        continue;
      }
      const engine::Camera cam = fly.camera(live, f->extent);
      const auto cpu0 = Clock::now();
      timer.beginFrame(f->cmd, f->slot);
      if (!timer.results().empty()) gpu = timer.results();
      if (auto e = renderer.prepare(cam, st)) throw std::runtime_error(*e);
      renderer.record(*f, timer, live.overlay, st);
      imgui.record(*f);
      cpuFrameMs = std::chrono::duration<double, std::milli>(Clock::now() - cpu0).count();
      target.endFrame();
      ++rendered;
    }
    target.waitIdle();
    gInput = nullptr;
    std::printf("frames rendered: %d, swapchain generations: %u\n", rendered,
                target.swapchainGeneration());
    if (o.frames > 0 && rendered < o.frames)
      throw std::runtime_error("could not render all frames");
  }
  ctx.shutdown();
  const engine::ValidationCounts counts = engine::validationCounts();
  std::printf("validation messages: %llu\n",
              static_cast<unsigned long long>(counts.warnings + counts.errors));
  return counts.warnings + counts.errors == 0 ? 0 : 1;
}

}  // namespace flythrough
