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

/// The sun's direction on the `day` path: azimuth from +x toward +z and elevation above the
/// horizon, degrees (AppSettings::lightAzimuthDeg / lightElevationDeg).
struct SunPose {
  double azimuthDeg = 0.0;
  double elevationDeg = 0.0;
};

/// The clock of the paths that run in time rather than along t: `day` (the sun crosses the sky
/// from sunrise to sunset in dayLengthS seconds) and `cut` (the camera jumps to the next place
/// every cutEveryS seconds). The headless flight runs at kHeadlessFrameS a frame.
struct PathClock {
  double dayLengthS = 1200.0;
  double cutEveryS = 1.0;
};
inline constexpr double kMinDayLengthS = 10.0, kMaxDayLengthS = 86400.0;
inline constexpr double kMinCutEveryS = 0.05, kMaxCutEveryS = 600.0;
/// The simulated time of one headless frame (60 frames a second).
inline constexpr double kHeadlessFrameS = 1.0 / 60.0;

/// The engine camera at `pose`: its position, yaw and pitch, its vertical field of view, and the
/// given aspect and clip planes (the one conversion the fly-through, the tools and the tests use).
[[nodiscard]] engine::Camera poseCamera(const CameraPose& pose, double aspect, double nearM,
                                        double farM);

/// The named paths: forest (low pass over the forest), fast (fast straight flight), rotate (slow
/// rotation in place), zoom (FOV zoom on the tower), far (the forest pass 10^7 m from the origin),
/// cables (along the power line), day (the forest pass while the sun moves: sunAt), cut (the
/// camera jumps between six places of the world: shotAt).
[[nodiscard]] const std::vector<std::string>& pathNames();
/// Where the world must be generated for a path (the "far" path moves it to 10^7 m).
[[nodiscard]] glm::dvec3 pathWorldOrigin(const std::string& name, double worldSizeM);

class FlightPath {
 public:
  /// The path `name` over `world`, or nothing for an unknown name or a clock outside its ranges
  /// (kMinDayLengthS..., the ranges of the day.lengthS and cut.everyS settings).
  [[nodiscard]] static std::optional<FlightPath> make(const std::string& name, const World& world,
                                                      double baseFovDeg, PathClock clock = {});
  /// The pose at t in [0, 1] (start to end). The `cut` path visits each of its places once over
  /// t (as at(seconds) over six shots of cutEveryS).
  [[nodiscard]] CameraPose at(double t) const;
  /// The pose at t along the path and `seconds` into the flight: the `cut` path's pose follows
  /// the time (a new place every cutEveryS, drifting slowly between cuts); the others follow t.
  [[nodiscard]] CameraPose at(double t, double seconds) const;
  /// The `cut` path's shot at `seconds` (a new index is a camera cut: the previous frame has
  /// nothing in common with this one); 0 on every other path.
  [[nodiscard]] int shotAt(double seconds) const;
  /// The `day` path's sun `seconds` into the flight (from mid-morning toward sunset, then the
  /// next day); nothing on the other paths (the settings' sun holds).
  [[nodiscard]] std::optional<SunPose> sunAt(double seconds) const;
  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] const PathClock& clock() const { return clock_; }
  /// The path cuts between places (`cut`) / moves the sun (`day`).
  [[nodiscard]] bool cuts() const { return timed_; }
  [[nodiscard]] bool movesSun() const { return sun_; }

 private:
  [[nodiscard]] CameraPose splinePose(double t) const;
  [[nodiscard]] CameraPose cutPose(double seconds) const;

  std::string name_;
  const World* world_ = nullptr;
  PathClock clock_{};
  bool timed_ = false;  // `cut`: the pose follows the time
  bool sun_ = false;    // `day`: the sun moves
  // `cut`: the places it jumps between (metres from the world's corner, and the heading).
  std::vector<glm::dvec3> shotsUvYaw_;
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
