#include "csm/splits.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "csm/ladder.hpp"

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

namespace csm {

std::uint32_t depthHistogramBin(double nearM, double farM, std::uint32_t bins,
                                double depthM) noexcept {
  if (bins == 0) return 0;
  const double u = static_cast<double>(bins) * std::log(depthM / nearM) / std::log(farM / nearM);
  if (!(u >= 0.0)) return 0;  // before nearM, 0 and NaN
  if (!(u < static_cast<double>(bins))) return bins - 1;
  return static_cast<std::uint32_t>(u);
}

namespace {

constexpr std::uint32_t kMaxSplitCandidates = 126;  // interior rungs the placement considers

// Sum of the bins' weights (count / centre depth) whose centre lies before `depthM`, from the
// prefix sums `prefix` (kDepthHistogramBins + 1 entries).
double weightBefore(const ReceiverDepthHistogram& h, const double* prefix, double depthM) noexcept {
  const double binsPerLog = kDepthHistogramBins / std::log(h.farM / h.nearM);
  // Centre of bin b: nearM * r^(b + 0.5) < depthM  <=>  b < ln(depth / near) * binsPerLog - 0.5.
  const double u = std::log(depthM / h.nearM) * binsPerLog - 0.5;
  if (!(u > 0.0)) return prefix[0];
  if (!(u < kDepthHistogramBins)) return prefix[kDepthHistogramBins];
  return prefix[static_cast<std::uint32_t>(std::ceil(u))];
}

}  // namespace

bool histogramSplits(const ReceiverDepthHistogram& h, double nearM, double farM,
                     std::uint32_t count, double stepsPerOctave, const SliceHalfExtent& halfExtent,
                     const SplitArray* previous, double hysteresis, SplitArray& splits) noexcept {
  if (!h.present() || !(h.nearM > 0.0) || !(h.farM > h.nearM) || !std::isfinite(h.farM)) {
    return false;
  }
  if (!(nearM > 0.0) || !(farM > nearM) || !std::isfinite(farM) || count < 2 ||
      count > kMaxCascades || !(stepsPerOctave >= 1.0 && stepsPerOctave <= 64.0) ||
      halfExtent.halfExtentM == nullptr || !(hysteresis >= 0.0)) {
    return false;
  }
  // Per-bin weight: receivers / view depth at the bin's centre (log-spaced bins).
  std::array<double, kDepthHistogramBins + 1> prefix{};
  const double ratio = std::log(h.farM / h.nearM) / kDepthHistogramBins;
  std::uint64_t total = 0;
  for (std::uint32_t b = 0; b < kDepthHistogramBins; ++b) {
    const double centreM = h.nearM * std::exp((b + 0.5) * ratio);
    prefix[b + 1] = prefix[b] + static_cast<double>(h.counts[b]) / centreM;
    total += h.counts[b];
  }
  if (total == 0 || !std::isfinite(prefix[kDepthHistogramBins])) return false;

  // The candidate edges: the ladder's rungs strictly inside (nearM, farM), thinned to at most
  // kMaxSplitCandidates; edge 0 is nearM, the last farM.
  int first = ladderRungUp(nearM, stepsPerOctave);  // smallest rung > nearM
  if (!(ladderValue(first, stepsPerOctave) > nearM)) ++first;
  const int last = ladderRungUp(farM, stepsPerOctave) - 1;  // largest rung < farM
  if (last < first || static_cast<std::uint32_t>(last - first + 1) < count - 1) return false;
  const int rungs = last - first + 1;
  const int stride =
      (rungs + static_cast<int>(kMaxSplitCandidates) - 1) / static_cast<int>(kMaxSplitCandidates);
  std::array<double, kMaxSplitCandidates + 2> edge{};
  std::uint32_t m = 0;  // interior candidates
  edge[0] = nearM;
  for (int k = first; k <= last && m < kMaxSplitCandidates; k += stride)
    edge[++m] = ladderValue(k, stepsPerOctave);
  if (m < count - 1) return false;
  const std::uint32_t end = m + 1;
  edge[end] = farM;
  std::array<double, kMaxSplitCandidates + 2> before{};
  before[0] = prefix[0];
  for (std::uint32_t j = 1; j < end; ++j) before[j] = weightBefore(h, prefix.data(), edge[j]);
  before[end] = prefix[kDepthHistogramBins];
  auto cost = [&](double a, double b, double weight) {
    return weight > 0.0 ? halfExtent(a, b) * weight : 0.0;
  };

  // best[k][j]: least cost of k + 1 cascades covering [edge 0, edge j]; from[k][j] its previous
  // edge. Cascade k + 1 (the last) must end at edge `end`.
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::array<std::array<double, kMaxSplitCandidates + 2>, kMaxCascades> best{};
  std::array<std::array<std::uint8_t, kMaxSplitCandidates + 2>, kMaxCascades> from{};
  for (auto& row : best) row.fill(kInf);
  for (std::uint32_t j = 1; j < end; ++j) best[0][j] = cost(edge[0], edge[j], before[j]);
  for (std::uint32_t k = 1; k < count; ++k) {
    const std::uint32_t jEnd = k + 1 == count ? end : end - 1;
    for (std::uint32_t j = k + 1; j <= jEnd; ++j) {
      if (k + 1 == count && j != end) continue;
      for (std::uint32_t i = k; i < j; ++i) {
        if (best[k - 1][i] == kInf) continue;
        const double c = best[k - 1][i] + cost(edge[i], edge[j], before[j] - before[i]);
        if (c < best[k][j]) {
          best[k][j] = c;
          from[k][j] = static_cast<std::uint8_t>(i);
        }
      }
    }
  }
  const double minimum = best[count - 1][end];
  if (!(minimum < kInf)) return false;
  SplitArray placed{};
  placed[0] = nearM;
  placed[count] = farM;
  for (std::uint32_t k = count - 1, j = end; k > 0; --k) {
    j = from[k][j];
    placed[k] = edge[j];
  }

  // Hysteresis: last frame's splits while they stay nearly as good.
  if (previous != nullptr) {
    bool usable = true;
    for (std::uint32_t i = 1; i < count; ++i) {
      const double p = (*previous)[i];
      if (!(p > nearM && p < farM) || (i > 1 && !(p > (*previous)[i - 1]))) usable = false;
    }
    if (usable) {
      double kept = 0.0;
      for (std::uint32_t i = 0; i < count; ++i) {
        const double a = i == 0 ? nearM : (*previous)[i];
        const double b = i + 1 == count ? farM : (*previous)[i + 1];
        const double wa = i == 0 ? before[0] : weightBefore(h, prefix.data(), a);
        const double wb = i + 1 == count ? before[end] : weightBefore(h, prefix.data(), b);
        kept += cost(a, b, wb - wa);
      }
      if (kept <= minimum * (1.0 + hysteresis)) {
        for (std::uint32_t i = 1; i < count; ++i) placed[i] = (*previous)[i];
      }
    }
  }
  splits = placed;
  return true;
}

}  // namespace csm
