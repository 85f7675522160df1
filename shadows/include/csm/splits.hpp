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

}  // namespace csm
