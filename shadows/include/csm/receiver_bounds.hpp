// Receiver-driven light-space partition bounds (the box half of sample-distribution shadow
// maps): collecting them from one frame's receivers and fitting a cascade's box to them.
#pragma once

#include <optional>
#include <span>

#include "csm/cascades.hpp"
#include "csm/types.hpp"

namespace csm {

/// Empty bounds for `frame` (its cascade count, splits, light basis and camera position; every
/// cascade minLs = +inf, maxLs = -inf), to be grown with addReceiver().
[[nodiscard]] ReceiverLightBounds emptyReceiverLightBounds(const CascadeFrame& frame) noexcept;

/// Adds one visible receiver (world position, double) to the bounds: it goes to the cascade
/// whose view-depth interval [splitsM[i], splitsM[i + 1]) holds its depth along `forwardWs`
/// from the bounds' camera (the frame's cameraForwardWs); receivers outside every interval are
/// ignored, as the shader leaves them lit. Returns the cascade, or -1.
int addReceiver(ReceiverLightBounds& bounds, const glm::dvec3& forwardWs,
                const glm::dvec3& posWs) noexcept;

/// The bounds of a set of receivers seen in `frame`.
[[nodiscard]] ReceiverLightBounds receiverLightBounds(const CascadeFrame& frame,
                                                      std::span<const glm::dvec3> posWs);

/// The bounds apply to a frame with this cascade count, these splits and this light basis:
/// all equal bit for bit (the ladder holds them between rung events, so bounds taken a few
/// frames earlier usually apply; after a rung event or a light step they do not).
[[nodiscard]] bool receiverBoundsApply(const ReceiverLightBounds& bounds, std::uint32_t count,
                                       const SplitArray& splitsM,
                                       const glm::dmat3& lightBasisWs) noexcept;

/// A cascade's box from the receivers' bounds, light space about the world origin.
struct ReceiverBoxFit {
  /// The centre of the rectangle the box must cover, and its half sides (x, y).
  glm::dvec2 centerLs{0.0};
  glm::dvec2 coverHalfLs{0.0};
};

/// Fits cascade `i`'s box to the receivers: their rectangle, widened by the camera's light-space
/// x, y motion since the bounds were taken (the rectangle and its copy moved by it), pushed out
/// on every side by margin x `todayHalfM`, then clipped to the square the box covers without
/// bounds (centre `todayCenterLs`, half side `todayHalfM`), so never larger. Nothing (keep
/// today's box) when the cascade saw no receiver, when the camera moved more than `todayHalfM`
/// in light-space x, y (a cut), or when the rectangle misses today's square. `cameraWs` is this
/// frame's camera; `lightBasisWs` the frame's (the bounds' own, see receiverBoundsApply).
[[nodiscard]] std::optional<ReceiverBoxFit> fitBoxToReceivers(
    const ReceiverLightBounds& bounds, std::uint32_t i, const glm::dmat3& lightBasisWs,
    const glm::dvec3& cameraWs, const glm::dvec2& todayCenterLs, double todayHalfM,
    double margin) noexcept;

}  // namespace csm
