// The consumer's scene, shared by the consumer (which renders it) and its checker (which knows
// the analytic answer). Everything sits 10^6 m from the world origin, to show that the module's
// camera-relative rendering needs nothing special from the host.
#pragma once

#include <glm/glm.hpp>

namespace scene {

inline constexpr int kWidth = 320;
inline constexpr int kHeight = 180;
inline const glm::dvec3 kOrigin{1.0e6, 0.0, -1.0e6};
// Ground: a square of half side 30 m at y = 0. Caster: a box floating above it.
inline constexpr double kGroundHalfM = 30.0;
inline const glm::dvec3 kBoxMin{-1.5, 1.0, -1.0};
inline const glm::dvec3 kBoxMax{1.5, 3.0, 1.0};
// Light direction (travel), camera placement.
inline const glm::dvec3 kLightDir{0.6, -1.0, 0.35};
inline const glm::dvec3 kEye{3.0, 10.0, 12.0};
inline const glm::dvec3 kTarget{1.5, 0.0, 1.0};
inline constexpr double kFovYDeg = 50.0;
inline constexpr double kNearM = 0.1;
inline constexpr double kFarM = 200.0;
// The module's settings the consumer uses (the checker needs them for texel sizes).
inline constexpr unsigned kCascades = 2;
inline constexpr unsigned kResolution = 1024;
inline constexpr double kShadowDistanceM = 60.0;

}  // namespace scene
