#include "csm/ladder.hpp"

#include <cmath>

#include "csm/frustum.hpp"

namespace csm {

double ladderValue(int rung, double stepsPerOctave) noexcept {
  // Rounded up to 17 significant bits (quantizeLengthUp): a rung's texel 2h/res and whole
  // multiples of it are then exact in double, which keeps snapping exact far from the origin.
  return quantizeLengthUp(std::exp2(static_cast<double>(rung) / stepsPerOctave));
}

int ladderRungUp(double lengthM, double stepsPerOctave) noexcept {
  int k = static_cast<int>(std::ceil(std::log2(lengthM) * stepsPerOctave));
  // exp2/log2 round: correct by at most a step either way so the answer is exact.
  while (ladderValue(k, stepsPerOctave) < lengthM) ++k;
  while (ladderValue(k - 1, stepsPerOctave) >= lengthM) --k;
  return k;
}

int ladderRungUpHysteretic(double lengthM, double stepsPerOctave, int previous,
                           double hysteresisSteps) noexcept {
  const int up = ladderRungUp(lengthM, stepsPerOctave);
  if (previous == kNoRung || previous < up) return up;
  // previous >= up covers; keep it while lengthM is less than (1 + h) steps below it.
  const double stepsBelow = static_cast<double>(previous) - std::log2(lengthM) * stepsPerOctave;
  return stepsBelow < 1.0 + hysteresisSteps ? previous : up;
}

int ladderRungDownHysteretic(double lengthM, double stepsPerOctave, int previous,
                             double hysteresisSteps) noexcept {
  int down = ladderRungUp(lengthM, stepsPerOctave);
  if (ladderValue(down, stepsPerOctave) > lengthM) --down;
  if (previous == kNoRung || previous > down) return down;
  const double stepsAbove = std::log2(lengthM) * stepsPerOctave - static_cast<double>(previous);
  return stepsAbove < 1.0 + hysteresisSteps ? previous : down;
}

int ladderRungNearestHysteretic(double lengthM, double stepsPerOctave, int previous,
                                double hysteresisSteps) noexcept {
  const double u = std::log2(lengthM) * stepsPerOctave;
  if (previous != kNoRung && std::abs(u - static_cast<double>(previous)) < 0.5 + hysteresisSteps) {
    return previous;
  }
  return static_cast<int>(std::lround(u));
}

}  // namespace csm
