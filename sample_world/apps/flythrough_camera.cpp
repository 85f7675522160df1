// csm_flythrough: camera poses along a path, the window's input callbacks and the free-flight
// camera of the windowed loop.
#include "flythrough_app.hpp"

#include <GLFW/glfw3.h>
#include <imgui.h>

#include <algorithm>
#include <glm/glm.hpp>

namespace flythrough {

void poseCamera(engine::Camera& cam, const world::CameraPose& pose, double aspect,
                const world::AppSettings& s) {
  cam = world::poseCamera(pose, aspect, 0.5, s.farM);
}

Input* gInput = nullptr;
void onScroll(GLFWwindow*, double, double dy) {
  if (gInput) gInput->scroll += dy;
}
// Installed before ImGui, which chains to it: every press and release is seen, however short.
void onKey(GLFWwindow*, int key, int, int action, int) {
  if (gInput) gInput->keys.event(key, action != GLFW_RELEASE);
}
void onFocus(GLFWwindow*, int focused) {
  if (gInput && !focused) gInput->keys.releaseAll();
}

FlyCamera::FlyCamera(const world::CameraPose& start, GLFWwindow* win)
    : start_(start), pos_(start.positionWs), yaw_(start.yawRad), pitch_(start.pitchRad) {
  glfwGetCursorPos(win, &lastX_, &lastY_);
}

void FlyCamera::update(GLFWwindow* win, Input& input, const world::World& w, double dt,
                       world::AppSettings& live) {
  const ImGuiIO& io = ImGui::GetIO();
  double x = 0, y = 0;
  glfwGetCursorPos(win, &x, &y);
  const double dx = x - lastX_, dy = y - lastY_;
  lastX_ = x;
  lastY_ = y;
  const double ground = w.heightAt(pos_.x, pos_.z);
  const double speed = std::max(20.0, 0.8 * (pos_.y - ground)) *
                       (input.keys.active(GLFW_KEY_LEFT_SHIFT) ? 5.0 : 1.0);
  engine::Camera cam;
  cam.setYawPitchRoll(yaw_, pitch_);
  if (!io.WantCaptureMouse) {
    if (glfwGetMouseButton(win, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS) {
      yaw_ -= dx * 0.004;
      pitch_ = std::clamp(pitch_ - dy * 0.004, -1.55, 1.55);
    }
    if (glfwGetMouseButton(win, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS) {
      pos_ += (-dx * cam.rightWs() + dy * cam.upWs()) * (speed * 0.004);
    }
    pos_ += cam.forwardWs() * (input.scroll * speed * 0.25);
  }
  input.scroll = 0.0;
  if (!io.WantCaptureKeyboard) {
    // From key events: a tap shorter than a frame still moves the camera for one frame.
    auto key = [&](int k) { return input.keys.active(k) ? 1.0 : 0.0; };
    const glm::dvec3 move = cam.forwardWs() * (key(GLFW_KEY_W) - key(GLFW_KEY_S)) +
                            cam.rightWs() * (key(GLFW_KEY_D) - key(GLFW_KEY_A)) +
                            glm::dvec3(0, 1, 0) * (key(GLFW_KEY_E) - key(GLFW_KEY_Q));
    pos_ += move * speed * dt;
    if (input.keys.pressed(GLFW_KEY_R)) {
      pos_ = start_.positionWs;
      yaw_ = start_.yawRad;
      pitch_ = start_.pitchRad;
    }
    if (input.keys.pressed(GLFW_KEY_F1)) live.overlay = !live.overlay;
  }
  input.keys.endFrame();
}

void FlyCamera::cutTo(const world::CameraPose& pose) {
  start_ = pose;
  pos_ = pose.positionWs;
  yaw_ = pose.yawRad;
  pitch_ = pose.pitchRad;
}

engine::Camera FlyCamera::camera(const world::AppSettings& live, VkExtent2D extent) const {
  engine::Camera cam;
  cam.positionWs = pos_;
  cam.setYawPitchRoll(yaw_, pitch_);
  cam.fovYRad = glm::radians(live.fovDeg);
  cam.aspect = double(extent.width) / double(extent.height);
  cam.nearM = 0.5;
  cam.farM = live.farM;
  return cam;
}

}  // namespace flythrough
