// Inputs of the cascade math: settings, camera, light and scene bounds, with their validation.
// World space is right-handed, +Y up, metres; world positions are double precision.
#pragma once

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include <array>
#include <cstdint>
#include <optional>

#include "csm/error.hpp"
#include "csm/shared_constants.h"

namespace csm {

inline constexpr std::uint32_t kMaxCascades = CSM_MAX_CASCADES;
inline constexpr std::uint32_t kMinResolution = 256;
inline constexpr std::uint32_t kMaxResolution = 16384;

/// What a host sets once and changes rarely. Every field is checked by validate(); nothing is
/// clamped silently.
struct ShadowSettings {
  /// Number of cascades, [1, CSM_MAX_CASCADES].
  std::uint32_t cascadeCount = 4;
  /// Side of every cascade's shadow map in texels: a power of two in [256, 16384].
  std::uint32_t resolution = 2048;
  /// Practical split blend: 0 = uniform, 1 = logarithmic, [0, 1].
  double splitLambda = 0.75;
  /// Distance along the view direction that shadows reach, metres; > camera near, finite.
  /// Clamped further (in quantised steps) to the camera's far plane and the scene's extent.
  double shadowDistanceM = 400.0;
  /// Width of the blend band at the far end of each cascade, as a fraction of that cascade's
  /// depth range, [0, 0.5]. 0 switches cascades with no blend.
  double blendBand = 0.1;
  /// Constant depth bias, in units of the depth format's minimum resolvable difference, >= 0.
  float depthBiasConstant = 1.0f;
  /// Slope-scaled depth bias (depthBiasSlopeFactor), >= 0.
  float depthBiasSlope = 1.5f;
  /// Normal-offset bias in texels of the receiver's cascade (scaled in the shader by the
  /// cascade's texel size and the kernel radius), >= 0.
  float normalOffsetTexels = 1.0f;
  /// Stabilised cascades (bounding sphere, whole-texel snapping). Off: tight fit, no snap
  /// (shimmers; kept for comparison).
  bool stabilize = true;
  /// Casters whose bounds span fewer than this many texels of a cascade are not drawn into it
  /// (they cannot show there). 0 turns the test off. [0, 1e6].
  float minCasterTexels = 0.0f;
  /// Explicit split positions instead of splitLambda (as Filament's cascadeSplitPositions): the
  /// first cascadeCount - 1 entries place the inner splits between the camera's near plane and
  /// the shadow far distance, as fractions in (0, 1), strictly increasing:
  /// split_i = near + splitPositions[i - 1] * (far - near). All 0 (the default): splitLambda
  /// places them. Entries past cascadeCount - 1 are ignored.
  std::array<double, kMaxCascades - 1> splitPositions{};

  /// Whether splitPositions is in use (any of its first cascadeCount - 1 entries is non-zero).
  [[nodiscard]] bool explicitSplits() const noexcept {
    for (std::uint32_t i = 0; i + 1 < cascadeCount && i < kMaxCascades - 1; ++i) {
      if (splitPositions[i] != 0.0) return true;
    }
    return false;
  }
};

/// A perspective camera. Looks down its local -Z with +Y up (the GLM/Vulkan view convention).
struct Camera {
  glm::dvec3 positionWs{0.0};
  /// Rotation from camera space to world space (unit quaternion).
  glm::dquat orientationWs{1.0, 0.0, 0.0, 0.0};
  /// Vertical field of view in radians, (0, pi).
  double fovYRad = glm::radians(60.0);
  /// Width over height, (0, 1e4].
  double aspect = 16.0 / 9.0;
  /// Near and far plane distances, 0 < near < far, finite.
  double nearM = 0.1;
  double farM = 5000.0;

  [[nodiscard]] glm::dvec3 forwardWs() const noexcept {
    return orientationWs * glm::dvec3(0, 0, -1);
  }
  [[nodiscard]] glm::dvec3 upWs() const noexcept { return orientationWs * glm::dvec3(0, 1, 0); }
  [[nodiscard]] glm::dvec3 rightWs() const noexcept { return orientationWs * glm::dvec3(1, 0, 0); }
};

/// A directional light. `directionWs` is the direction light travels (from the light toward the
/// scene): the sun overhead is (0, -1, 0). Any finite non-zero vector; normalised internally.
struct DirectionalLight {
  glm::dvec3 directionWs{0.0, -1.0, 0.0};
};

/// Axis-aligned box in world space. Used for the scene's extent (receivers and casters).
struct AabbWs {
  glm::dvec3 minWs{0.0};
  glm::dvec3 maxWs{0.0};
};

/// Each returns the first invalid field, or nothing when the input is valid.
[[nodiscard]] std::optional<ValidationError> validate(const ShadowSettings& settings);
[[nodiscard]] std::optional<ValidationError> validate(const Camera& camera);
[[nodiscard]] std::optional<ValidationError> validate(const DirectionalLight& light);
[[nodiscard]] std::optional<ValidationError> validate(const AabbWs& box, const char* field);
/// The checks that involve more than one struct (shadow distance > camera near).
[[nodiscard]] std::optional<ValidationError> validate(const ShadowSettings& settings,
                                                      const Camera& camera,
                                                      const DirectionalLight& light);

}  // namespace csm
