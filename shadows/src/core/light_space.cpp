#include "csm/light_space.hpp"

#include <cmath>

namespace csm {

glm::dmat3 lightBasisWs(const glm::dvec3& directionWs) noexcept {
  const glm::dvec3 n = glm::normalize(directionWs);
  // Rotate world so that world -Y becomes +Z: (x, y, z) -> (x, z, -y) (a proper rotation), build
  // the Duff et al. basis there, and rotate back. The basis is smooth wherever n.y keeps its
  // sign and regular everywhere: the only division is by (sign + z'), which is >= 1 in size.
  const glm::dvec3 m(n.x, n.z, -n.y);
  const double sign = std::copysign(1.0, m.z);
  const double a = -1.0 / (sign + m.z);
  const double b = m.x * m.y * a;
  const glm::dvec3 t(1.0 + sign * m.x * m.x * a, sign * b, -sign * m.x);
  const glm::dvec3 u(b, sign + m.y * m.y * a, -m.y);
  // Back to world: (x', y', z') -> (x', -z', y').
  const glm::dvec3 rightWs(t.x, -t.z, t.y);
  const glm::dvec3 upWs(u.x, -u.z, u.y);
  return glm::dmat3(rightWs, upWs, n);
}

}  // namespace csm
