#version 460
// Engine mesh vertex (position, normal) transformed by a camera-relative model-view-projection.

layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;

layout(push_constant) uniform Push {
  mat4 mvpCr;          // object -> clip, with the camera at the origin (built in double on CPU)
  vec4 normalToWs[3];  // columns of the object -> world normal matrix (xyz used)
  vec4 color;          // base colour
} pc;  // 128 bytes: the minimum maxPushConstantsSize every device offers

layout(location = 0) out vec3 outNormalWs;

void main() {
  gl_Position = pc.mvpCr * vec4(inPosition, 1.0);
  outNormalWs = mat3(pc.normalToWs[0].xyz, pc.normalToWs[1].xyz, pc.normalToWs[2].xyz) * inNormal;
}
