// Ray-traced ground truth with Embree 3: the scene's full-detail triangles in one Embree scene,
// anchored at the scene's local origin so that rays stay precise 1e7 m from the world origin.
#pragma once

#include <glm/glm.hpp>

#include <span>
#include <vector>

#include "csm_measure/scene.hpp"

namespace csm_measure {

/// Occlusion queries against a Scene's triangles. Not copyable; thread-compatible.
class RayTracer {
 public:
  /// visibility()'s default lift off the surface (m).
  static constexpr double kDefaultLiftM = 2e-3;

  /// Builds the Embree scene (every instance's triangles, transformed to anchor-relative float).
  explicit RayTracer(const Scene& scene);
  ~RayTracer();
  RayTracer(const RayTracer&) = delete;
  RayTracer& operator=(const RayTracer&) = delete;

  /// Visibility toward the light for receivers at `posWs` with unit normals `normalWs`: 1 when
  /// the ray from the point (lifted off its surface by `liftM` along the normal, and by
  /// `liftM` toward the light) to infinity along -lightDirWs hits nothing, else 0.
  void visibility(std::span<const glm::dvec3> posWs, std::span<const glm::vec3> normalWs,
                  const glm::dvec3& lightDirWs, std::span<float> out,
                  double liftM = kDefaultLiftM) const;

  /// Nearest hit of a ray (world origin, unit direction); false when nothing is hit.
  bool intersect(const glm::dvec3& originWs, const glm::dvec3& dirWs, glm::dvec3* hitWs,
                 glm::vec3* normalWs) const;

 private:
  struct Impl;
  Impl* impl_;
};

}  // namespace csm_measure
