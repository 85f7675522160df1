// Accuracy pass: what csm.glsl answers at every receiver pixel, written as floats for the CPU to
// compare with a ray-traced truth: position, shadow factor, normal, selected cascade, and the
// world footprint of the pixel (for the texel-to-pixel ratio). Included by
// stability_accuracy.frag (the prefiltered filters read level 0) and stability_accuracy_lod.frag
// (CSM_IMPLICIT_LOD: they read the mip of the pixel's footprint, as the sample world's lit pass
// does).

#define CSM_SET 1
#include "csm.glsl"

// 1: the bias uses the interpolated shading normal instead of the facet normal.
layout(constant_id = 16) const int kBiasFromShadingNormal = 0;

layout(location = 0) in vec3 inPositionCr;
layout(location = 1) in vec3 inNormalWs;

layout(location = 0) out vec4 outPositionShadow;  // xyz camera-relative position (m), w shadow
layout(location = 1) out vec4 outNormalCascade;   // xyz unit world normal, w cascade (-1 none)
layout(location = 2) out vec4 outFootprint;       // x pixel footprint (m), y blend cascade,
                                                  // z blend weight, w 1 (a surface was drawn)

void main() {
  const vec3 n = normalize(inNormalWs);
  // The bias follows the facet (csmGeometricNormal) unless the harness asks for the smooth
  // normal (the bias before issue #12's facet normals, for comparison).
  const vec3 facet = csmGeometricNormal(dFdx(inPositionCr), dFdy(inPositionCr), n);
  const float s =
      csmShadow(inPositionCr, kBiasFromShadingNormal != 0 ? n : facet, gl_FragCoord.xy);
  const CsmSelection sel = csmSelectCascade(csmViewDepth(inPositionCr));
  // Square root of the pixel's area on the surface.
  const vec3 dx = dFdx(inPositionCr);
  const vec3 dy = dFdy(inPositionCr);
  const float footprint = sqrt(length(cross(dx, dy)));
  outPositionShadow = vec4(inPositionCr, s);
  outNormalCascade = vec4(n, float(sel.index));
  outFootprint = vec4(footprint, float(sel.blendIndex), sel.blendWeight, 1.0);
}
