// csm_flythrough: camera poses along a path and the window's input callbacks.
#include "flythrough_app.hpp"

#include <GLFW/glfw3.h>

#include <glm/glm.hpp>

namespace flythrough {

void poseCamera(engine::Camera& cam, const world::CameraPose& pose, double aspect,
                const world::AppSettings& s) {
  cam.positionWs = pose.positionWs;
  cam.setYawPitchRoll(pose.yawRad, pose.pitchRad);
  cam.fovYRad = glm::radians(pose.fovDeg);
  cam.aspect = aspect;
  cam.nearM = 0.5;
  cam.farM = s.farM;
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

}  // namespace flythrough
