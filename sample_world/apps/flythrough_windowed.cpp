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

int runWindowed(Options o) {
  engine::ContextDesc desc;
  desc.appName = "csm_flythrough";
  desc.validation = o.validation;
  engine::WindowTarget::prepareContext(desc);
  engine::Context ctx(desc);  // no device: found before the world is built
  const world::World w = makeWorld(o, o.path);
  const std::optional<world::FlightPath> path =
      world::FlightPath::make(o.path, w, o.settings.fovDeg);
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

    const world::CameraPose start = path->at(0.0);
    glm::dvec3 pos = start.positionWs;
    double yaw = start.yawRad, pitch = start.pitchRad;
    double lastX = 0, lastY = 0;
    glfwGetCursorPos(target.window(), &lastX, &lastY);
    std::uint32_t generation = target.swapchainGeneration();
    world::FrameStats st;
    std::map<std::string, double> gpu;
    double cpuFrameMs = 0.0;
    int rendered = 0, attempts = 0;
    auto prev = Clock::now();
    while (!target.shouldClose()) {
      if (o.frames > 0 && (rendered >= o.frames || attempts++ > o.frames * 50)) break;
      target.pollEvents();
      GLFWwindow* win = target.window();
      if (input.keys.active(GLFW_KEY_ESCAPE)) break;
      if (o.smokeTest && o.frames > 0) {
        if (rendered == o.frames / 3)
          glfwSetWindowSize(win, int(o.settings.width) + 160, int(o.settings.height) + 90);
        if (rendered == o.frames / 2 && attempts % 4 == 0) glfwIconifyWindow(win);
        if (rendered == o.frames / 2 && attempts % 4 == 2) glfwRestoreWindow(win);
        // Down to 1x1 and back: the panels must stay on screen (keepOnScreen).
        if (rendered == (2 * o.frames) / 3) glfwSetWindowSize(win, 1, 1);
        if (rendered == (5 * o.frames) / 6)
          glfwSetWindowSize(win, int(o.settings.width), int(o.settings.height));
      }
      const auto now = Clock::now();
      const double dt = std::min(0.25, std::chrono::duration<double>(now - prev).count());
      prev = now;

      // ---- Input (ignored while ImGui wants it) ------------------------------------------------
      const ImGuiIO& io = ImGui::GetIO();
      double x = 0, y = 0;
      glfwGetCursorPos(win, &x, &y);
      const double dx = x - lastX, dy = y - lastY;
      lastX = x;
      lastY = y;
      const double ground = w.heightAt(pos.x, pos.z);
      const double speed = std::max(20.0, 0.8 * (pos.y - ground)) *
                           (input.keys.active(GLFW_KEY_LEFT_SHIFT) ? 5.0 : 1.0);
      engine::Camera cam;
      cam.setYawPitchRoll(yaw, pitch);
      if (!io.WantCaptureMouse) {
        if (glfwGetMouseButton(win, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS) {
          yaw -= dx * 0.004;
          pitch = std::clamp(pitch - dy * 0.004, -1.55, 1.55);
        }
        if (glfwGetMouseButton(win, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS) {
          pos += (-dx * cam.rightWs() + dy * cam.upWs()) * (speed * 0.004);
        }
        pos += cam.forwardWs() * (input.scroll * speed * 0.25);
      }
      input.scroll = 0.0;
      if (!io.WantCaptureKeyboard) {
        // From key events: a tap shorter than a frame still moves the camera for one frame.
        auto key = [&](int k) { return input.keys.active(k) ? 1.0 : 0.0; };
        const glm::dvec3 move = cam.forwardWs() * (key(GLFW_KEY_W) - key(GLFW_KEY_S)) +
                                cam.rightWs() * (key(GLFW_KEY_D) - key(GLFW_KEY_A)) +
                                glm::dvec3(0, 1, 0) * (key(GLFW_KEY_E) - key(GLFW_KEY_Q));
        pos += move * speed * dt;
        if (input.keys.pressed(GLFW_KEY_R)) {
          pos = start.positionWs;
          yaw = start.yawRad;
          pitch = start.pitchRad;
        }
        if (input.keys.pressed(GLFW_KEY_F1)) live.overlay = !live.overlay;
      }
      input.keys.endFrame();

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
      cam.positionWs = pos;
      cam.setYawPitchRoll(yaw, pitch);
      cam.fovYRad = glm::radians(live.fovDeg);
      cam.aspect = double(f->extent.width) / double(f->extent.height);
      cam.nearM = 0.5;
      cam.farM = live.farM;
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
