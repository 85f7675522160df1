// Cascade split distances along the view direction.
#pragma once

#include <array>
#include <cstdint>

#include "csm/types.hpp"

namespace csm {

/// N+1 split distances d_0 .. d_N (only the first count+1 entries are meaningful).
using SplitArray = std::array<double, kMaxCascades + 1>;

/// d_i = n + (f - n) * i / N. d_0 = n and d_N = f exactly.
[[nodiscard]] SplitArray uniformSplits(double nearM, double farM, std::uint32_t count) noexcept;

/// d_i = n * (f / n)^(i / N). d_0 = n and d_N = f exactly.
[[nodiscard]] SplitArray logarithmicSplits(double nearM, double farM, std::uint32_t count) noexcept;

/// The practical scheme lambda * log + (1 - lambda) * uniform. lambda = 0 returns
/// uniformSplits and lambda = 1 logarithmicSplits bit for bit. Requires 0 < n < f, finite,
/// count in [1, kMaxCascades], lambda in [0, 1]; the result is strictly increasing.
[[nodiscard]] SplitArray practicalSplits(double nearM, double farM, std::uint32_t count,
                                         double lambda) noexcept;

/// Explicit splits: d_0 = n, d_i = n + (f - n) * positions[i - 1] for 0 < i < count, d_count = f.
/// Requires 0 < n < f and positions strictly increasing in (0, 1) (validate() checks them).
[[nodiscard]] SplitArray explicitSplits(
    double nearM, double farM, std::uint32_t count,
    const std::array<double, kMaxCascades - 1>& positions) noexcept;

/// The far distance the splits end at, quantised so that it changes only in steps, with
/// hysteresis. `neededM` is the distance shadows must reach this frame (shadow distance, camera
/// far and scene extent already applied); `previousM` the value used last frame (0 if none).
/// The result is >= neededM (never leaves a receiver uncovered), is one of the fixed steps
/// `maxM * 2^(-k/8)` or `maxM` itself, and only shrinks once neededM falls two steps below it.
[[nodiscard]] double quantizedShadowFar(double neededM, double maxM, double minM,
                                        double previousM) noexcept;

/// The bin of view depth `depthM` in a histogram of `bins` log-spaced bins over [nearM, farM)
/// (ReceiverDepthHistogram): floor(bins * ln(depth / near) / ln(far / near)), clamped to
/// [0, bins - 1] (also for depths outside the range, 0 and NaN). The GPU reduction
/// (csm_depth_range.comp) bins with the same formula in float.
[[nodiscard]] std::uint32_t depthHistogramBin(double nearM, double farM, std::uint32_t bins,
                                              double depthM) noexcept;

/// The half side (metres) the box of the frustum slice between view depths nearM < farM needs:
/// the split placement's model of a cascade's texel size (texel = 2 x half side / resolution).
/// A function and its context, so that placing splits allocates nothing.
struct SliceHalfExtent {
  double (*halfExtentM)(const void* context, double nearM, double farM) noexcept = nullptr;
  const void* context = nullptr;
  [[nodiscard]] double operator()(double nearM, double farM) const noexcept {
    return halfExtentM(context, nearM, farM);
  }
};

/// Sample-distribution split placement from a histogram of the visible receivers' view depth.
/// Chooses the count - 1 interior splits among the ladder's rungs 2^(k / stepsPerOctave) strictly
/// inside (nearM, farM) (every 2nd, 3rd... rung if there are more than 126) that minimise
///   sum over cascades of  halfExtent(cascade) x sum over its receivers of 1 / view depth,
/// i.e. the receivers' mean texel size in units of their pixel's footprint (a pixel's footprint
/// grows with its view depth): cascades go where the receivers are, tight around clusters, and an
/// empty depth gap costs nothing, so it gets no resolution. Each bin counts in the cascade that
/// holds its centre (bins before nearM in the first, after farM in the last). Exact minimum by
/// dynamic programming over the rungs (count x rungs^2 slice extents).
/// `previous` (optional): last frame's splits; they are kept while their cost is at most
/// (1 + hysteresis) x the minimum's (and they are strictly increasing inside (nearM, farM)), so
/// a histogram that changes a little moves no split.
/// Returns false and leaves `splits` alone when there is nothing to place by: no histogram, no
/// receiver counted, non-finite or inverted inputs, count < 2, or fewer rungs than interior
/// splits. Otherwise splits[0] = nearM, splits[count] = farM, strictly increasing.
[[nodiscard]] bool histogramSplits(const ReceiverDepthHistogram& histogram, double nearM,
                                   double farM, std::uint32_t count, double stepsPerOctave,
                                   const SliceHalfExtent& halfExtent, const SplitArray* previous,
                                   double hysteresis, SplitArray& splits) noexcept;

}  // namespace csm
