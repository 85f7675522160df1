#version 450
// The consumer's own vertex shader: positions relative to the camera (the host computes the
// translation in double), normals in world space.
layout(push_constant) uniform Push {
  mat4 viewProjCr;
  vec4 translationCr;
  vec4 color;
} pc;

layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 0) out vec3 outPositionCr;
layout(location = 1) out vec3 outNormalWs;

void main() {
  outPositionCr = inPosition + pc.translationCr.xyz;
  outNormalWs = inNormal;
  gl_Position = pc.viewProjCr * vec4(outPositionCr, 1.0);
}
