// Receiver-driven light-space partition bounds (the box half of sample-distribution shadow
// maps): collecting them from one frame's receivers and fitting a cascade's box to them.
#pragma once

#include <optional>
#include <span>

#include "csm/cascades.hpp"
#include "csm/types.hpp"

namespace csm {

/// Empty bounds for `frame` drawn with `camera` (its cascade count, splits, light basis and the
/// camera's position, orientation and field of view; every cascade minLs = +inf,
/// maxLs = -inf), to be grown with addReceiver().
[[nodiscard]] ReceiverLightBounds emptyReceiverLightBounds(const CascadeFrame& frame,
                                                           const Camera& camera) noexcept;

/// Adds one visible receiver (world position, double) to the bounds: it goes to the cascade
/// whose view-depth interval [splitsM[i], splitsM[i + 1]) holds its depth along `forwardWs`
/// from the bounds' camera (the frame's cameraForwardWs); receivers outside every interval are
/// ignored, as the shader leaves them lit. Returns the cascade, or -1.
int addReceiver(ReceiverLightBounds& bounds, const glm::dvec3& forwardWs,
                const glm::dvec3& posWs) noexcept;

/// The bounds of a set of receivers seen in `frame` drawn with `camera`.
[[nodiscard]] ReceiverLightBounds receiverLightBounds(const CascadeFrame& frame,
                                                      const Camera& camera,
                                                      std::span<const glm::dvec3> posWs);

/// The bounds apply to a frame with this cascade count and this light basis, both equal bit for
/// bit (the light step holds the basis; after a step they do not); each cascade then checks its
/// own interval (fitBoxToReceivers).
[[nodiscard]] bool receiverBoundsApply(const ReceiverLightBounds& bounds, std::uint32_t count,
                                       const glm::dmat3& lightBasisWs) noexcept;

/// A cascade's box from the receivers' bounds, light space about the world origin.
struct ReceiverBoxFit {
  /// The centre of the rectangle the box must cover, and its half sides (x, y).
  glm::dvec2 centerLs{0.0};
  glm::dvec2 coverHalfLs{0.0};
};

/// Fits cascade `i` (view depths [nearM, farM] this frame) to the receivers: their rectangle,
/// widened by the camera's light-space x, y motion since the bounds were taken (the rectangle
/// and its copy moved by it), pushed out on every side by margin x `todayHalfM`, then clipped to
/// the square the box covers without bounds (centre `todayCenterLs`, half side `todayHalfM`), so
/// never larger. Nothing (keep today's box) when the cascade's interval then did not hold
/// [nearM, farM], when it saw no receiver, when the camera has turned or changed its field of view
/// since (new receivers at a grazing angle may lie anywhere along the slice), when it moved more
/// than `todayHalfM` in light-space x, y (a cut), or when the rectangle misses today's square.
/// `camera` is this frame's; `lightBasisWs` the frame's (the bounds' own, see receiverBoundsApply).
[[nodiscard]] std::optional<ReceiverBoxFit> fitBoxToReceivers(
    const ReceiverLightBounds& bounds, std::uint32_t i, const glm::dmat3& lightBasisWs,
    const Camera& camera, double nearM, double farM, const glm::dvec2& todayCenterLs,
    double todayHalfM, double margin) noexcept;

}  // namespace csm
