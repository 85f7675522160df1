// Shadow depth pass, one cascade per render pass: the cascade index comes in the push constants.
#version 450
#extension GL_GOOGLE_include_directive : require

#define CSM_SET 0
#define CSM_UNIFORMS_ONLY
#include "csm.glsl"

layout(location = 0) in vec3 inPositionMs;

// 68 bytes (CSM_DEPTH_PUSH_SIZE): camera-relative model matrix, then the cascade index.
layout(push_constant) uniform CsmDepthPush {
  mat4 modelCr;
  uint cascadeOrMask;
} pc;

void main() {
  const uint cascade = min(pc.cascadeOrMask, uint(CSM_MAX_CASCADES - 1));
  gl_Position = csmU.cascades[cascade].viewProjCr * (pc.modelCr * vec4(inPositionMs, 1.0));
}
