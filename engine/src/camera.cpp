#include "engine/camera.hpp"

#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <stdexcept>
#include <string>

namespace engine {
namespace {

void require(bool ok, const char* field, double value, const char* range) {
  if (!ok)
    throw std::invalid_argument(std::string("Camera::") + field + " = " + std::to_string(value) +
                                " is outside " + range);
}

}  // namespace

void Camera::setYawPitchRoll(double yawRad, double pitchRad, double rollRad) {
  orientation = glm::angleAxis(yawRad, glm::dvec3(0, 1, 0)) *
                glm::angleAxis(pitchRad, glm::dvec3(1, 0, 0)) *
                glm::angleAxis(rollRad, glm::dvec3(0, 0, 1));
}

void Camera::lookAt(const glm::dvec3& targetWs) {
  const glm::dvec3 d = targetWs - positionWs;
  const double len = glm::length(d);
  if (!(len > 0.0)) return;
  const glm::dvec3 f = d / len;
  // Straight up or down: world +Y is parallel to the view, use +Z as the up reference instead.
  const glm::dvec3 upRef = std::abs(f.y) > 0.999999 ? glm::dvec3(0, 0, 1) : glm::dvec3(0, 1, 0);
  const glm::dvec3 r = glm::normalize(glm::cross(f, upRef));
  const glm::dvec3 u = glm::cross(r, f);
  orientation = glm::normalize(glm::quat_cast(glm::dmat3(r, u, -f)));
}

glm::dvec3 Camera::forwardWs() const {
  return orientation * glm::dvec3(0, 0, -1);
}
glm::dvec3 Camera::rightWs() const {
  return orientation * glm::dvec3(1, 0, 0);
}
glm::dvec3 Camera::upWs() const {
  return orientation * glm::dvec3(0, 1, 0);
}

glm::mat4 Camera::viewRotation() const {
  return glm::mat4(glm::mat3_cast(glm::conjugate(glm::normalize(orientation))));
}

glm::mat4 Camera::projection() const {
  require(fovYRad > 0.0 && fovYRad < 3.14159, "fovYRad", fovYRad, "(0, pi)");
  require(aspect > 0.0 && std::isfinite(aspect), "aspect", aspect, "(0, inf)");
  require(nearM > 0.0 && std::isfinite(nearM), "nearM", nearM, "(0, farM)");
  require(farM > nearM && std::isfinite(farM), "farM", farM, "(nearM, inf)");
  glm::dmat4 p = glm::perspectiveRH_ZO(fovYRad, aspect, nearM, farM);
  p[1][1] = -p[1][1];  // Vulkan clip space: y points down
  return glm::mat4(p);
}

glm::mat4 Camera::viewProjectionCr() const {
  return projection() * viewRotation();
}

glm::vec3 Camera::toCameraRelative(const glm::dvec3& posWs) const {
  return glm::vec3(posWs - positionWs);
}

}  // namespace engine
