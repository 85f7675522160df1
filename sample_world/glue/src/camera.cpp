#include "glue/camera.hpp"

namespace glue {
namespace {

// Copies what both cameras spell alike (the projection: field of view, aspect, near and far);
// the callers add the pose, whose orientation field is named differently on each side.
template <class To, class From>
To withProjection(const From& from) {
  To to;
  to.fovYRad = from.fovYRad;
  to.aspect = from.aspect;
  to.nearM = from.nearM;
  to.farM = from.farM;
  return to;
}

}  // namespace

csm::Camera toCsmCamera(const engine::Camera& camera) {
  csm::Camera c = withProjection<csm::Camera>(camera);
  c.positionWs = camera.positionWs;
  c.orientationWs = camera.orientation;
  return c;
}

engine::Camera toEngineCamera(const csm::Camera& camera) {
  engine::Camera e = withProjection<engine::Camera>(camera);
  e.positionWs = camera.positionWs;
  e.orientation = camera.orientationWs;
  return e;
}

}  // namespace glue
