// A perspective camera at a double-precision world position. Rendering is camera-relative: the
// view matrix holds rotation only and positions reach the GPU as float offsets from the camera.
#pragma once

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace engine {

/// Right-handed, +Y up; the camera looks down its local -Z with +Y up and +X right.
struct Camera {
  glm::dvec3 positionWs{0.0};                  ///< world position, metres
  glm::dquat orientation{1.0, 0.0, 0.0, 0.0};  ///< camera-to-world rotation
  double fovYRad = glm::radians(60.0);         ///< vertical field of view
  double aspect = 16.0 / 9.0;                  ///< width / height
  double nearM = 0.1;                          ///< near plane distance, > 0
  double farM = 1000.0;                        ///< far plane distance, > near

  /// Sets the orientation from yaw (about world +Y, 0 looks down -Z, positive turns left), pitch
  /// (about the camera's X, positive looks up) and roll (about the view axis), in radians.
  void setYawPitchRoll(double yawRad, double pitchRad, double rollRad = 0.0);
  /// Turns the camera to look at `targetWs` with world +Y as up (no-op when the target is at the
  /// camera; a target straight above or below uses +Z as the up reference).
  void lookAt(const glm::dvec3& targetWs);

  /// Unit view direction in world space (camera -Z).
  glm::dvec3 forwardWs() const;
  /// Unit right direction in world space (camera +X).
  glm::dvec3 rightWs() const;
  /// Unit up direction in world space (camera +Y).
  glm::dvec3 upWs() const;

  /// World-to-view rotation only (camera-relative world space to view space), float.
  glm::mat4 viewRotation() const;
  /// Vulkan projection: depth in [0, 1] (near -> 0), clip y pointing down.
  glm::mat4 projection() const;
  /// projection() * viewRotation(): camera-relative world space to clip space.
  glm::mat4 viewProjectionCr() const;
  /// A world position relative to the camera, computed in double and rounded to float once.
  glm::vec3 toCameraRelative(const glm::dvec3& posWs) const;
};

}  // namespace engine
