#version 450
// Engine lit pass: camera-relative positions and world normals for lit.frag.

layout(location = 0) in vec3 inPositionMs;
layout(location = 1) in vec3 inNormalMs;

layout(std140, set = 0, binding = 0) uniform LitFrame {
  mat4 viewProjCr;      // camera-relative world -> clip
  vec4 lightDirection;  // xyz direction the light travels
  vec4 lightColor;      // rgb
  vec4 ambientColor;    // rgb
  vec4 params;          // x specular strength, y shininess
} frame;

// 128 bytes: the minimum maxPushConstantsSize.
layout(push_constant) uniform LitPush {
  mat4 modelCr;         // object -> camera-relative world (translation made relative on the CPU)
  vec4 normalToWs[3];   // columns of the object -> world normal matrix
  vec4 color;           // base colour
} pc;

layout(location = 0) out vec3 outPositionCr;
layout(location = 1) out vec3 outNormalWs;

void main() {
  const vec4 posCr = pc.modelCr * vec4(inPositionMs, 1.0);
  outPositionCr = posCr.xyz;
  outNormalWs = mat3(pc.normalToWs[0].xyz, pc.normalToWs[1].xyz, pc.normalToWs[2].xyz) * inNormalMs;
  gl_Position = frame.viewProjCr * posCr;
}
