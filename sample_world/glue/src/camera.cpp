#include "glue/camera.hpp"

namespace glue {

csm::Camera toCsmCamera(const engine::Camera& camera) {
  csm::Camera c;
  c.positionWs = camera.positionWs;
  c.orientationWs = camera.orientation;
  c.fovYRad = camera.fovYRad;
  c.aspect = camera.aspect;
  c.nearM = camera.nearM;
  c.farM = camera.farM;
  return c;
}

engine::Camera toEngineCamera(const csm::Camera& camera) {
  engine::Camera e;
  e.positionWs = camera.positionWs;
  e.orientation = camera.orientationWs;
  e.fovYRad = camera.fovYRad;
  e.aspect = camera.aspect;
  e.nearM = camera.nearM;
  e.farM = camera.farM;
  return e;
}

}  // namespace glue
