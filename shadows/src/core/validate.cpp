// Validation of every input of the cascade math. Comparisons are written so that NaN fails
// them (`!(x >= lo)`), and every refusal names the field, its value and the allowed range.
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

#include "csm/names.hpp"
#include "csm/types.hpp"

namespace csm {
namespace {

using Check = std::optional<ValidationError>;

Check refuse(std::string field, double value, std::string allowed) {
  return ValidationError{std::move(field), value, std::move(allowed)};
}

Check finiteVec(const glm::dvec3& v, const std::string& field) {
  static constexpr const char* kAxes[3] = {".x", ".y", ".z"};
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(v[i])) return refuse(field + kAxes[i], v[i], "a finite number");
  }
  return std::nullopt;
}

/// Finite, and within the domain where positions are exact (types.hpp, kMaxWorldCoordinateM).
Check worldPosition(const glm::dvec3& v, const std::string& field) {
  static constexpr const char* kAxes[3] = {".x", ".y", ".z"};
  for (int i = 0; i < 3; ++i) {
    if (!(std::abs(v[i]) <= kMaxWorldCoordinateM)) {
      return refuse(field + kAxes[i], v[i],
                    "a coordinate in metres in [-1e9, 1e9] (kMaxWorldCoordinateM: the domain "
                    "where shadows are exact)");
    }
  }
  return std::nullopt;
}

/// A number as %g (1e-03 stays readable; std::to_string would print 0.001000).
std::string shortNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

bool isPowerOfTwo(std::uint32_t v) {
  return v != 0 && (v & (v - 1)) == 0;
}

}  // namespace

