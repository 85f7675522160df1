#version 450
// Sample world lit pass (forward): the shading of world_shading.glsl per rasterised fragment.
#extension GL_GOOGLE_include_directive : require

#define CSM_SET 1
#define CSM_IMPLICIT_LOD  // fragment stage: the prefiltered filters read the footprint's mip
#include "csm.glsl"
#include "world_shading.glsl"

layout(location = 0) in vec3 inPositionCr;
layout(location = 1) in vec3 inNormalWs;
layout(location = 2) in vec4 inColor;
layout(location = 0) out vec4 outColor;

void main() {
  vec3 n = normalize(inNormalWs);
  if (!gl_FrontFacing) n = -n;  // open and thin meshes are seen from both sides
  // The bias follows the facet the shadow map holds (coarse cones and canopies); lighting the
  // smooth normal.
  const vec3 dPdx = dFdx(inPositionCr), dPdy = dFdy(inPositionCr);
  const vec3 ng = csmGeometricNormal(dPdx, dPdy, n);
  outColor = vec4(
      worldShade(inPositionCr, n, ng, inColor.rgb, inColor.a > 0.5, gl_FragCoord.xy, dPdx, dPdy),
      1.0);
}
