#version 460
// Lambert lighting from a fixed directional light plus an ambient term.

layout(push_constant) uniform Push {
  mat4 mvpCr;
  vec4 normalToWs[3];
  vec4 color;
} pc;

layout(location = 0) in vec3 inNormalWs;
layout(location = 0) out vec4 outColor;

const vec3 kToLightWs = normalize(vec3(0.4, 1.0, 0.6));

void main() {
  float lambert = max(dot(normalize(inNormalWs), kToLightWs), 0.0);
  outColor = vec4(pc.color.rgb * (0.25 + 0.75 * lambert), pc.color.a);
}
