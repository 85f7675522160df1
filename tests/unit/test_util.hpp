// Helpers shared by the unit tests: random cameras and an independent minimal-sphere reference.
#pragma once

#include <array>
#include <cmath>
#include <random>
#include <stdexcept>

#include "csm/core.hpp"

namespace csm::test {

inline glm::dquat randomOrientation(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  glm::dquat q(n(rng), n(rng), n(rng), n(rng));
  return glm::normalize(q);
}

// Orientation looking along `forward` (any non-zero vector, straight up/down included).
inline glm::dquat lookAlong(glm::dvec3 forward) {
  forward = glm::normalize(forward);
  const glm::dvec3 up = std::abs(forward.y) > 0.999 ? glm::dvec3(0, 0, 1) : glm::dvec3(0, 1, 0);
  const glm::dvec3 right = glm::normalize(glm::cross(forward, up));
  const glm::dvec3 camUp = glm::cross(right, forward);
  return glm::normalize(glm::quat_cast(glm::dmat3(right, camUp, -forward)));
}

struct Sphere {
  glm::dvec3 center{0.0};
  double radius = -1.0;
};

// Circumsphere of 1..4 points (smallest sphere with all of them on its surface).
inline bool circumsphere(const glm::dvec3* p, int n, Sphere& out) {
  if (n == 1) {
    out = {p[0], 0.0};
    return true;
  }
  if (n == 2) {
    out = {0.5 * (p[0] + p[1]), 0.5 * glm::length(p[1] - p[0])};
    return true;
  }
  const glm::dvec3 a = p[1] - p[0], b = p[2] - p[0];
  if (n == 3) {
    const glm::dvec3 axb = glm::cross(a, b);
    const double d = 2.0 * glm::dot(axb, axb);
    if (d < 1e-300) return false;
    const glm::dvec3 c =
        (glm::dot(a, a) * glm::cross(b, axb) + glm::dot(b, b) * glm::cross(axb, a)) / d;
    out = {p[0] + c, glm::length(c)};
    return true;
  }
  const glm::dvec3 c3 = p[3] - p[0];
  const double det = 2.0 * glm::dot(a, glm::cross(b, c3));
  if (std::abs(det) < 1e-300) return false;
  const glm::dvec3 c = (glm::dot(a, a) * glm::cross(b, c3) + glm::dot(b, b) * glm::cross(c3, a) +
                        glm::dot(c3, c3) * glm::cross(a, b)) /
                       det;
  out = {p[0] + c, glm::length(c)};
  return true;
}

// Brute-force minimal enclosing sphere: the smallest circumsphere of 2, 3 or 4 of the points
// that contains them all (the minimal sphere is always one of these).
template <std::size_t N>
Sphere bruteForceMinimalSphere(const std::array<glm::dvec3, N>& pts) {
  Sphere best;
  auto consider = [&](const glm::dvec3* sel, int n) {
    Sphere s;
    if (!circumsphere(sel, n, s)) return;
    if (best.radius >= 0.0 && s.radius >= best.radius) return;
    const double tol = 1e-9 * (s.radius + 1e-300);
    for (const auto& p : pts) {
      if (glm::length(p - s.center) > s.radius + tol) return;
    }
    best = s;
  };
  const int n = static_cast<int>(N);
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      const glm::dvec3 two[2] = {pts[i], pts[j]};
      consider(two, 2);
      for (int k = j + 1; k < n; ++k) {
        const glm::dvec3 three[3] = {pts[i], pts[j], pts[k]};
        consider(three, 3);
        for (int l = k + 1; l < n; ++l) {
          const glm::dvec3 four[4] = {pts[i], pts[j], pts[k], pts[l]};
          consider(four, 4);
        }
      }
    }
  return best;
}

inline CascadeFrame computeOrDie(const ShadowSettings& s, const Camera& c,
                                 const DirectionalLight& l, const AabbWs* scene = nullptr,
                                 CascadeHistory* h = nullptr) {
  auto r = computeCascades(s, c, l, scene, h);
  if (!r.ok()) throw std::runtime_error(r.error().message());
  return r.value();
}

inline bool allFinite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

}  // namespace csm::test
