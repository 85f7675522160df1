#version 450
// Test probe: evaluates csm.glsl's shadow function at given camera-relative points in compute
// (the use a stability test makes of it), one invocation per point.
#extension GL_GOOGLE_include_directive : require

#define CSM_SET 1
#include "csm.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer Points {
  vec4 posCr[];  // xyz camera-relative position
};
layout(std430, set = 0, binding = 1) writeonly buffer Results {
  float shadow[];
};
layout(push_constant) uniform ProbePush {
  vec4 normalWs;
  uint count;
} pc;

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= pc.count) return;
  shadow[i] = csmShadow(posCr[i].xyz, pc.normalWs.xyz, vec2(float(i), 0.0));
}
