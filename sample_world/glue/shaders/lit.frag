#version 450
// Engine lit pass: Lambert + Blinn-Phong under one directional light, shadowed through csm.glsl
// (set 1); ambient darkened by mix(1, s, 0.5). The csm debug outputs replace the colour when on.
#extension GL_GOOGLE_include_directive : require

#define CSM_SET 1
#include "csm.glsl"

layout(std140, set = 0, binding = 0) uniform LitFrame {
  mat4 viewProjCr;
  vec4 lightDirection;
  vec4 lightColor;
  vec4 ambientColor;
  vec4 params;
} frame;

layout(push_constant) uniform LitPush {
  mat4 modelCr;
  vec4 normalToWs[3];
  vec4 color;
} pc;

layout(location = 0) in vec3 inPositionCr;
layout(location = 1) in vec3 inNormalWs;
layout(location = 0) out vec4 outColor;

void main() {
  const vec3 n = normalize(inNormalWs);
  const vec3 toLight = -normalize(frame.lightDirection.xyz);
  const vec3 toEye = normalize(-inPositionCr);  // the camera sits at the camera-relative origin
  // The bias follows the facet the shadow map holds; lighting the smooth normal.
  const vec3 ng = csmGeometricNormal(dFdx(inPositionCr), dFdy(inPositionCr), n);
  const float s = csmShadow(inPositionCr, ng, gl_FragCoord.xy);
  const float lambert = max(dot(n, toLight), 0.0);
  const vec3 h = normalize(toLight + toEye);
  const float spec = lambert > 0.0 ? pow(max(dot(n, h), 0.0), frame.params.y) : 0.0;
  const vec3 base = pc.color.rgb;
  vec3 color = base * frame.ambientColor.rgb * mix(1.0, s, 0.5) +
               frame.lightColor.rgb * s * (base * lambert + frame.params.x * spec);
  if (csmDebugMode() != CSM_DEBUG_NONE) {
    color = csmDebugColor(inPositionCr, n, gl_FragCoord.xy, s, color);
  }
  outColor = vec4(color, pc.color.a);
}
