// The planes of the bias and flicker tests (issue 24): what a host builds first to try a shadow
// module, a ground plane with a few boxes and poles, flat or gently sloped, under a sun at any
// elevation and azimuth.
#pragma once

#include "stability_common.hpp"

namespace csm_stability {

// The planes' views: smaller than the other scenes' (the plane fills most of it; 20,000 and more
// lit pixels a case, and the matrix is large).
constexpr VkExtent2D kPlaneView{256, 144};

/// Direction the light travels for a sun `elevationDeg` above the horizon, from `azimuthDeg`
/// (0 = from +z, 90 = from +x). Exactly straight down at 90.
inline glm::dvec3 sunDirection(double elevationDeg, double azimuthDeg) {
  if (elevationDeg >= 90.0) return glm::dvec3(0.0, -1.0, 0.0);
  const double e = glm::radians(elevationDeg);
  const double a = glm::radians(azimuthDeg);
  const glm::dvec3 toLight(std::cos(e) * std::sin(a), std::sin(e), std::cos(e) * std::cos(a));
  return -toLight;
}

/// A gable roof: a triangular prism over the unit square, its ridge along z at x = 0, y = 1;
/// flat-shaded (each face its own vertices and normal), closed, wound outward.
inline csm_measure::MeshData makeRoofMesh() {
  csm_measure::MeshData m;
  m.name = "roof";
  auto face = [&](std::initializer_list<glm::vec3> ps) {
    const std::vector<glm::vec3> p(ps);
    const glm::vec3 n = glm::normalize(glm::cross(p[1] - p[0], p[2] - p[0]));
    const auto base = static_cast<uint32_t>(m.vertices.size());
    for (const glm::vec3& q : p) m.vertices.push_back({q, n});
    for (uint32_t k = 1; k + 1 < p.size(); ++k)
      m.indices.insert(m.indices.end(), {base, base + k, base + k + 1});
  };
  const glm::vec3 a(-0.5f, 0, -0.5f), b(0.5f, 0, -0.5f), c(0.5f, 0, 0.5f), d(-0.5f, 0, 0.5f);
  const glm::vec3 r0(0, 1, -0.5f), r1(0, 1, 0.5f);
  face({d, c, r1});      // gable +z
  face({b, a, r0});      // gable -z
  face({c, b, r0, r1});  // slope facing +x
  face({a, d, r1, r0});  // slope facing -x
  face({a, b, c, d});    // underside
  return m;
}

/// A host's first test scene: a ground plane 400 m wide, flat or tilted `slopeDeg` about the x
/// axis (rising away from the camera), with a few boxes (most with gable roofs) and poles.
inline csm_measure::Scene makePlaneScene(double slopeDeg) {
  csm_measure::Scene scene;
  const double s = glm::radians(slopeDeg);
  // Rotation about x taking +y to the plane's normal (0, cos s, sin s): the ground rises toward -z.
  const glm::mat3 tilt(glm::vec3(1, 0, 0), glm::vec3(0, float(std::cos(s)), float(std::sin(s))),
                       glm::vec3(0, -float(std::sin(s)), float(std::cos(s))));
  auto groundY = [&](double z) { return -z * std::tan(s); };
  const uint32_t ground = scene.addMesh(csm_measure::makeGroundMesh(false, 400.0, 16, 0.0, 0.0));
  const uint32_t cube = scene.addMesh(csm_measure::makeCubeMesh());
  const uint32_t roof = scene.addMesh(makeRoofMesh());
  scene.addInstance({ground,
                     glm::dvec3(0.0),
                     tilt,
                     {0.6f, 0.6f, 0.55f, 1.0f},
                     csm_measure::InstanceKind::kGround});
  struct Thing {
    double x, z, w, h, d;
  };
  // Boxes (2-6 m) and poles (0.2 m) scattered over the view, most of the ground left open.
  const Thing things[] = {
      {-8.0, -6.0, 3.0, 2.5, 2.0},  {9.0, -14.0, 4.0, 5.0, 3.0},  {-15.0, -30.0, 6.0, 4.0, 6.0},
      {18.0, -45.0, 5.0, 3.0, 4.0}, {-3.0, -70.0, 8.0, 6.0, 5.0}, {4.0, -3.0, 0.2, 4.0, 0.2},
      {-5.0, -20.0, 0.2, 6.0, 0.2}, {13.0, -28.0, 0.2, 5.0, 0.2}, {-22.0, -55.0, 0.2, 8.0, 0.2}};
  for (const Thing& t : things) {
    glm::mat3 m(1.0f);
    m[0][0] = float(t.w);
    m[1][1] = float(t.h);
    m[2][2] = float(t.d);
    // Sunk to the downhill side of its footprint (5 cm more): no gap under it on the slope.
    const double bottom = groundY(t.z) - 0.5 * t.d * std::tan(s) - 0.05;
    const glm::dvec3 c(t.x, bottom + 0.5 * t.h, t.z);
    const bool pole = t.w < 0.5;
    scene.addInstance(
        {cube,
         c,
         m,
         {0.4f, 0.4f, 0.45f, 1.0f},
         pole ? csm_measure::InstanceKind::kPole : csm_measure::InstanceKind::kBuilding});
    // Houses get a gable roof 40% of their width high (30-40 degree slopes): one slope faces
    // away from a sun across the ridge, the other grazes a low one.
    if (!pole && t.w < 7.0) {
      glm::mat3 rm(1.0f);
      rm[0][0] = float(t.w);
      rm[1][1] = float(0.4 * t.w);
      rm[2][2] = float(t.d);
      scene.addInstance({roof,
                         glm::dvec3(t.x, bottom + t.h, t.z),
                         rm,
                         {0.5f, 0.3f, 0.25f, 1.0f},
                         csm_measure::InstanceKind::kBuilding});
    }
  }
  return scene;
}

inline csm::Camera planeCamera() {
  engine::Camera e;
  e.positionWs = glm::dvec3(0.0, 5.0, 14.0);
  e.lookAt(glm::dvec3(0.0, 0.0, -25.0));
  e.fovYRad = glm::radians(60.0);
  e.aspect = double(kPlaneView.width) / kPlaneView.height;
  e.nearM = 0.1;
  e.farM = 1000.0;
  return glue::toCsmCamera(e);
}

/// A host's settings for the planes: 4 cascades over 200 m, everything else the module's
/// defaults (tent 3x3, the bias defaults).
inline csm::ShadowSettings planeSettings(bool stabilize) {
  csm::ShadowSettings s;
  s.cascadeCount = 4;
  s.resolution = 1024;
  s.shadowDistanceM = 200.0;
  s.diagnostics.stabilize = stabilize;
  return s;
}

}  // namespace csm_stability
