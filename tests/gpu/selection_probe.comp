#version 450
// Test probe: csm.glsl's cascade selection (index, blended cascade, blend weight) at given
// camera-relative points, one invocation per point, for comparison with csm::selectCascade.
#extension GL_GOOGLE_include_directive : require

#define CSM_SET 1
#include "csm.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer Points {
  vec4 posCr[];  // xyz camera-relative position
};
layout(std430, set = 0, binding = 1) writeonly buffer Results {
  vec4 selection[];  // x index, y blend index, z blend weight, w view depth
};
layout(push_constant) uniform ProbePush {
  vec4 normalWs;
  uint count;
} pc;

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= pc.count) return;
  const float depth = csmViewDepth(posCr[i].xyz);
  const CsmSelection s = csmSelectCascade(depth);
  selection[i] = vec4(float(s.index), float(s.blendIndex), s.blendWeight, depth);
}
