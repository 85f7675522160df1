// csm_tradeoff: the sweep (configurations measured on poses along a path).
#include "tradeoff.hpp"

#include <cstdio>
#include <engine/camera.hpp>
#include <glue/camera.hpp>
#include <string>

namespace tradeoff {

csm::Camera cameraAt(const world::CameraPose& p, double aspect) {
  engine::Camera e;
  e.positionWs = p.positionWs;
  e.setYawPitchRoll(p.yawRad, p.pitchRad);
  e.fovYRad = glm::radians(p.fovDeg);
  e.aspect = aspect;
  e.nearM = 0.1;
  e.farM = 5000.0;
  return glue::toCsmCamera(e);
}

void progress(size_t done, size_t total, const std::string& what, double elapsedS) {
  const int width = 30;
  const int filled = total ? int(width * done / total) : width;
  const double eta = done ? elapsedS / double(done) * double(total - done) : 0.0;
  std::fprintf(stderr, "\r[%.*s%*s] %zu/%zu  %-44s eta %4.0f s", filled,
               "##############################", width - filled, "", done, total, what.c_str(),
               eta);
  if (done == total) std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

}  // namespace tradeoff