std::optional<ValidationError> validate(const ShadowSettings& s) {
  if (!(s.cascadeCount >= 1 && s.cascadeCount <= kMaxCascades)) {
    return refuse("settings.cascadeCount", s.cascadeCount,
                  "an integer in [1, " + std::to_string(kMaxCascades) + "]");
  }
  if (!(s.resolution >= kMinResolution && s.resolution <= kMaxResolution) ||
      !isPowerOfTwo(s.resolution)) {
    return refuse("settings.resolution", s.resolution, "a power of two in [256, 16384]");
  }
  if (!(s.splitLambda >= 0.0 && s.splitLambda <= 1.0)) {
    return refuse("settings.splitLambda", s.splitLambda, "a number in [0, 1]");
  }
  if (s.explicitSplits()) {
    double previous = 0.0;
    for (std::uint32_t i = 0; i + 1 < s.cascadeCount; ++i) {
      const double p = s.splitPositions[i];
      if (!(p > previous && p < 1.0)) {
        return refuse("settings.splitPositions[" + std::to_string(i) + "]", p,
                      "a fraction in (" + std::to_string(previous) +
                          ", 1): explicit splits are strictly increasing in (0, 1)");
      }
      previous = p;
    }
  }
  if (!(s.shadowDistanceM > 0.0 && s.shadowDistanceM <= kMaxWorldCoordinateM)) {
    return refuse("settings.shadowDistanceM", s.shadowDistanceM,
                  "a distance in metres > camera.nearM and <= 1e9 (kMaxWorldCoordinateM)");
  }
  if (!(s.blendBand >= 0.0 && s.blendBand <= 0.5)) {
    return refuse("settings.blendBand", s.blendBand, "a fraction of a cascade's depth in [0, 0.5]");
  }
  if (!(s.depthBiasConstant >= 0.0f) || !std::isfinite(s.depthBiasConstant)) {
    return refuse("settings.depthBiasConstant", s.depthBiasConstant, "a finite number >= 0");
  }
  if (!(s.depthBiasSlope >= 0.0f) || !std::isfinite(s.depthBiasSlope)) {
    return refuse("settings.depthBiasSlope", s.depthBiasSlope, "a finite number >= 0");
  }
  if (!(s.normalOffsetTexels >= 0.0f && s.normalOffsetTexels <= 16.0f)) {
    return refuse("settings.normalOffsetTexels", s.normalOffsetTexels,
                  "a multiple of the kernel's reach in [0, 16]");
  }
  if (!(s.depthFloorTexels >= 0.0f && s.depthFloorTexels <= 16.0f)) {
    return refuse("settings.depthFloorTexels", s.depthFloorTexels, "a number of texels in [0, 16]");
  }
  if (!(s.ladderStepsPerOctave >= 1.0 && s.ladderStepsPerOctave <= 64.0)) {
    return refuse("settings.ladderStepsPerOctave", s.ladderStepsPerOctave,
                  "rungs per doubling in [1, 64]");
  }
  if (!(s.ladderHysteresisSteps >= 0.0 && s.ladderHysteresisSteps <= 8.0)) {
    return refuse("settings.ladderHysteresisSteps", s.ladderHysteresisSteps,
                  "a number of rungs in [0, 8]");
  }
  if (!(s.boxFit == BoxFit::kSphere || s.boxFit == BoxFit::kTight)) {
    return refuse("settings.boxFit", static_cast<double>(s.boxFit), "0 (sphere) or 1 (tight)");
  }
  if (!(s.lightStepDeg >= 0.0 && s.lightStepDeg <= 10.0)) {
    return refuse("settings.lightStepDeg", s.lightStepDeg, "an angle in degrees in [0, 10]");
  }
  if (!(s.receiverDepthMargin >= 0.0 && s.receiverDepthMargin <= 1.0)) {
    return refuse("settings.receiverDepthMargin", s.receiverDepthMargin,
                  "a fraction of the range in [0, 1]");
  }
  if (!(s.receiverBoundsMargin >= 0.0 && s.receiverBoundsMargin <= 1.0)) {
    return refuse("settings.receiverBoundsMargin", s.receiverBoundsMargin,
                  "a fraction of the box half side in [0, 1]");
  }
  if (!(s.receiverSplitScheme == ReceiverSplitScheme::kRange ||
        s.receiverSplitScheme == ReceiverSplitScheme::kHistogram)) {
    return refuse("settings.receiverSplitScheme", static_cast<double>(s.receiverSplitScheme),
                  "0 (range) or 1 (histogram)");
  }
  if (!(s.diagnostics.cacheRestore == CacheRestore::kWholeLayer ||
        s.diagnostics.cacheRestore == CacheRestore::kCopyRects ||
        s.diagnostics.cacheRestore == CacheRestore::kRedraw ||
        s.diagnostics.cacheRestore == CacheRestore::kShaderCopy)) {
    return refuse("settings.diagnostics.cacheRestore",
                  static_cast<double>(s.diagnostics.cacheRestore),
                  "0 (whole layer), 1 (copy rects), 2 (redraw) or 3 (shader copy)");
  }
  if (!(s.fadeFraction >= 0.0 && s.fadeFraction <= 1.0)) {
    return refuse("settings.fadeFraction", s.fadeFraction,
                  "a fraction of the shadow distance in [0, 1] (0: no fade)");
  }
  if (!(s.minCasterTexels >= 0.0f && s.minCasterTexels <= 1e6f)) {
    return refuse("settings.minCasterTexels", s.minCasterTexels,
                  "a number of texels in [0, 1e6] (0 turns the test off)");
  }
  if (!(s.lightAngularDiameterDeg >= 0.0 && s.lightAngularDiameterDeg <= 20.0)) {
    return refuse("settings.lightAngularDiameterDeg", s.lightAngularDiameterDeg,
                  "an angle in degrees in [0, 20] (the sun: 0.53)");
  }
  if (!(s.maxPenumbraM >= 0.0 && s.maxPenumbraM <= 100.0)) {
    return refuse("settings.maxPenumbraM", s.maxPenumbraM, "a width in metres in [0, 100]");
  }
  if (!(static_cast<std::uint32_t>(s.kernel) < CSM_FILTER_COUNT)) {
    return refuse(
        "settings.kernel", static_cast<double>(static_cast<std::uint32_t>(s.kernel)),
        "a PcfKernel in [0, " + std::to_string(CSM_FILTER_COUNT - 1) + "] (" + kernelNames() + ")");
  }
  if (!(s.pcssTaps >= 1 && s.pcssTaps <= CSM_PCSS_MAX_TAPS)) {
    return refuse("settings.pcssTaps", s.pcssTaps,
                  "a number of taps in [1, " + std::to_string(CSM_PCSS_MAX_TAPS) + "]");
  }
  if (!(s.momentBlurM >= 0.0 && s.momentBlurM <= 10.0)) {
    return refuse("settings.momentBlurM", s.momentBlurM, "a width in metres in [0, 10]");
  }
  if (!(s.momentBleedReduction >= 0.0f && s.momentBleedReduction <= 0.95f)) {
    return refuse("settings.momentBleedReduction", s.momentBleedReduction,
                  "a fraction in [0, 0.95]");
  }
  const std::string exponentRange = "an exponent in (0, " +
                                    std::to_string(int(CSM_EVSM_MAX_EXPONENT)) +
                                    "] (e^(2c) must stay finite in a 32-bit float)";
  if (!(s.evsmPositiveExponent > 0.0f && s.evsmPositiveExponent <= CSM_EVSM_MAX_EXPONENT)) {
    return refuse("settings.evsmPositiveExponent", s.evsmPositiveExponent, exponentRange);
  }
  if (!(s.evsmNegativeExponent > 0.0f && s.evsmNegativeExponent <= CSM_EVSM_MAX_EXPONENT)) {
    return refuse("settings.evsmNegativeExponent", s.evsmNegativeExponent, exponentRange);
  }
  if (!(s.msmMomentBias >= 1e-7f && s.msmMomentBias <= 0.01f)) {
    return refuse("settings.msmMomentBias", s.msmMomentBias, "a weight in [1e-7, 0.01]");
  }
  return std::nullopt;
}

