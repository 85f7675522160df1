#version 460
// The view-depth range of the visible receivers in a host's depth buffer, and optionally their
// histogram over log-spaced view-depth bins, for receiver-driven splits
// (csm::vk::DepthRangeReducer). Each workgroup reduces 16x16 pixels in shared memory and folds
// its min/max into the result slot with one atomic each, and each non-empty bin of its tile's
// histogram with one atomic add. Positive floats compare like their bit patterns as unsigned
// integers, so the min/max atomics work on floatBitsToUint.
// Pixels at the clear depth (sky) and non-finite or non-positive depths are skipped.
// Optionally (boundsCount > 0) the receivers' light-space x, y bounds per cascade: each pixel's
// camera-relative position is reconstructed from its view depth and the projection, binned into
// the cascade whose view-depth interval holds it, and its light-space x, y (camera-relative, the
// host adds the camera's in double) folded in with atomicMin on order-preserving uints (the
// maxima stored inverted, so one fill value, 0xffffffff, resets every field).
#extension GL_GOOGLE_include_directive : require
#include "csm/shared_constants.h"

layout(local_size_x = 16, local_size_y = 16) in;

layout(set = 0, binding = 0) uniform sampler2D depthTex;
// Per slot: range.x = min depth bits, y = max depth bits, z = pixels counted, w = unused;
// bins: receiver pixels per view-depth bin (all 0 without a histogram).
// bounds: per cascade (min x, min y, ~max x, ~max y) as order-preserving uints.
struct Slot {
  uvec4 range;
  uint bins[CSM_DEPTH_HISTOGRAM_BINS];
  uint bounds[CSM_MAX_CASCADES * 4];
};
layout(set = 0, binding = 1, std430) buffer Result {
  Slot slots[];
} result;

layout(push_constant) uniform Push {
  uvec2 extent;
  // View depth from the depth buffer's value z: d = p32 / (z + p22), with p22 = P[2][2] and
  // p32 = P[3][2] of the host's projection (any perspective, standard or reversed depth).
  float p22;
  float p32;
  float clearDepth;
  uint slot;
  // Histogram: bin = floor(ln(d / histNear) * binsPerLog), clamped to the bins (csm::
  // depthHistogramBin); histNear = 0: no histogram.
  float histNear;
  float binsPerLog;
  // Bounds: light-space x and y rows of (light basis^T x camera rotation), w = 1 / P[0][0] and
  // 1 / P[1][1]; the projection's off-centre terms P[2][0], P[2][1]; the cascade count (0: no
  // bounds) and the splits the frame was drawn with.
  vec4 lsX;
  vec4 lsY;
  vec2 pOff;
  uint boundsCount;
  float pad;
  float splits[CSM_MAX_CASCADES + 1];
} pc;

shared uint sMin;
shared uint sMax;
shared uint sCount;
shared uint sBins[CSM_DEPTH_HISTOGRAM_BINS];
shared uint sBounds[CSM_MAX_CASCADES * 4];

// Order-preserving float -> uint: negative floats reversed below the positive ones.
uint orderedBits(float f) {
  const uint u = floatBitsToUint(f);
  return (u & 0x80000000u) != 0u ? ~u : (u | 0x80000000u);
}

void main() {
  const uint local = gl_LocalInvocationIndex;
  if (local == 0u) {
    sMin = 0x7f7fffffu;  // FLT_MAX
    sMax = 0u;
    sCount = 0u;
  }
  for (uint b = local; b < CSM_DEPTH_HISTOGRAM_BINS; b += 256u) sBins[b] = 0u;
  if (local < CSM_MAX_CASCADES * 4) sBounds[local] = 0xffffffffu;
  barrier();
  const uvec2 p = gl_GlobalInvocationID.xy;
  if (p.x < pc.extent.x && p.y < pc.extent.y) {
    const float z = texelFetch(depthTex, ivec2(p), 0).r;
    if (z != pc.clearDepth) {
      const float d = pc.p32 / (z + pc.p22);
      if (d > 0.0 && !isinf(d) && !isnan(d)) {
        const uint bits = floatBitsToUint(d);
        atomicMin(sMin, bits);
        atomicMax(sMax, bits);
        atomicAdd(sCount, 1u);
        if (pc.histNear > 0.0) {
          const float u = log(d / pc.histNear) * pc.binsPerLog;
          const uint bin = uint(clamp(u, 0.0, float(CSM_DEPTH_HISTOGRAM_BINS - 1)));
          atomicAdd(sBins[bin], 1u);
        }
        if (pc.boundsCount > 0u) {
          const vec2 ndc = (vec2(p) + 0.5) / vec2(pc.extent) * 2.0 - 1.0;
          const vec3 v = vec3((ndc.x + pc.pOff.x) * pc.lsX.w, (ndc.y + pc.pOff.y) * pc.lsY.w,
                              -1.0) * d;
          const vec2 ls = vec2(dot(pc.lsX.xyz, v), dot(pc.lsY.xyz, v));
          int c = -1;
          for (uint i = 0u; i < pc.boundsCount; ++i) {
            if (d >= pc.splits[i] && d < pc.splits[i + 1u]) c = int(i);
          }
          if (c >= 0) {
            const uint o = uint(c) * 4u;
            atomicMin(sBounds[o + 0u], orderedBits(ls.x));
            atomicMin(sBounds[o + 1u], orderedBits(ls.y));
            atomicMin(sBounds[o + 2u], ~orderedBits(ls.x));
            atomicMin(sBounds[o + 3u], ~orderedBits(ls.y));
          }
        }
      }
    }
  }
  barrier();
  if (local == 0u && sCount > 0u) {
    atomicMin(result.slots[pc.slot].range.x, sMin);
    atomicMax(result.slots[pc.slot].range.y, sMax);
    atomicAdd(result.slots[pc.slot].range.z, sCount);
  }
  for (uint b = local; b < CSM_DEPTH_HISTOGRAM_BINS; b += 256u) {
    if (sBins[b] > 0u) atomicAdd(result.slots[pc.slot].bins[b], sBins[b]);
  }
  if (local < pc.boundsCount * 4u && sBounds[local] != 0xffffffffu) {
    atomicMin(result.slots[pc.slot].bounds[local], sBounds[local]);
  }
}
