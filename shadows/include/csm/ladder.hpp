// The rung ladder: every length that sets a cascade's extent or texel size takes only values of a
// fixed geometric ladder 2^(k / stepsPerOctave) metres, chosen with hysteresis so that a quantity
// oscillating about a rung does not flip between rungs. While a rung holds, the texel grid holds.
#pragma once

#include <climits>

namespace csm {

/// "No rung yet" (a fresh history).
inline constexpr int kNoRung = INT_MIN;

/// Value of rung k: 2^(k / stepsPerOctave), rounded up to 17 significant bits. The same k always
/// gives the same double, and values strictly increase with k for stepsPerOctave <= 64.
[[nodiscard]] double ladderValue(int rung, double stepsPerOctave) noexcept;

/// The smallest rung whose value is >= lengthM (lengthM > 0, finite).
[[nodiscard]] int ladderRungUp(double lengthM, double stepsPerOctave) noexcept;

/// A rung >= lengthM with hysteresis: keeps `previous` while its value still covers lengthM and
/// lies less than (1 + hysteresisSteps) steps above it; otherwise ladderRungUp. Growth takes
/// effect at once (a box never fails to cover); shrinking waits until the length has fallen
/// more than `hysteresisSteps` steps below the rung under the previous one.
[[nodiscard]] int ladderRungUpHysteretic(double lengthM, double stepsPerOctave, int previous,
                                         double hysteresisSteps) noexcept;

/// A rung <= lengthM with hysteresis, the mirror of ladderRungUpHysteretic: keeps `previous`
/// while its value is still <= lengthM and less than (1 + hysteresisSteps) steps below it.
[[nodiscard]] int ladderRungDownHysteretic(double lengthM, double stepsPerOctave, int previous,
                                           double hysteresisSteps) noexcept;

/// The nearest rung with hysteresis: keeps `previous` while lengthM lies within
/// (0.5 + hysteresisSteps) steps of it (in log space); otherwise the nearest rung.
[[nodiscard]] int ladderRungNearestHysteretic(double lengthM, double stepsPerOctave, int previous,
                                              double hysteresisSteps) noexcept;

}  // namespace csm
