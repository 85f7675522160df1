#version 450
// The one GPU probe of csm.glsl (glue::ShadowProbe): evaluates the shadow function and the cascade
// selection at fixed receiver points (camera-relative positions computed in double on the CPU),
// one invocation per point. Used by the GPU tests (tests/gpu), the shimmer tests (tests/stability)
// and csm_tradeoff; the same code path as a lighting shader, with the point's screen pixel where
// the caller gives one (else its index) as csmShadow's pixel argument.
#extension GL_GOOGLE_include_directive : require

#define CSM_SET 1
#include "csm.glsl"

layout(local_size_x = 64) in;

struct ProbePoint {
  vec4 posCr;     // xyz: receiver position relative to the camera (m); w: screen pixel x
  vec4 normalWs;  // xyz: unit world normal; w: screen pixel y (negative: use the index)
};

layout(std430, set = 0, binding = 0) readonly buffer Points {
  ProbePoint points[];
};
// Two vec4 per point. [2i]: x shadow factor (1 lit), y cascade index (-1 none), z blended
// cascade (-1 none), w blend weight. [2i+1]: x the smallest |receiver depth - stored depth| (m)
// over the 5x5 texels around the receiver in its cascade (1e30 outside every cascade): a
// receiver within rounding noise of a stored depth sits on a depth tie (a diagnostic: reports
// give the smallest gap of the points that changed); y the view depth the selection used (m).
layout(std430, set = 0, binding = 1) writeonly buffer Results {
  vec4 results[];
};
layout(push_constant) uniform ProbePush {
  uint count;
} pc;

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= pc.count) return;
  const vec3 posCr = points[i].posCr.xyz;
  const vec3 normalWs = points[i].normalWs.xyz;
  const vec2 pixel = points[i].posCr.w >= 0.0 ? vec2(points[i].posCr.w, points[i].normalWs.w)
                                              : vec2(float(i % 4096u), float(i / 4096u));
  const float s = csmShadow(posCr, normalWs, pixel);
  const float viewDepth = csmViewDepth(posCr);
  const CsmSelection sel = csmSelectCascade(viewDepth);
  float gapM = 1e30;
  if (sel.index >= 0) {
    const vec3 c = csmShadowCoord(sel.index, posCr, normalWs);
    const vec2 base = floor(c.xy);
    const float metresPerDepth = csmU.cascades[sel.index].depthRangeM;
    for (int dy = -2; dy <= 2; ++dy) {
      for (int dx = -2; dx <= 2; ++dx) {
        // Through the wrap of windowed (stabilised per-layer or cached) layers.
        const vec2 uv = csmWrapUv(base + vec2(dx, dy) + 0.5, sel.index);
        const float stored = textureLod(csmDepthMap, vec3(uv, float(sel.index)), 0.0).r;
        gapM = min(gapM, abs(c.z - stored) * metresPerDepth);
      }
    }
  }
  results[2u * i] = vec4(s, float(sel.index), float(sel.blendIndex), sel.blendWeight);
  results[2u * i + 1u] = vec4(gapM, viewDepth, 0.0, 0.0);
}
