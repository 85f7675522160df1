#version 450
// Overlay: solid colour, or a shadow-map layer read raw (nearest) with its depth remapped to the
// range the cascade's bounding sphere occupies, so that casters are readable.
#extension GL_GOOGLE_include_directive : require

#define CSM_SET 0
#include "csm.glsl"

layout(location = 0) in vec2 inUv;
layout(location = 1) in vec4 inColor;
layout(location = 2) flat in vec4 inDepth;
layout(location = 0) out vec4 outColor;

void main() {
  if (inDepth.x < 0.0) {
    outColor = inColor;
    return;
  }
  const float d = textureLod(csmDepthMap, vec3(inUv, inDepth.x), 0.0).r;
  const float v = clamp((d - inDepth.y) / max(inDepth.z - inDepth.y, 1e-6), 0.0, 1.0);
  // Near the light dark, far (nothing drawn) light; a cascade tint edge comes from the vertices.
  outColor = vec4(mix(vec3(0.05), vec3(0.95), v) * inColor.rgb, 1.0);
}
