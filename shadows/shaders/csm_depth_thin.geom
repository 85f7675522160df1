// Shadow depth pass, thin casters (CasterInstance::thin): every triangle is drawn as it is and
// gets a rim in light space, so that a caster thinner than a texel (a 3 cm cable under 28 cm
// texels) still covers the texel centres along its length instead of a dashed few. How wide:
// the push constants' widening of the layer drawn (csm::thinCasterWidenTexels of the caster's
// width in that cascade, RendererOptions::thinCasterWidenTexels at least). The map is an orthographic projection (w = 1), so the widening is exact in texels: each
// edge is extruded outward along its own normal in the map's plane (a quad at the edge's depth),
// and each corner gets the wedge between its two extruded edges (at the corner's depth): a
// bevelled dilation, no miter spikes on slivers. The triangle itself is emitted unchanged, so
// where it covers a texel the depth is what the plain pipeline writes; the rim only adds texels,
// at depths of the triangle's own boundary. A triangle seen edge-on (a line in the map) becomes
// a band twice the widening wide along it. Used where the device has geometry shaders, unless it
// has VK_EXT_conservative_rasterization and the widening is half a texel or more. Both depth
// vertex shaders hand over the layer (csmLayer: 0 for the per-layer passes, the cascade for the
// layered pass, which picks it per instance); it is forwarded to gl_Layer on every vertex.
#version 450
#extension GL_GOOGLE_include_directive : require

#include "csm/shared_constants.h"
#include "csm/gpu_shared.h"

layout(triangles) in;
layout(triangle_strip, max_vertices = 24) out;

layout(constant_id = 1) const float kResolution = 1024.0;

layout(location = 0) flat in uint csmLayer[];

// CSM_THIN_PUSH_SIZE bytes at CSM_THIN_PUSH_OFFSET (C++ ThinPush), after the vertex stage's.
layout(push_constant) uniform CsmThinPush {
  layout(offset = CSM_THIN_PUSH_OFFSET) float widenTexels[CSM_MAX_CASCADES];
} thinPc;

// Outward normal (unit, texels) of edge a -> b for a triangle of orientation `s` (+1 counter-
// clockwise); 0 for an edge of zero length.
vec2 edgeNormal(vec2 a, vec2 b, float s) {
  const vec2 e = b - a;
  const float len = length(e);
  return len > 0.0 ? s * vec2(e.y, -e.x) / len : vec2(0.0);
}

void emitTexel(vec2 t, float z) {
  gl_Layer = int(csmLayer[0]);
  gl_Position = vec4(t * (2.0 / kResolution), z, 1.0);
  EmitVertex();
}

void main() {
  vec2 p[3];
  float z[3];
  for (int i = 0; i < 3; ++i) {
    const vec4 c = gl_in[i].gl_Position;
    p[i] = c.xy / c.w * (0.5 * kResolution);  // texels about the map's centre
    z[i] = c.z / c.w;
  }
  // The triangle as the plain pipeline draws it.
  for (int i = 0; i < 3; ++i) {
    gl_Layer = int(csmLayer[0]);
    gl_Position = gl_in[i].gl_Position;
    EmitVertex();
  }
  EndPrimitive();
  const vec2 e0 = p[1] - p[0];
  const vec2 e2 = p[2] - p[0];
  const float s = e0.x * e2.y - e0.y * e2.x >= 0.0 ? 1.0 : -1.0;
  vec2 n[3];
  const float widen = thinPc.widenTexels[min(csmLayer[0], uint(CSM_MAX_CASCADES - 1))];
  for (int i = 0; i < 3; ++i) n[i] = edgeNormal(p[i], p[(i + 1) % 3], s) * widen;
  // Edge i (p[i] -> p[i + 1]) extruded by n[i]; corner i between n[i - 1] and n[i].
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    // Wound like the triangle (so face culling treats the rim as the triangle).
    emitTexel(p[j], z[j]);
    emitTexel(p[i], z[i]);
    emitTexel(p[j] + n[i], z[j]);
    emitTexel(p[i] + n[i], z[i]);
    EndPrimitive();
    const int k = (i + 2) % 3;  // the previous edge ends at corner i
    emitTexel(p[i], z[i]);
    emitTexel(p[i] + n[k], z[i]);
    emitTexel(p[i] + n[i], z[i]);
    EndPrimitive();
  }
}
