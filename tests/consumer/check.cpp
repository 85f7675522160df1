// Checks the consumer's image against the analytic answer: for every pixel that sees the ground,
// is the point in the box's shadow? Pixels within 2 shadow texels of the analytic edge are left
// out. Passes when >= 99.5% of the rest agree and both shadow and light are present.
//   csm_consumer_check IMAGE.png      exit 0 pass, 1 fail
#include <cmath>
#include <csm/core.hpp>
#include <cstdio>
#include <glm/gtc/matrix_transform.hpp>

#define STB_IMAGE_IMPLEMENTATION
#include <stb_image.h>

#include "scene.hpp"

namespace {

// Ray (origin o, direction d) against an AABB: entry distance, or -1 when missed.
double hitBox(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& lo,
              const glm::dvec3& hi) {
  double t0 = 0.0, t1 = 1e30;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-300) {
      if (o[a] < lo[a] || o[a] > hi[a]) return -1.0;
      continue;
    }
    double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return -1.0;
  }
  return t0;
}

// Analytic: is ground point p (local coordinates) in the box's shadow?
bool inShadow(const glm::dvec3& p) {
  return hitBox(p, -glm::normalize(scene::kLightDir), scene::kBoxMin, scene::kBoxMax) >= 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  int w = 0, h = 0, n = 0;
  unsigned char* px = stbi_load(argv[1], &w, &h, &n, 4);
  if (!px || w != scene::kWidth || h != scene::kHeight) {
    std::fprintf(stderr, "check: cannot read %s as a %dx%d image\n", argv[1], scene::kWidth,
                 scene::kHeight);
    return 1;
  }
  // The same camera and cascades as the consumer (local coordinates: origin at kOrigin).
  csm::Camera cam;
  cam.positionWs = scene::kOrigin + scene::kEye;
  const glm::dmat4 look =
      glm::lookAt(glm::dvec3(0.0), scene::kTarget - scene::kEye, glm::dvec3(0, 1, 0));
  cam.orientationWs = glm::quat_cast(glm::transpose(glm::dmat3(look)));
  cam.fovYRad = glm::radians(scene::kFovYDeg);
  cam.aspect = double(w) / h;
  cam.nearM = scene::kNearM;
  cam.farM = scene::kFarM;
  csm::ShadowSettings s;
  s.cascadeCount = scene::kCascades;
  s.resolution = scene::kResolution;
  s.shadowDistanceM = scene::kShadowDistanceM;
  const double g = scene::kGroundHalfM;
  const csm::AabbWs bounds{scene::kOrigin + glm::dvec3(-g, -0.5, -g),
                           scene::kOrigin + glm::dvec3(g, scene::kBoxMax.y, g)};
  const csm::CascadeFrame f =
      csm::computeCascades(s, cam, csm::DirectionalLight{scene::kLightDir}, &bounds).value();

  const double tanY = std::tan(cam.fovYRad / 2), tanX = tanY * cam.aspect;
  const glm::dvec3 fwd = cam.forwardWs(), right = cam.rightWs(), up = cam.upWs();
  const double slope = 1.0 / std::abs(glm::normalize(scene::kLightDir).y);
  long agree = 0, total = 0, shadowed = 0, lit = 0, edge = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double ndcX = (x + 0.5) / w * 2 - 1, ndcY = (y + 0.5) / h * 2 - 1;  // y down
      const glm::dvec3 d = glm::normalize(fwd + right * (ndcX * tanX) - up * (ndcY * tanY));
      const glm::dvec3 eye = scene::kEye;
      if (!(d.y < 0.0)) continue;
      const double tGround = -eye.y / d.y;
      const double tBox = hitBox(eye, d, scene::kBoxMin, scene::kBoxMax);
      if (tBox >= 0.0 && tBox < tGround) continue;  // the pixel sees the box, not the ground
      const glm::dvec3 p = eye + d * tGround;
      if (std::abs(p.x) > g - 0.5 || std::abs(p.z) > g - 0.5) continue;
      const csm::CascadeSelection sel =
          csm::selectCascade(f, csm::viewDepthM(f, scene::kOrigin + p), 0.0);
      if (sel.index < 0) continue;
      // Within 2 texels (as they land on the ground) of the shadow's edge: left out.
      const double r = 2.0 * f.cascades[sel.index].texelSizeM() * slope;
      const bool expected = inShadow(p);
      bool nearEdge = false;
      for (int k = 0; k < 16 && !nearEdge; ++k) {
        const double a = k * 3.14159265358979 / 8;
        nearEdge = inShadow(p + glm::dvec3(std::cos(a) * r, 0, std::sin(a) * r)) != expected;
      }
      if (nearEdge) {
        ++edge;
        continue;
      }
      const bool dark = px[(y * w + x) * 4] < 108;
      ++total;
      agree += dark == expected;
      (expected ? shadowed : lit) += 1;
    }
  }
  stbi_image_free(px);
  const double rate = total ? double(agree) / total : 0.0;
  std::printf(
      "check: %ld ground pixels (%ld in shadow, %ld lit, %ld near the edge left out): "
      "%.3f%% agree with the analytic shadow\n",
      total, shadowed, lit, edge, 100.0 * rate);
  return (rate >= 0.995 && shadowed >= 500 && lit >= 10000) ? 0 : 1;
}
