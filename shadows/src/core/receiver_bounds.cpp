#include "csm/receiver_bounds.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace csm {

ReceiverLightBounds emptyReceiverLightBounds(const CascadeFrame& frame) noexcept {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  ReceiverLightBounds b;
  b.cascadeCount = frame.cascadeCount;
  b.splitsM = frame.splitsM;
  b.lightBasisWs = frame.lightBasisWs;
  b.cameraPositionWs = frame.cameraPositionWs;
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

ReceiverLightBounds receiverLightBounds(const CascadeFrame& frame,
                                        std::span<const glm::dvec3> posWs) {
  ReceiverLightBounds b = emptyReceiverLightBounds(frame);
  for (const glm::dvec3& p : posWs) addReceiver(b, frame.cameraForwardWs, p);
  return b;
}

bool receiverBoundsApply(const ReceiverLightBounds& bounds, std::uint32_t count,
                         const SplitArray& splitsM, const glm::dmat3& lightBasisWs) noexcept {
  if (bounds.cascadeCount != count || count == 0) return false;
  for (std::uint32_t i = 0; i <= count; ++i) {
    if (bounds.splitsM[i] != splitsM[i]) return false;
  }
  return bounds.lightBasisWs == lightBasisWs;
}

std::optional<ReceiverBoxFit> fitBoxToReceivers(const ReceiverLightBounds& bounds, std::uint32_t i,
                                                const glm::dmat3& lightBasisWs,
                                                const glm::dvec3& cameraWs,
                                                const glm::dvec2& todayCenterLs, double todayHalfM,
                                                double margin) noexcept {
  if (i >= bounds.cascadeCount || !bounds.hasReceivers(i) || !(todayHalfM > 0.0)) {
    return std::nullopt;
  }
  // The camera's light-space motion since the bounds were taken (a difference of two nearby
  // points, exact far from the origin).
  const glm::dvec3 moved = cameraWs - bounds.cameraPositionWs;
  const glm::dvec2 d(glm::dot(lightBasisWs[0], moved), glm::dot(lightBasisWs[1], moved));
  if (!(std::max(std::abs(d.x), std::abs(d.y)) <= todayHalfM)) return std::nullopt;
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
