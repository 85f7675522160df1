// Named flight paths (see paths.hpp).
#include "sample_world/paths.hpp"

#include <algorithm>
#include <cmath>
#include <glm/gtc/constants.hpp>

namespace world {

namespace {

glm::dvec2 catmullRom(const std::vector<glm::dvec2>& p, double t) {
  const double segs = static_cast<double>(p.size() - 1);
  const double x = std::clamp(t, 0.0, 1.0) * segs;
  const auto i = static_cast<std::size_t>(std::min(std::floor(x), segs - 1.0));
  const double f = x - static_cast<double>(i);
  const glm::dvec2 p0 = p[i == 0 ? 0 : i - 1], p1 = p[i], p2 = p[i + 1];
  const glm::dvec2 p3 = p[std::min(i + 2, p.size() - 1)];
  const double f2 = f * f, f3 = f2 * f;
  return 0.5 * ((2.0 * p1) + (-p0 + p2) * f + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * f2 +
                (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * f3);
}

}  // namespace

const std::vector<std::string>& pathNames() {
  static const std::vector<std::string> names = {"forest", "fast",   "rotate", "zoom",
                                                 "far",    "cables", "day",    "cut"};
  return names;
}

glm::dvec3 pathWorldOrigin(const std::string& name, double worldSizeM) {
  const double h = 0.5 * worldSizeM;
  if (name == "far") return {1.0e7 - h, 0.0, 1.0e7 - h};
  return {-h, 0.0, -h};
}

std::optional<FlightPath> FlightPath::make(const std::string& name, const World& world,
                                           double baseFovDeg, PathClock clock) {
  if (!(clock.dayLengthS >= kMinDayLengthS && clock.dayLengthS <= kMaxDayLengthS) ||
      !(clock.cutEveryS >= kMinCutEveryS && clock.cutEveryS <= kMaxCutEveryS)) {
    return std::nullopt;
  }
  FlightPath p;
  p.name_ = name;
  p.world_ = &world;
  p.clock_ = clock;
  p.fov0_ = p.fov1_ = baseFovDeg;
  const double c = 0.5 * world.desc.sizeM;
  if (name == "forest" || name == "far" || name == "day") {
    p.pointsUv_ = {{c - 1300, c + 900}, {c - 900, c + 650}, {c - 520, c + 380},
                   {c - 150, c + 330},  {c + 250, c + 80},  {c + 650, c - 300}};
    p.altitudeM_ = 28.0;
    p.pitchRad_ = -0.22;
    p.sun_ = name == "day";
  } else if (name == "fast") {
    // Straight and fast over the forest the low pass winds through (higher, looking down enough
    // to keep trees and their shadows in view in every frame).
    p.pointsUv_ = {{c - 1300, c + 900}, {c + 650, c - 300}};
    p.altitudeM_ = 60.0;
    p.pitchRad_ = -0.3;
  } else if (name == "rotate") {
    p.pointsUv_ = {{c - 260, c + 220}, {c - 260, c + 220}};
    p.altitudeM_ = 35.0;
    p.pitchRad_ = -0.25;
    p.followTangent_ = false;
    p.yaw0_ = 0.0;
    p.yaw1_ = glm::radians(120.0);
  } else if (name == "zoom") {
    p.pointsUv_ = {{c + 20 + 650, c - 30 - 420}, {c + 20 + 650, c - 30 - 420}};
    p.altitudeM_ = 40.0;
    p.followTangent_ = false;
    p.lookAt_ = true;
    p.lookAtUv_ = {c + 20, c - 30};
    p.fov0_ = 70.0;
    p.fov1_ = 8.0;
  } else if (name == "cables") {
    // Above and beside the power line east of the town (world.cpp, thinCasters()), 70 m up
    // and 130 m south of it, looking down across it (-z) while flying 300 m along it: its 3 cm
    // cables' shadows on the terrain 130-200 m away.
    p.pointsUv_ = {{c + 700, c + 190}, {c + 1000, c + 190}};
    p.altitudeM_ = 70.0;
    p.pitchRad_ = -0.45;
    p.followTangent_ = false;
    p.yaw0_ = p.yaw1_ = 0.0;
  } else if (name == "cut") {
    // Six places far apart (a respawn, a teleport, a cut between cameras): the forest's start,
    // the town from the south-east, the rotate path's point, the power line, the forest's end,
    // the south-west; each looked at along its own heading.
    p.shotsUvYaw_ = {{c - 1300, c + 900, 2.3}, {c + 670, c - 450, 1.0},  {c - 260, c + 220, -0.8},
                     {c + 850, c + 190, 0.0},  {c + 650, c - 300, -2.4}, {c - 700, c - 800, 3.0}};
    p.pointsUv_ = {{c, c}, {c, c}};  // unused: the pose follows the shots
    p.altitudeM_ = 32.0;
    p.pitchRad_ = -0.25;
    p.followTangent_ = false;
    p.timed_ = true;
  } else {
    return std::nullopt;
  }
  return p;
}

CameraPose FlightPath::at(double t) const {
  if (timed_) {
    const double shots = static_cast<double>(shotsUvYaw_.size());
    // Just short of the end, so that t = 1 stays in the last shot.
    return cutPose(std::clamp(t, 0.0, 1.0) * shots * clock_.cutEveryS * (1.0 - 1e-9));
  }
  return splinePose(t);
}

CameraPose FlightPath::at(double t, double seconds) const {
  return timed_ ? cutPose(seconds) : splinePose(t);
}

int FlightPath::shotAt(double seconds) const {
  if (!timed_) return 0;
  // (A frame's time on the cut, such as 18 x 1/60 s at 0.1 s, belongs to the new shot despite
  // its rounding.)
  return static_cast<int>(std::floor(std::max(0.0, seconds) / clock_.cutEveryS + 1e-9));
}

CameraPose FlightPath::cutPose(double seconds) const {
  const int shot = shotAt(seconds);
  const glm::dvec3& s = shotsUvYaw_[static_cast<std::size_t>(shot) % shotsUvYaw_.size()];
  const double since = std::max(0.0, std::max(0.0, seconds) - shot * clock_.cutEveryS);
  // Between cuts the camera drifts forward at 6 m/s (a walk-and-look shot, not a still).
  const glm::dvec2 forward(-std::sin(s.z), -std::cos(s.z));
  const glm::dvec2 uv = glm::dvec2(s.x, s.y) + forward * (6.0 * since);
  const glm::dvec3 o = world_->desc.originWs;
  CameraPose pose;
  pose.positionWs = {o.x + uv.x, world_->heightAt(o.x + uv.x, o.z + uv.y) + altitudeM_, o.z + uv.y};
  pose.yawRad = s.z;
  pose.pitchRad = pitchRad_;
  pose.fovDeg = fov0_;
  return pose;
}

std::optional<SunPose> FlightPath::sunAt(double seconds) const {
  if (!sun_) return std::nullopt;
  // The fraction of daylight from sunrise (east, azimuth 90) through noon (south, 180, at
  // kNoonDeg) to sunset (west, 270); the flight starts at mid-morning. Near the horizon the
  // elevation holds at kLowDeg (the sun's disk is still above the ground there).
  constexpr double kStart = 0.25, kNoonDeg = 65.0, kLowDeg = 2.0;
  const double day = kStart + std::max(0.0, seconds) / clock_.dayLengthS;
  const double f = day - std::floor(day);
  SunPose sun;
  sun.azimuthDeg = 90.0 + 180.0 * f;
  sun.elevationDeg = std::max(kLowDeg, kNoonDeg * std::sin(glm::pi<double>() * f));
  return sun;
}

CameraPose FlightPath::splinePose(double t) const {
  t = std::clamp(t, 0.0, 1.0);
  const glm::dvec3 o = world_->desc.originWs;
  const glm::dvec2 uv = catmullRom(pointsUv_, t);
  // Altitude above the highest ground near this stretch of the path (smooth, never below it).
  double ground = -1e30;
  for (int k = -4; k <= 4; ++k) {
    const glm::dvec2 q = catmullRom(pointsUv_, std::clamp(t + k * 0.01, 0.0, 1.0));
    ground = std::max(ground, world_->heightAt(o.x + q.x, o.z + q.y));
  }
  CameraPose pose;
  pose.positionWs = {o.x + uv.x, ground + altitudeM_, o.z + uv.y};
  pose.pitchRad = pitchRad_;
  pose.fovDeg = fov0_ + (fov1_ - fov0_) * t;
  if (followTangent_) {
    const glm::dvec2 a = catmullRom(pointsUv_, std::max(0.0, t - 0.01));
    const glm::dvec2 b = catmullRom(pointsUv_, std::min(1.0, t + 0.01));
    const glm::dvec2 d = b - a;
    pose.yawRad = std::atan2(-d.x, -d.y);  // yaw 0 looks down -z, positive turns left
  } else if (lookAt_) {
    const glm::dvec3 target(o.x + lookAtUv_.x,
                            world_->heightAt(o.x + lookAtUv_.x, o.z + lookAtUv_.y) + 30.0,
                            o.z + lookAtUv_.y);
    const glm::dvec3 d = target - pose.positionWs;
    pose.yawRad = std::atan2(-d.x, -d.z);
    pose.pitchRad = std::atan2(d.y, std::sqrt(d.x * d.x + d.z * d.z));
  } else {
    pose.yawRad = yaw0_ + (yaw1_ - yaw0_) * t;
  }
  return pose;
}

engine::Camera poseCamera(const CameraPose& pose, double aspect, double nearM, double farM) {
  engine::Camera cam;
  cam.positionWs = pose.positionWs;
  cam.setYawPitchRoll(pose.yawRad, pose.pitchRad);
  cam.fovYRad = glm::radians(pose.fovDeg);
  cam.aspect = aspect;
  cam.nearM = nearM;
  cam.farM = farM;
  return cam;
}

}  // namespace world
