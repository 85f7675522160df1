// The light's orthonormal basis and the world <-> light-space mapping.
#pragma once

#include "csm/types.hpp"

namespace csm {

/// Orthonormal, right-handed light basis: columns are right (x), up (y) and forward (z, the
/// direction light travels). Defined for every non-zero direction without a threshold: it uses
/// the branch-free construction of Duff et al. 2017 ("Building an Orthonormal Basis, Revisited")
/// about world -Y, so it is smooth over every light that shines downward (straight down
/// included) and over every light that shines upward, and changes branch only when the light
/// crosses the horizontal plane. Straight up, straight down and along any view are regular.
[[nodiscard]] glm::dmat3 lightBasisWs(const glm::dvec3& directionWs) noexcept;

/// World position -> light space about an origin: (dot(p - o, right), dot(p - o, up),
/// dot(p - o, forward)).
[[nodiscard]] inline glm::dvec3 toLightSpace(const glm::dmat3& basisWs, const glm::dvec3& originWs,
                                             const glm::dvec3& posWs) noexcept {
  return glm::transpose(basisWs) * (posWs - originWs);
}

}  // namespace csm
