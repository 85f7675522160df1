// The shimmer scene and its camera motions: the measurement test scene at a distance from the
// world origin, the camera that looks at it and how that camera moves frame by frame. The
// stability tests (tests/stability) and csm_datasheet measure shimmer with them.
#pragma once

#include <csm/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "csm_measure/harness.hpp"
#include "csm_measure/scene.hpp"

namespace csm_measure {

/// The scene's local origin `distanceM` from the world origin (a direction that is on no axis).
glm::dvec3 originAt(double distanceM);

/// The shimmer scene's light unless a measurement says otherwise: it never moves.
csm::DirectionalLight testLight();

/// The base camera: local (0, 7, 28) looking at local (0, 0, -25), 60 degrees, near 0.1 m,
/// far 1000 m.
csm::Camera baseCamera(const glm::dvec3& originWs, double aspect = 16.0 / 9.0);

/// A distance from the origin as reports print it: "0", "1e+06", "1e+07".
std::string distanceKey(double d);

/// The test scene (Scene::makeTestScene, terrain and buildings) `distanceM` from the origin,
/// handed to the harness.
Scene setShimmerScene(Harness& harness, double distanceM);

/// `count` receivers (30% on building walls) over the base camera's whole view.
std::vector<Receiver> viewReceivers(const Scene& scene, uint32_t count);

/// The camera of frame f of a motion about the base camera at `origin`, in texels of the
/// stabilised cascades of the base camera (cascade 0's `texel0`, the last one's `texelLast`) so
/// that "sub-texel" means the same at every distance:
///   static      the base camera
///   subtexel    translation by 0.3 texel0 per frame
///   multitexel  translation by 3.3 texelLast per frame
///   yaw         0.35 degrees per frame
///   pitch       0.25 degrees per frame
///   orbit       about a point 53 m ahead, 0.4 degrees per frame
///   zoom        the vertical field of view narrowed by 0.25 degrees per frame from 60
/// Throws std::invalid_argument for another name.
csm::Camera motionCamera(const std::string& motion, const glm::dvec3& origin, double texel0,
                         double texelLast, int f);

}  // namespace csm_measure
