#include "csm/receiver_bounds.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/gtc/quaternion.hpp>

namespace csm {

ReceiverLightBounds emptyReceiverLightBounds(const CascadeFrame& frame,
                                             const Camera& camera) noexcept {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  ReceiverLightBounds b;
  b.cascadeCount = frame.cascadeCount;
  b.splitsM = frame.splitsM;
  b.lightBasisWs = frame.lightBasisWs;
  b.cameraPositionWs = frame.cameraPositionWs;
  b.cameraOrientationWs = glm::normalize(camera.orientationWs);
  b.fovYRad = camera.fovYRad;
  b.aspect = camera.aspect;
  b.minLs.fill(glm::dvec2(kInf));
  b.maxLs.fill(glm::dvec2(-kInf));
  return b;
}

int addReceiver(ReceiverLightBounds& bounds, const glm::dvec3& forwardWs,
                const glm::dvec3& posWs) noexcept {
  const double depth = glm::dot(posWs - bounds.cameraPositionWs, forwardWs);
  for (std::uint32_t i = 0; i < bounds.cascadeCount; ++i) {
    if (depth >= bounds.splitsM[i] && depth < bounds.splitsM[i + 1]) {
      const glm::dvec2 q(glm::dot(bounds.lightBasisWs[0], posWs),
                         glm::dot(bounds.lightBasisWs[1], posWs));
      bounds.minLs[i] = glm::min(bounds.minLs[i], q);
      bounds.maxLs[i] = glm::max(bounds.maxLs[i], q);
      return static_cast<int>(i);
    }
  }
  return -1;
}

ReceiverLightBounds receiverLightBounds(const CascadeFrame& frame, const Camera& camera,
                                        std::span<const glm::dvec3> posWs) {
  ReceiverLightBounds b = emptyReceiverLightBounds(frame, camera);
  for (const glm::dvec3& p : posWs) addReceiver(b, frame.cameraForwardWs, p);
  return b;
}

bool receiverBoundsApply(const ReceiverLightBounds& bounds, std::uint32_t count,
                         const glm::dmat3& lightBasisWs) noexcept {
  return bounds.cascadeCount == count && count != 0 && bounds.lightBasisWs == lightBasisWs;
}

std::optional<ReceiverBoxFit> fitBoxToReceivers(const ReceiverLightBounds& bounds, std::uint32_t i,
                                                const glm::dmat3& lightBasisWs,
                                                const Camera& camera, double nearM, double farM,
                                                const glm::dvec2& todayCenterLs, double todayHalfM,
                                                double margin) noexcept {
  if (i >= bounds.cascadeCount || !bounds.hasReceivers(i) || !(todayHalfM > 0.0)) {
    return std::nullopt;
  }
  // The slice then held this one (a split that moved inward keeps a superset).
  if (!(bounds.splitsM[i] <= nearM && farM <= bounds.splitsM[i + 1])) return std::nullopt;
  const glm::dvec3& cameraWs = camera.positionWs;
  // The camera's light-space motion since the bounds were taken (a difference of two nearby
  // points, exact far from the origin).
  const glm::dvec3 moved = cameraWs - bounds.cameraPositionWs;
  const glm::dvec2 d(glm::dot(lightBasisWs[0], moved), glm::dot(lightBasisWs[1], moved));
  if (!(std::max(std::abs(d.x), std::abs(d.y)) <= todayHalfM)) return std::nullopt;
  // A camera that turned or widened its view sees receivers the bounds know nothing about: a
  // side of the frustum that moves by an angle a uncovers, on ground seen at a grazing angle g,
  // receivers up to farM x a / sin g away along it, unbounded as g -> 0; and a narrower view
  // samples the ground between the pixels that were bounded, whose footprint there is as long.
  // So the bounds hold only while the view keeps its orientation (to 1e-9 rad) and its field of
  // view (a translation moves every pixel's ray, and on flat ground its receiver, rigidly).
  const glm::dquat q = glm::normalize(camera.orientationWs);
  const double cosHalf = std::min(1.0, std::abs(glm::dot(q, bounds.cameraOrientationWs)));
  if (!(2.0 * std::acos(cosHalf) <= 1e-9)) return std::nullopt;
  if (!(camera.fovYRad == bounds.fovYRad && camera.aspect == bounds.aspect)) return std::nullopt;
  const glm::dvec2 pad(margin * todayHalfM);
  glm::dvec2 lo = glm::min(bounds.minLs[i], bounds.minLs[i] + d) - pad;
  glm::dvec2 hi = glm::max(bounds.maxLs[i], bounds.maxLs[i] + d) + pad;
  lo = glm::max(lo, todayCenterLs - todayHalfM);
  hi = glm::min(hi, todayCenterLs + todayHalfM);
  if (!(lo.x <= hi.x && lo.y <= hi.y)) return std::nullopt;
  ReceiverBoxFit fit;
  fit.centerLs = 0.5 * (lo + hi);
  // Never a degenerate box (one receiver and no margin): at least 1/1024 of today's.
  fit.coverHalfLs = glm::max(0.5 * (hi - lo), glm::dvec2(todayHalfM / 1024.0));
  return fit;
}

}  // namespace csm
