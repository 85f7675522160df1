// Shadow depth pass, one cascade per render pass. The push constants carry the whole
// model -> shadow clip transform of this caster in this cascade, composed in double on the CPU
// about the cascade's snapped box centre, so the map does not depend on the camera's sub-texel
// position (see modelToShadowClip in shadow_renderer.cpp).
#version 450

layout(location = 0) in vec3 inPositionMs;

// 68 bytes (CSM_DEPTH_PUSH_SIZE, C++ DepthPushPerLayer): model -> shadow clip, then the cascade
// index (unused here).
layout(push_constant) uniform CsmDepthPush {
  mat4 modelToShadowClip;
  uint cascade;
} pc;

void main() { gl_Position = pc.modelToShadowClip * vec4(inPositionMs, 1.0); }
