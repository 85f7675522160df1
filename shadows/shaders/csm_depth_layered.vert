// Shadow depth pass, every cascade in one render pass: each instance goes to one layer
// (gl_Layer, Vulkan 1.2 shaderOutputLayer). The push constants carry the mask of cascades this
// caster was culled into; instance n draws into the n-th set bit, so per-cascade culling is kept.
#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_ARB_shader_viewport_layer_array : require

#define CSM_SET 0
#define CSM_UNIFORMS_ONLY
#include "csm.glsl"

layout(location = 0) in vec3 inPositionMs;
// The layer, for the thin casters' geometry stage (csm_depth_thin.geom), which must write
// gl_Layer itself; without a geometry stage nothing reads it.
layout(location = 0) flat out uint csmLayer;

// 68 bytes (CSM_DEPTH_PUSH_SIZE, C++ DepthPushLayered).
layout(push_constant) uniform CsmDepthPush {
  mat4 modelToCameraRelative;
  uint cascadeMask;
} pc;

void main() {
  uint n = uint(gl_InstanceIndex);
  int layer = 0;
  for (int i = 0; i < CSM_MAX_CASCADES; ++i) {
    if ((pc.cascadeMask & (1u << uint(i))) != 0u) {
      if (n == 0u) {
        layer = i;
        break;
      }
      --n;
    }
  }
  gl_Layer = layer;
  csmLayer = uint(layer);
  gl_Position =
      csmU.cascades[layer].viewProjCr * (pc.modelToCameraRelative * vec4(inPositionMs, 1.0));
}
