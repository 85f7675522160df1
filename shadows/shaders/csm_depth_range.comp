#version 460
// The view-depth range of the visible receivers in a host's depth buffer, and optionally their
// histogram over log-spaced view-depth bins, for receiver-driven splits
// (csm::vk::DepthRangeReducer). Each workgroup reduces 16x16 pixels in shared memory and folds
// its min/max into the result slot with one atomic each, and each non-empty bin of its tile's
// histogram with one atomic add. Positive floats compare like their bit patterns as unsigned
// integers, so the min/max atomics work on floatBitsToUint.
// Pixels at the clear depth (sky) and non-finite or non-positive depths are skipped.
#extension GL_GOOGLE_include_directive : require
#include "csm/shared_constants.h"

layout(local_size_x = 16, local_size_y = 16) in;

layout(set = 0, binding = 0) uniform sampler2D depthTex;
// Per slot: range.x = min depth bits, y = max depth bits, z = pixels counted, w = unused;
// bins: receiver pixels per view-depth bin (all 0 without a histogram).
struct Slot {
  uvec4 range;
  uint bins[CSM_DEPTH_HISTOGRAM_BINS];
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
} pc;

shared uint sMin;
shared uint sMax;
shared uint sCount;
shared uint sBins[CSM_DEPTH_HISTOGRAM_BINS];

void main() {
  const uint local = gl_LocalInvocationIndex;
  if (local == 0u) {
    sMin = 0x7f7fffffu;  // FLT_MAX
    sMax = 0u;
    sCount = 0u;
  }
  for (uint b = local; b < CSM_DEPTH_HISTOGRAM_BINS; b += 256u) sBins[b] = 0u;
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
}