std::optional<ValidationError> validate(const Camera& c) {
  if (auto e = worldPosition(c.positionWs, "camera.positionWs")) return e;
  const glm::dquat& q = c.orientationWs;
  const double len = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  if (!(std::abs(len - 1.0) <= 1e-3)) {
    return refuse("camera.orientationWs (length)", len,
                  "a unit quaternion (length in [0.999, 1.001])");
  }
  if (!(c.fovYRad > 0.0 && c.fovYRad < glm::pi<double>())) {
    return refuse("camera.fovYRad", c.fovYRad, "an angle in radians in (0, pi)");
  }
  if (!(c.aspect > 0.0 && c.aspect <= 1e4)) {
    return refuse("camera.aspect", c.aspect, "width / height in (0, 1e4]");
  }
  if (!(c.nearM >= kMinNearM && c.nearM <= kMaxWorldCoordinateM)) {
    return refuse("camera.nearM", c.nearM, "a distance in metres in [1e-6, 1e9] (kMinNearM)");
  }
  if (!(c.farM > c.nearM * (1.0 + 1e-6)) || !(c.farM <= c.nearM * kMaxFarOverNear)) {
    return refuse("camera.farM", c.farM,
                  "a distance in metres in (camera.nearM * (1 + 1e-6), camera.nearM * 1e10] = (" +
                      shortNumber(c.nearM * (1.0 + 1e-6)) + ", " +
                      shortNumber(c.nearM * kMaxFarOverNear) + "] (kMaxFarOverNear)");
  }
  return std::nullopt;
}

std::optional<ValidationError> validate(const DirectionalLight& l) {
  if (auto e = finiteVec(l.directionWs, "light.directionWs")) return e;
  const double len = glm::length(l.directionWs);
  if (!(len > 1e-12)) {
    return refuse("light.directionWs (length)", len, "a non-zero direction (length > 1e-12)");
  }
  return std::nullopt;
}

std::optional<ValidationError> validate(const ReceiverDepthRange& r) {
  if (!(r.minM >= 0.0) || !std::isfinite(r.minM)) {
    return refuse("receivers.minM", r.minM, "a finite view depth in metres >= 0");
  }
  if (!(r.maxM >= r.minM) || !std::isfinite(r.maxM)) {
    return refuse("receivers.maxM", r.maxM, "a finite view depth in metres >= receivers.minM");
  }
  const ReceiverDepthHistogram& h = r.histogram;
  if (h.present()) {
    if (!(h.nearM > 0.0) || !std::isfinite(h.nearM)) {
      return refuse("receivers.histogram.nearM", h.nearM,
                    "a finite view depth in metres > 0 (0: no histogram)");
    }
    if (!(h.farM > h.nearM * (1.0 + 1e-6)) || !std::isfinite(h.farM)) {
      return refuse("receivers.histogram.farM", h.farM,
                    "a finite view depth in metres > receivers.histogram.nearM * (1 + 1e-6)");
    }
  }
  const ReceiverLightBounds& b = r.lightBounds;
  if (b.present()) {
    if (b.cascadeCount > kMaxCascades) {
      return refuse("receivers.lightBounds.cascadeCount", b.cascadeCount,
                    "a cascade count in [1, CSM_MAX_CASCADES] (0: no bounds)");
    }
    if (auto e = worldPosition(b.cameraPositionWs, "receivers.lightBounds.cameraPositionWs")) {
      return e;
    }
    for (std::uint32_t i = 0; i <= b.cascadeCount; ++i) {
      if (!std::isfinite(b.splitsM[i])) {
        return refuse("receivers.lightBounds.splitsM", b.splitsM[i], "finite view depths");
      }
    }
    for (std::uint32_t i = 0; i < b.cascadeCount; ++i) {
      // Empty (min > max, infinities included) is allowed; NaN is not.
      for (int a = 0; a < 2; ++a) {
        if (std::isnan(b.minLs[i][a]) || std::isnan(b.maxLs[i][a])) {
          return refuse("receivers.lightBounds.minLs/maxLs", b.minLs[i][a],
                        "light-space positions, not NaN (min > max: no receiver)");
        }
      }
    }
  }
  return std::nullopt;
}

std::optional<ValidationError> validate(const AabbWs& box, const char* field) {
  const std::string name = field;
  if (auto e = worldPosition(box.minWs, name + ".minWs")) return e;
  if (auto e = worldPosition(box.maxWs, name + ".maxWs")) return e;
  static constexpr const char* kAxes[3] = {".x", ".y", ".z"};
  for (int i = 0; i < 3; ++i) {
    if (!(box.maxWs[i] >= box.minWs[i])) {
      return refuse(name + ".maxWs" + kAxes[i], box.maxWs[i],
                    "a coordinate >= " + name + ".minWs" + kAxes[i]);
    }
  }
  return std::nullopt;
}

std::optional<ValidationError> validate(const ShadowSettings& settings, const Camera& camera,
                                        const DirectionalLight& light) {
  if (auto e = validate(settings)) return e;
  if (auto e = validate(camera)) return e;
  if (auto e = validate(light)) return e;
  if (!(settings.shadowDistanceM > camera.nearM * (1.0 + 1e-6))) {
    return refuse(
        "settings.shadowDistanceM", settings.shadowDistanceM,
        "a distance > camera.nearM * (1 + 1e-6) = " + shortNumber(camera.nearM * (1.0 + 1e-6)));
  }
  return std::nullopt;
}

}  // namespace csm
