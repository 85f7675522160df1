#version 450
// The consumer's own lighting shader: Lambert plus ambient, shadowed through the installed
// csm.glsl (set 1, the module's default bindings).
#extension GL_GOOGLE_include_directive : require
#define CSM_SET 1
#include "csm.glsl"

layout(push_constant) uniform Push {
  mat4 viewProjCr;
  vec4 translationCr;
  vec4 color;
} pc;

layout(location = 0) in vec3 inPositionCr;
layout(location = 1) in vec3 inNormalWs;
layout(location = 0) out vec4 outColor;

void main() {
  const vec3 n = normalize(inNormalWs);
  const vec3 ng = csmGeometricNormal(dFdx(inPositionCr), dFdy(inPositionCr), n);
  const float s = csmShadow(inPositionCr, ng, gl_FragCoord.xy);
  const float lambert = max(dot(n, -normalize(csmU.lightDirection.xyz)), 0.0);
  outColor = vec4(pc.color.rgb * (0.15 + 0.85 * lambert * s), 1.0);
}
