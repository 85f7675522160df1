// The thin casters' widening rule (csm/thin_casters.hpp).
#include "csm/thin_casters.hpp"

#include <algorithm>
#include <cmath>

namespace csm {

float thinCasterWidenTexels(float requestedTexels, float widthM, double texelM) noexcept {
  if (!(requestedTexels > 0.0f) || !std::isfinite(requestedTexels)) return 0.0f;
  if (!(widthM > 0.0f) || !std::isfinite(widthM) || !(texelM > 0.0) || !std::isfinite(texelM)) {
    return requestedTexels;
  }
  const double widthTexels = double(widthM) / texelM;
  if (widthTexels < kThinFullTexelMinWidthTexels || widthTexels >= 1.0) return requestedTexels;
  return std::max(requestedTexels, float(0.5 * (1.0 - widthTexels)));
}

float thinCasterMaxWidenTexels(float requestedTexels) noexcept {
  if (!(requestedTexels > 0.0f) || !std::isfinite(requestedTexels)) return 0.0f;
  return std::max(requestedTexels, kThinWidthRuleMaxTexels);
}

}  // namespace csm
