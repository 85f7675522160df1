// Far-field flicker in the image: how much a screen pixel's shadow factor changes from one frame to
// the next where the truth of what the pixel covers does not change. A stabilised map gives every
// world receiver the same factor frame after frame (the shimmer tests), but a far pixel covers
// many texels and reads one point of them: as the camera moves, that point moves over the texels
// and a percentage-closer pixel can jump between lit and shadowed while the pixel's true lit
// fraction stays put. The truth here is the pixel's coverage: the lit fraction of the surface
// inside the pixel, by S x S camera rays through the pixel, each with a shadow ray (Embree).
// Pure CPU (the rendered pixels come from Harness::renderAccuracy).
#pragma once

#include <csm/types.hpp>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <span>
#include <vector>

#include "csm_measure/harness.hpp"
#include "csm_measure/raytracer.hpp"

namespace csm_measure {

/// What counts as a flickering pixel.
struct FlickerOptions {
  /// Pixels read from this cascade on (in both frames of a pair): the far field.
  int minCascade = 2;
  /// Camera rays per pixel along each axis (subsamples^2 in all) for the coverage truth.
  int subsamples = 4;
  /// A sub-sample's hit distance may differ from the pixel centre's by this fraction of it: a
  /// pixel that spans a depth discontinuity (a silhouette) is not compared.
  double continuity = 0.05;
  /// A pair is stable when the coverage truth changes by at most this much.
  double stableTruth = 0.05;
  /// A stable pair flickers when the rendered factor changes by more than this.
  double visibleChange = 0.1;
};

/// The coverage truth of every pixel of an `extent` frame of `camera` (row-major, y down as the
/// rasteriser's): the fraction of `subsamples`^2 camera rays through the pixel whose hit sees the
/// light (RayTracer::visibility), faded toward the shadow distance as the frame fades
/// (fadedTruth). -1 where the pixel is not compared: no rendered receiver there (`pixels`), its
/// cascade below `o.minCascade`, a sub-sample that sees the sky, a surface facing away from the
/// light, or a hit distance off the centre's by more than `o.continuity`. Runs on every hardware
/// thread.
std::vector<float> pixelCoverageTruth(const RayTracer& tracer, const csm::Camera& camera,
                                      VkExtent2D extent, const csm::DirectionalLight& light,
                                      std::span<const PixelSample> pixels,
                                      const csm::CascadeFrame& frame, const FlickerOptions& o = {});

/// The camera ray through the point (`px`, `py`) of an `extent` image (pixel centres at +0.5, y
/// down), unit length, in world space: what the rasteriser's projection of `camera` maps there.
glm::dvec3 cameraRayWs(const csm::Camera& camera, VkExtent2D extent, double px, double py);

/// Frame-to-frame changes of rendered pixels against their coverage truth.
struct FlickerStats {
  /// Pixel pairs (the same pixel in consecutive frames) compared in both frames.
  uint64_t pairs = 0;
  /// Of those, the pairs whose coverage truth changed by at most FlickerOptions::stableTruth.
  uint64_t stablePairs = 0;
  /// Stable pairs whose rendered factor changed by more than FlickerOptions::visibleChange.
  uint64_t flickering = 0;
  /// Pairs (stable or not) whose rendered change exceeds the truth's by more than
  /// FlickerOptions::visibleChange.
  uint64_t excess = 0;
  double renderChangeSum = 0.0;  ///< |dF| over the stable pairs
  double truthChangeSum = 0.0;   ///< |dT| over the stable pairs
  double maxRenderChange = 0.0;  ///< over the stable pairs
  uint64_t nonFinite = 0;

  /// The far-field flicker: the fraction of stable pairs that flicker.
  [[nodiscard]] double rate() const noexcept {
    return stablePairs ? double(flickering) / double(stablePairs) : 0.0;
  }
  [[nodiscard]] double excessRate() const noexcept {
    return pairs ? double(excess) / double(pairs) : 0.0;
  }
  [[nodiscard]] double meanRenderChange() const noexcept {
    return stablePairs ? renderChangeSum / double(stablePairs) : 0.0;
  }
  [[nodiscard]] nlohmann::json toJson() const;
};

/// Adds the pairs of two consecutive frames of one `extent`: `a` and `b` their rendered pixels
/// (renderAccuracy), `truthA` and `truthB` their pixelCoverageTruth.
void accumulateFlicker(FlickerStats& stats, VkExtent2D extent, std::span<const PixelSample> a,
                       std::span<const float> truthA, std::span<const PixelSample> b,
                       std::span<const float> truthB, const FlickerOptions& o = {});

}  // namespace csm_measure
