#include "csm/frustum.hpp"

#include <cmath>

namespace csm {

std::array<glm::dvec3, 8> sliceCornersCr(const Camera& camera, double nearM, double farM) noexcept {
  const double tanY = std::tan(camera.fovYRad * 0.5);
  const double tanX = tanY * camera.aspect;
  const glm::dmat3 rot = glm::mat3_cast(glm::normalize(camera.orientationWs));
  std::array<glm::dvec3, 8> corners{};
  static constexpr double kSx[4] = {-1.0, 1.0, 1.0, -1.0};
  static constexpr double kSy[4] = {-1.0, -1.0, 1.0, 1.0};
  for (int plane = 0; plane < 2; ++plane) {
    const double d = plane == 0 ? nearM : farM;
    for (int i = 0; i < 4; ++i) {
      corners[plane * 4 + i] = rot * glm::dvec3(kSx[i] * d * tanX, kSy[i] * d * tanY, -d);
    }
  }
  return corners;
}

SliceSphere minimalSliceSphere(double fovYRad, double aspect, double nearM, double farM) noexcept {
  const double tanY = std::tan(fovYRad * 0.5);
  // k^2: squared ratio of a corner's lateral distance to its depth.
  const double k2 = tanY * tanY * (1.0 + aspect * aspect);
  const double z = 0.5 * (nearM + farM) * (1.0 + k2);
  if (z < farM) {
    // Equidistant from the near and far corner circles; take the larger of the two computed
    // distances so rounding can never leave a corner outside.
    const double dn = std::sqrt((z - nearM) * (z - nearM) + nearM * nearM * k2);
    const double df = std::sqrt((farM - z) * (farM - z) + farM * farM * k2);
    return {z, std::max(dn, df)};
  }
  // The far corners' circle is a great circle of the sphere; the near corners lie inside it.
  return {farM, farM * std::sqrt(k2)};
}

double quantizeLengthUp(double lengthM) noexcept {
  if (!(lengthM > 0.0) || !std::isfinite(lengthM)) return lengthM;
  const int e = std::ilogb(lengthM);
  const double quantum = std::ldexp(1.0, e - 16);
  return std::ceil(lengthM / quantum) * quantum;
}

}  // namespace csm
