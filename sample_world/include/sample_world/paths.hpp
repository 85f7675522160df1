// Named camera flights over the sample world (Catmull-Rom splines in world-relative metres),
// so that the same flight can be flown anywhere, 10^7 m from the origin included.
#pragma once

#include <glm/glm.hpp>

#include <optional>
#include <string>
#include <vector>

#include "engine/camera.hpp"
#include "sample_world/world.hpp"

namespace world {

/// A camera pose along a path.
struct CameraPose {
  glm::dvec3 positionWs{0.0};
  double yawRad = 0.0;    ///< about +y; 0 looks down -z
  double pitchRad = 0.0;  ///< positive looks up
  double fovDeg = 60.0;
};

/// The engine camera at `pose`: its position, yaw and pitch, its vertical field of view, and the
/// given aspect and clip planes (the one conversion the fly-through, the tools and the tests use).
[[nodiscard]] engine::Camera poseCamera(const CameraPose& pose, double aspect, double nearM,
                                        double farM);

/// The named paths: forest (low pass over the forest), fast (fast straight flight), rotate (slow
/// rotation in place), zoom (FOV zoom on the tower), far (the forest pass 10^7 m from the origin).
[[nodiscard]] const std::vector<std::string>& pathNames();
/// Where the world must be generated for a path (the "far" path moves it to 10^7 m).
[[nodiscard]] glm::dvec3 pathWorldOrigin(const std::string& name, double worldSizeM);

class FlightPath {
 public:
  /// The path `name` over `world`, or nothing for an unknown name.
  [[nodiscard]] static std::optional<FlightPath> make(const std::string& name, const World& world,
                                                      double baseFovDeg);
  /// The pose at t in [0, 1] (start to end).
  [[nodiscard]] CameraPose at(double t) const;
  [[nodiscard]] const std::string& name() const { return name_; }

 private:
  std::string name_;
  const World* world_ = nullptr;
  std::vector<glm::dvec2> pointsUv_;  // control points, metres from the world's corner
  double altitudeM_ = 30.0;
  double pitchRad_ = -0.2;
  double fov0_ = 60.0, fov1_ = 60.0;
  double yaw0_ = 0.0, yaw1_ = 0.0;
  bool followTangent_ = true;
  glm::dvec2 lookAtUv_{0.0};
  bool lookAt_ = false;
};

}  // namespace world
