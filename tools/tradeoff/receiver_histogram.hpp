// What csm::vk::DepthRangeReducer returns for a frame, computed on the CPU from that frame's
// receiver pixels (an accuracy render): the nearest and farthest view depth and, with
// histogramNearM > 0, the histogram over log-spaced view-depth bins, binned by
// csm::depthHistogramBin as the shader does. The sweep and --fit-study feed it to the splits of
// the frame after, as the fly-through does with the GPU reduction's result.
#pragma once

#include <csm/splits.hpp>
#include <csm_measure/harness.hpp>

#include <algorithm>
#include <optional>
#include <span>

namespace tradeoff {

inline std::optional<csm::ReceiverDepthRange> receiverRangeOf(
    std::span<const csm_measure::PixelSample> pixels, const csm::Camera& camera,
    double histogramNearM = 0.0, double histogramFarM = 0.0) {
  csm::ReceiverDepthRange r{1e300, 0.0};
  if (histogramNearM > 0.0) {
    r.histogram.nearM = histogramNearM;
    r.histogram.farM = histogramFarM;
  }
  for (const csm_measure::PixelSample& p : pixels) {
    const double d = glm::dot(p.posWs - camera.positionWs, camera.forwardWs());
    r.minM = std::min(r.minM, d);
    r.maxM = std::max(r.maxM, d);
    if (histogramNearM > 0.0) {
      ++r.histogram.counts[csm::depthHistogramBin(histogramNearM, histogramFarM,
                                                  csm::kDepthHistogramBins, d)];
    }
  }
  if (!(r.maxM >= r.minM)) return std::nullopt;
  r.minM = std::max(0.0, r.minM);
  return r;
}

}  // namespace tradeoff
