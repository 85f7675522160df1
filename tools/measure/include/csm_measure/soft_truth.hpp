// Ray-traced truth for soft (area-light) shadows: the fraction of the sun's disk a receiver sees,
// by stratified rays over the disk through the scene's real triangles (Embree), and the
// comparison of a rendered frame or a line of receivers with it. Pure CPU.
#pragma once

#include <nlohmann/json.hpp>

#include <span>
#include <vector>

#include "csm_measure/harness.hpp"
#include "csm_measure/raytracer.hpp"

namespace csm_measure {

/// Directions of travel of `strataPerAxis`^2 rays spread over a disk of angular diameter
/// `angularDiameterDeg` about `lightDirWs` (uniform in solid angle for a small disk): one jittered
/// sample per cell of a strataPerAxis x strataPerAxis grid, mapped to the disk by Shirley and
/// Chiu's concentric map (cells keep equal area). Deterministic (fixed seed).
std::vector<glm::dvec3> sunDiskDirections(const glm::dvec3& lightDirWs, double angularDiameterDeg,
                                          int strataPerAxis = 16);

/// Fraction of the light's disk visible from each receiver (1 lit, 0 umbra): the mean of
/// RayTracer::visibility over sunDiskDirections(). Runs on every hardware thread.
void softVisibility(const RayTracer& tracer, std::span<const glm::dvec3> posWs,
                    std::span<const glm::vec3> normalWs, const glm::dvec3& lightDirWs,
                    double angularDiameterDeg, std::span<float> out, int strataPerAxis = 16);

/// |s - v_soft| over the receiver pixels of a frame (inside a cascade, facing the light).
struct SoftErrorStats {
  uint64_t pixels = 0;
  double absErrorSum = 0.0;
  /// Pixels where the truth is neither 0 nor 1 (0.02 < v < 0.98): the penumbrae.
  uint64_t penumbraPixels = 0;
  double penumbraAbsErrorSum = 0.0;
  uint64_t nonFinite = 0;
  [[nodiscard]] double meanAbsError() const noexcept {
    return pixels ? absErrorSum / double(pixels) : 0.0;
  }
  [[nodiscard]] double penumbraMeanAbsError() const noexcept {
    return penumbraPixels ? penumbraAbsErrorSum / double(penumbraPixels) : 0.0;
  }
  [[nodiscard]] nlohmann::json toJson() const;
};

/// The soft truth of every pixel (same order; -1 for pixels that are not compared).
std::vector<float> softTruthOfPixels(std::span<const PixelSample> pixels,
                                     const csm::CascadeFrame& frame, const RayTracer& tracer,
                                     const csm::DirectionalLight& light, double angularDiameterDeg);

/// The soft truth of every finite pixel facing the light, whatever cascade covers it (-1 for the
/// others). It depends only on the pixels' positions and normals, so a sweep over shadow settings
/// traces it once per view; mark the pixels a frame does not compare (cascade < 0) -1 before
/// measureSoftError.
std::vector<float> softTruthOfReceivers(std::span<const PixelSample> pixels,
                                        const RayTracer& tracer, const csm::DirectionalLight& light,
                                        double angularDiameterDeg);

/// Compares each compared pixel's shadow factor with `truth` (from softTruthOfPixels).
SoftErrorStats measureSoftError(std::span<const PixelSample> pixels, std::span<const float> truth);

/// Width of a penumbra along a line of receivers spaced `stepM` apart whose value rises (or
/// falls) across one shadow edge: the distance between the 10% and 90% levels, from how many
/// samples lie below each level (exact for a monotone profile, robust to noise).
double penumbraWidth10to90(std::span<const float> profile, double stepM) noexcept;

}  // namespace csm_measure
