// Shadow depth pass, one cascade per render pass. The push constants carry the whole
// model -> shadow clip transform of this caster in this cascade, composed in double on the CPU
// about the cascade's snapped box centre, so the map does not depend on the camera's sub-texel
// position (see modelToShadowClip in shadow_renderer.cpp).
#version 450

layout(location = 0) in vec3 inPositionMs;
// Layer 0 of the one-layer view, for the thin casters' geometry stage (csm_depth_thin.geom);
// without a geometry stage nothing reads it.
layout(location = 0) flat out uint csmLayer;

// 68 bytes (CSM_DEPTH_PUSH_SIZE, C++ DepthPushPerLayer): model -> shadow clip, then the cascade
// index (unused here).
layout(push_constant) uniform CsmDepthPush {
  mat4 modelToShadowClip;
  uint cascade;
} pc;

void main() {
  gl_Position = pc.modelToShadowClip * vec4(inPositionMs, 1.0);
  csmLayer = 0u;
}
