#version 450
// Accuracy pass: camera-relative positions and world normals of every receiver pixel, for
// stability_accuracy.frag (same vertex layout and transforms as the engine's lit pass).

layout(location = 0) in vec3 inPositionMs;
layout(location = 1) in vec3 inNormalMs;

layout(std140, set = 0, binding = 0) uniform AccuracyFrame {
  mat4 viewProjCr;  // camera-relative world -> clip
} frame;

layout(push_constant) uniform AccuracyPush {
  mat4 modelCr;        // object -> camera-relative world (translation made relative on the CPU)
  vec4 normalToWs[3];  // columns of the object -> world normal matrix
} pc;

layout(location = 0) out vec3 outPositionCr;
layout(location = 1) out vec3 outNormalWs;

void main() {
  const vec4 posCr = pc.modelCr * vec4(inPositionMs, 1.0);
  outPositionCr = posCr.xyz;
  outNormalWs = mat3(pc.normalToWs[0].xyz, pc.normalToWs[1].xyz, pc.normalToWs[2].xyz) * inNormalMs;
  gl_Position = frame.viewProjCr * posCr;
}
