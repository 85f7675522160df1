// The shimmer scene and its camera motions (see motions.hpp).
#include "csm_measure/motions.hpp"

#include <engine/camera.hpp>
#include <glue/camera.hpp>

#include <cstdio>
#include <stdexcept>

namespace csm_measure {

glm::dvec3 originAt(double distanceM) {
  return distanceM * glm::dvec3(0.6, 0.0, -0.8);
}

csm::DirectionalLight testLight() {
  csm::DirectionalLight l;
  l.directionWs = glm::normalize(glm::dvec3(0.75, -0.6, 0.3));
  return l;
}

csm::Camera baseCamera(const glm::dvec3& originWs, double aspect) {
  engine::Camera e;
  e.positionWs = originWs + glm::dvec3(0.0, 7.0, 28.0);
  e.lookAt(originWs + glm::dvec3(0.0, 0.0, -25.0));
  e.fovYRad = glm::radians(60.0);
  e.aspect = aspect;
  e.nearM = 0.1;
  e.farM = 1000.0;
  return glue::toCsmCamera(e);
}

std::string distanceKey(double d) {
  if (d == 0.0) return "0";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.0e", d);
  return buf;
}

Scene setShimmerScene(Harness& harness, double distanceM) {
  TestSceneDesc sd;
  sd.originWs = originAt(distanceM);
  Scene scene = Scene::makeTestScene(sd);
  harness.setScene(scene);
  return scene;
}

std::vector<Receiver> viewReceivers(const Scene& scene, uint32_t count) {
  return scene.sampleReceivers(count, 0.3, {-45.0, -5.0, -100.0}, {45.0, 30.0, 15.0}, 7);
}

csm::Camera motionCamera(const std::string& motion, const glm::dvec3& origin, double texel0,
                         double texelLast, int f) {
  csm::Camera c = baseCamera(origin);
  const glm::dvec3 dir = glm::normalize(glm::dvec3(1.0, 0.15, -0.7));
  if (motion == "static") {
  } else if (motion == "subtexel") {
    c.positionWs += dir * (0.3 * texel0 * f);
  } else if (motion == "multitexel") {
    c.positionWs += dir * (3.3 * texelLast * f);
  } else if (motion == "yaw") {
    c.orientationWs = glm::angleAxis(glm::radians(0.35 * f), glm::dvec3(0, 1, 0)) * c.orientationWs;
  } else if (motion == "pitch") {
    c.orientationWs = c.orientationWs * glm::angleAxis(glm::radians(0.25 * f), glm::dvec3(1, 0, 0));
  } else if (motion == "orbit") {
    const glm::dvec3 target = origin + glm::dvec3(0.0, 0.0, -25.0);
    const glm::dquat r = glm::angleAxis(glm::radians(0.4 * f), glm::dvec3(0, 1, 0));
    engine::Camera e;
    e.positionWs = target + r * (c.positionWs - target);
    e.lookAt(target);
    c.positionWs = e.positionWs;
    c.orientationWs = e.orientation;
  } else if (motion == "zoom") {
    c.fovYRad = glm::radians(60.0 - 0.25 * f);
  } else {
    throw std::invalid_argument("motionCamera: unknown motion '" + motion +
                                "' (static, subtexel, multitexel, yaw, pitch, orbit, zoom)");
  }
  return c;
}

}  // namespace csm_measure
