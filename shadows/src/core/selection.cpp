#include "csm/selection.hpp"

#include <algorithm>

namespace csm {

double viewDepthM(const CascadeFrame& frame, const glm::dvec3& posWs) noexcept {
  return glm::dot(posWs - frame.cameraPositionWs, frame.cameraForwardWs);
}

CascadeSelection selectCascade(const CascadeFrame& frame, double viewDepth,
                               double blendBand) noexcept {
  CascadeSelection sel;
  const std::uint32_t n = frame.cascadeCount;
  if (n == 0 || !(viewDepth >= frame.splitsM[0] && viewDepth < frame.splitsM[n])) return sel;
  std::uint32_t i = 0;
  while (i + 1 < n && viewDepth >= frame.splitsM[i + 1]) ++i;
  if (frame.cascades[i].empty) return sel;
  sel.index = static_cast<int>(i);
  if (blendBand > 0.0 && i + 1 < n && !frame.cascades[i + 1].empty) {
    const double splitFar = frame.splitsM[i + 1];
    const double bandStart = cascadeReadFromM(frame, i + 1, blendBand);
    // The band starts at bandStart inclusive, as in csmSelectCascade (csm.glsl): weight 0 there.
    if (viewDepth >= bandStart) {
      sel.blendIndex = static_cast<int>(i + 1);
      sel.blendWeight = static_cast<float>((viewDepth - bandStart) / (splitFar - bandStart));
    }
  }
  return sel;
}

double cascadeReadFromM(const CascadeFrame& frame, std::uint32_t i, double blendBand) noexcept {
  if (i == 0) return frame.splitsM[0];
  return frame.splitsM[i] - blendBand * (frame.splitsM[i] - frame.splitsM[i - 1]);
}

double shadowFade(const CascadeFrame& frame, double viewDepthM) noexcept {
  const double length = frame.fadeLengthM;
  const double start = frame.fadeEndM - length;
  if (!(length > 0.0) || !(viewDepthM > start)) return 0.0;
  const double t = std::min((viewDepthM - start) / length, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

}  // namespace csm
