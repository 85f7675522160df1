#version 450
// Sample world lit pass: Lambert + Blinn-Phong under the sun, shadowed through csm.glsl (set 1),
// with the cascade-visualisation overlay: cascade tint (blend bands show as the mix of two
// tints) and each cascade's shadow texels as a checker on the receivers.
#extension GL_GOOGLE_include_directive : require

#define CSM_SET 1
#include "csm.glsl"

layout(std140, set = 0, binding = 0) uniform WorldFrame {
  mat4 viewProjCr;
  vec4 lightDirection;
  vec4 lightColor;
  vec4 ambientColor;
  uvec4 overlay;
} frame;

layout(location = 0) in vec3 inPositionCr;
layout(location = 1) in vec3 inNormalWs;
layout(location = 2) in vec4 inColor;
layout(location = 0) out vec4 outColor;

void main() {
  vec3 n = normalize(inNormalWs);
  if (!gl_FrontFacing) n = -n;  // open and thin meshes are seen from both sides
  const vec3 toLight = -normalize(frame.lightDirection.xyz);
  const vec3 toEye = normalize(-inPositionCr);
  const bool receives = inColor.a > 0.5;
  // The bias follows the facet the shadow map holds (coarse cones and canopies); lighting the
  // smooth normal.
  const vec3 ng = csmGeometricNormal(dFdx(inPositionCr), dFdy(inPositionCr), n);
  const float s = receives ? csmShadow(inPositionCr, ng, gl_FragCoord.xy) : 1.0;
  const float lambert = max(dot(n, toLight), 0.0);
  const vec3 h = normalize(toLight + toEye);
  const float spec = lambert > 0.0 ? pow(max(dot(n, h), 0.0), 24.0) : 0.0;
  const vec3 base = inColor.rgb;
  // Sky light from above, a little bounce from below.
  const float sky = 0.75 + 0.25 * n.y;
  vec3 color = base * frame.ambientColor.rgb * sky * mix(1.0, s, 0.4) +
               frame.lightColor.rgb * s * (base * lambert + 0.08 * spec);

  if (receives && (frame.overlay.x != 0u || frame.overlay.y != 0u)) {
    const CsmSelection sel = csmSelectCascade(csmViewDepth(inPositionCr));
    if (sel.index >= 0) {
      if (frame.overlay.x != 0u) {
        vec3 tint = csmCascadeTint(sel.index);
        if (sel.blendIndex >= 0) tint = mix(tint, csmCascadeTint(sel.blendIndex), sel.blendWeight);
        color = mix(color, tint, 0.3);
      }
      if (frame.overlay.y != 0u) {
        const vec3 c = csmShadowCoord(sel.index, inPositionCr, vec3(0.0));
        const vec2 cell = floor(c.xy);
        const float checker = mod(cell.x + cell.y, 2.0);
        color *= 0.78 + 0.22 * checker;
      }
    }
  }
  if (csmDebugMode() != CSM_DEBUG_NONE) {
    color = csmDebugColor(inPositionCr, n, gl_FragCoord.xy, s, color);
  }
  outColor = vec4(color, 1.0);
}
