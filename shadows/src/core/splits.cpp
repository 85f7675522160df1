#include "csm/splits.hpp"

#include <cmath>

namespace csm {

SplitArray uniformSplits(double nearM, double farM, std::uint32_t count) noexcept {
  SplitArray d{};
  for (std::uint32_t i = 0; i <= count; ++i) {
    d[i] = nearM + (farM - nearM) * (static_cast<double>(i) / count);
  }
  d[0] = nearM;
  d[count] = farM;
  return d;
}

SplitArray logarithmicSplits(double nearM, double farM, std::uint32_t count) noexcept {
  SplitArray d{};
  const double ratio = farM / nearM;
  for (std::uint32_t i = 0; i <= count; ++i) {
    d[i] = nearM * std::pow(ratio, static_cast<double>(i) / count);
  }
  d[0] = nearM;
  d[count] = farM;
  return d;
}

SplitArray explicitSplits(double nearM, double farM, std::uint32_t count,
                          const std::array<double, kMaxCascades - 1>& positions) noexcept {
  SplitArray d{};
  d[0] = nearM;
  for (std::uint32_t i = 1; i < count; ++i) d[i] = nearM + (farM - nearM) * positions[i - 1];
  d[count] = farM;
  return d;
}

SplitArray practicalSplits(double nearM, double farM, std::uint32_t count, double lambda) noexcept {
  const SplitArray uni = uniformSplits(nearM, farM, count);
  if (lambda == 0.0) return uni;
  const SplitArray log = logarithmicSplits(nearM, farM, count);
  if (lambda == 1.0) return log;
  SplitArray d{};
  for (std::uint32_t i = 0; i <= count; ++i) d[i] = lambda * log[i] + (1.0 - lambda) * uni[i];
  d[0] = nearM;
  d[count] = farM;
  return d;
}

namespace {
// 16 steps per octave: a step is ~4.4% of the distance.
constexpr double kStepsPerOctave = 16.0;
double stepValue(double maxM, int k) noexcept {
  return maxM * std::exp2(-k / kStepsPerOctave);
}
}  // namespace

double quantizedShadowFar(double neededM, double maxM, double minM, double previousM) noexcept {
  if (!(neededM < maxM)) return maxM;  // also takes NaN to the safe maximum
  if (!(neededM > minM)) neededM = minM;
  // Largest k whose step still covers neededM.
  int k = static_cast<int>(std::floor(-kStepsPerOctave * std::log2(neededM / maxM)));
  if (k < 0) k = 0;
  while (k > 0 && stepValue(maxM, k) < neededM) --k;
  while (stepValue(maxM, k + 1) >= neededM) ++k;
  const double candidate = stepValue(maxM, k);
  // Hysteresis: keep last frame's value while it still covers and is at most two steps larger.
  if (previousM >= neededM && previousM <= maxM && previousM <= stepValue(maxM, k - 2)) {
    return previousM;
  }
  return candidate;
}

}  // namespace csm
