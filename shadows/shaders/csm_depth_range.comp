#version 460
// The view-depth range of the visible receivers in a host's depth buffer, and optionally their
// histogram over log-spaced view-depth bins, for receiver-driven splits
// (csm::vk::DepthRangeReducer). Each workgroup reduces 16x16 pixels, each of its 8x8 invocations
// 2x2 of them in registers first (a run of pixels in one cascade or bin is folded once: a fourth
// of the shared-memory atomics, which a CPU rasteriser pays lane by lane), then in shared memory,
// and folds its min/max into the result slot with one atomic each, and each non-empty bin of its
// tile's histogram with one atomic add. Positive floats compare like their bit patterns as unsigned
// integers, so the min/max atomics work on floatBitsToUint.
// Pixels at the clear depth (sky) and non-finite or non-positive depths are skipped.
// Optionally (boundsCount > 0) the receivers' light-space x, y bounds per cascade: each pixel's
// camera-relative position is reconstructed from its view depth and the projection, binned into
// the cascade whose view-depth interval holds it, and its light-space x, y (camera-relative, the
// host adds the camera's in double) folded in with atomicMin on order-preserving uints (the
// maxima stored inverted, so one fill value, 0xffffffff, resets every field).
// Optionally (tileMarks != 0, with bounds) the receiver-marked tiles (csm::ReceiverTileMarks):
// each workgroup marks, per cascade, every tile of the cascade's grid that the light-space
// rectangle of its receivers there, widened by the reach, touches: the receivers the lighting
// shades with the cascade (its bounds above, when it is not empty) and those in the blend band of
// the cascade before it (a second rectangle). The host writes each cascade's grid (origin about
// the camera, 1 / tile side, reach) and blend band into the slot.
#extension GL_GOOGLE_include_directive : require
#include "csm/shared_constants.h"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D depthTex;
// Per slot: range.x = min depth bits, y = max depth bits, z = pixels counted, w = unused;
// bins: receiver pixels per view-depth bin (all 0 without a histogram).
// bounds: per cascade (min x, min y, ~max x, ~max y) as order-preserving uints.
// tiles: per cascade CSM_TILE_WORDS words of marks (bit y * CSM_TILE_GRID_SIDE + x); grid:
// per cascade (grid origin x, y in light space about the camera (m), 1 / tile side (1/m),
// reach (m)); band: per cascade (view depth where its blend band starts, 1 when non-empty).
struct Slot {
  uvec4 range;
  uint bins[CSM_DEPTH_HISTOGRAM_BINS];
  uint bounds[CSM_MAX_CASCADES * 4];
  uint tiles[CSM_MAX_CASCADES * CSM_TILE_WORDS];
  vec4 grid[CSM_MAX_CASCADES];
  vec4 band[CSM_MAX_CASCADES];
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
  uint tileMarks;  // 1: mark tiles (with bounds)
  float splits[CSM_MAX_CASCADES + 1];
} pc;

shared uint sMin;
shared uint sMax;
shared uint sCount;
shared uint sBins[CSM_DEPTH_HISTOGRAM_BINS];
shared uint sBounds[CSM_MAX_CASCADES * 4];
shared uint sBandBounds[CSM_MAX_CASCADES * 4];  // as sBounds, the band's receivers
shared vec4 sGrid[CSM_MAX_CASCADES];
shared vec4 sBand[CSM_MAX_CASCADES];

// Order-preserving float -> uint: negative floats reversed below the positive ones.
uint orderedBits(float f) {
  const uint u = floatBitsToUint(f);
  return (u & 0x80000000u) != 0u ? ~u : (u | 0x80000000u);
}

// The inverse of orderedBits().
float fromOrderedBits(uint u) {
  return uintBitsToFloat((u & 0x80000000u) != 0u ? (u & 0x7fffffffu) : ~u);
}

// Marks the grid tiles of cascade c that the rectangle of a bounds entry (min x, min y, ~max x,
// ~max y; light space about the camera) touches, widened by the cascade's reach.
void markTiles(uint c, uint minX, uint minY, uint notMaxX, uint notMaxY) {
  if (minX == 0xffffffffu) return;  // no receiver
  const vec4 g = sGrid[c];
  const vec2 lo = floor((vec2(fromOrderedBits(minX), fromOrderedBits(minY)) - g.w - g.xy) * g.z);
  const vec2 hi =
      floor((vec2(fromOrderedBits(~notMaxX), fromOrderedBits(~notMaxY)) + g.w - g.xy) * g.z);
  const float last = float(CSM_TILE_GRID_SIDE - 1);
  if (hi.x < 0.0 || hi.y < 0.0 || lo.x > last || lo.y > last) return;
  const uvec2 a = uvec2(max(lo, vec2(0.0)));
  const uvec2 b = uvec2(min(hi, vec2(last)));
  for (uint y = a.y; y <= b.y; ++y) {
    for (uint x = a.x; x <= b.x; ++x) {
      const uint bit = y * uint(CSM_TILE_GRID_SIDE) + x;
      atomicOr(result.slots[pc.slot].tiles[c * uint(CSM_TILE_WORDS) + bit / 32u],
               1u << (bit % 32u));
    }
  }
}

// A light-space rectangle being folded in registers: the run's cascade (-1: none) and its
// bounds (min x, min y, max x, max y).
struct Run {
  int c;
  vec4 r;
};

// Folds a run's rectangle into the shared bounds of its cascade.
void flushBounds(Run run, bool band) {
  if (run.c < 0) return;
  const uint o = uint(run.c) * 4u;
  if (band) {
    atomicMin(sBandBounds[o + 0u], orderedBits(run.r.x));
    atomicMin(sBandBounds[o + 1u], orderedBits(run.r.y));
    atomicMin(sBandBounds[o + 2u], ~orderedBits(run.r.z));
    atomicMin(sBandBounds[o + 3u], ~orderedBits(run.r.w));
  } else {
    atomicMin(sBounds[o + 0u], orderedBits(run.r.x));
    atomicMin(sBounds[o + 1u], orderedBits(run.r.y));
    atomicMin(sBounds[o + 2u], ~orderedBits(run.r.z));
    atomicMin(sBounds[o + 3u], ~orderedBits(run.r.w));
  }
}

// Adds light-space point ls of cascade c to a run, folding the run first when c differs.
void addToRun(inout Run run, int c, vec2 ls, bool band) {
  if (run.c != c) {
    flushBounds(run, band);
    run.c = c;
    run.r = vec4(ls, ls);
    return;
  }
  run.r = vec4(min(run.r.xy, ls), max(run.r.zw, ls));
}

void main() {
  const uint local = gl_LocalInvocationIndex;
  const uint size = gl_WorkGroupSize.x * gl_WorkGroupSize.y;
  if (local == 0u) {
    sMin = 0x7f7fffffu;  // FLT_MAX
    sMax = 0u;
    sCount = 0u;
  }
  for (uint b = local; b < CSM_DEPTH_HISTOGRAM_BINS; b += size) sBins[b] = 0u;
  for (uint b = local; b < CSM_MAX_CASCADES * 4; b += size) {
    sBounds[b] = 0xffffffffu;
    sBandBounds[b] = 0xffffffffu;
  }
  if (pc.tileMarks != 0u && local < CSM_MAX_CASCADES) {
    sGrid[local] = result.slots[pc.slot].grid[local];
    sBand[local] = result.slots[pc.slot].band[local];
  }
  barrier();
  // This invocation's 2x2 pixels of the workgroup's 16x16, reduced in registers.
  uint minBits = 0x7f7fffffu, maxBits = 0u, count = 0u;
  int bin = -1;
  uint binCount = 0u;
  Run own = Run(-1, vec4(0.0));
  Run banded = Run(-1, vec4(0.0));
  const uvec2 base = gl_WorkGroupID.xy * 16u + gl_LocalInvocationID.xy * 2u;
  for (uint k = 0u; k < 4u; ++k) {
    const uvec2 p = base + uvec2(k & 1u, k >> 1u);
    if (p.x >= pc.extent.x || p.y >= pc.extent.y) continue;
    const float z = texelFetch(depthTex, ivec2(p), 0).r;
    if (z == pc.clearDepth) continue;
    const float d = pc.p32 / (z + pc.p22);
    if (!(d > 0.0) || isinf(d) || isnan(d)) continue;
    const uint bits = floatBitsToUint(d);
    minBits = min(minBits, bits);
    maxBits = max(maxBits, bits);
    ++count;
    if (pc.histNear > 0.0) {
      const float u = log(d / pc.histNear) * pc.binsPerLog;
      const int b = int(clamp(u, 0.0, float(CSM_DEPTH_HISTOGRAM_BINS - 1)));
      if (b != bin) {
        if (binCount > 0u) atomicAdd(sBins[bin], binCount);
        bin = b;
        binCount = 0u;
      }
      ++binCount;
    }
    if (pc.boundsCount == 0u) continue;
    const vec2 ndc = (vec2(p) + 0.5) / vec2(pc.extent) * 2.0 - 1.0;
    const vec3 v =
        vec3((ndc.x + pc.pOff.x) * pc.lsX.w, (ndc.y + pc.pOff.y) * pc.lsY.w, -1.0) * d;
    const vec2 ls = vec2(dot(pc.lsX.xyz, v), dot(pc.lsY.xyz, v));
    int c = -1;
    for (uint i = 0u; i < pc.boundsCount; ++i) {
      if (d >= pc.splits[i] && d < pc.splits[i + 1u]) c = int(i);
    }
    if (c < 0) continue;
    addToRun(own, c, ls, false);
    // The blend band: the next cascade (when it is not empty) shades it too.
    if (pc.tileMarks != 0u && uint(c) + 1u < pc.boundsCount) {
      const uint n = uint(c) + 1u;
      const float bandStart = sBand[c].x;
      if (sBand[c].y != 0.0 && sBand[n].y != 0.0 && bandStart < pc.splits[n] &&
          d >= bandStart) {
        addToRun(banded, int(n), ls, true);
      }
    }
  }
  if (count > 0u) {
    atomicMin(sMin, minBits);
    atomicMax(sMax, maxBits);
    atomicAdd(sCount, count);
  }
  if (binCount > 0u) atomicAdd(sBins[bin], binCount);
  flushBounds(own, false);
  flushBounds(banded, true);
  barrier();
  if (local == 0u && sCount > 0u) {
    atomicMin(result.slots[pc.slot].range.x, sMin);
    atomicMax(result.slots[pc.slot].range.y, sMax);
    atomicAdd(result.slots[pc.slot].range.z, sCount);
  }
  for (uint b = local; b < CSM_DEPTH_HISTOGRAM_BINS; b += size) {
    if (sBins[b] > 0u) atomicAdd(result.slots[pc.slot].bins[b], sBins[b]);
  }
  if (local < pc.boundsCount * 4u && sBounds[local] != 0xffffffffu) {
    atomicMin(result.slots[pc.slot].bounds[local], sBounds[local]);
  }
  // One invocation per non-empty cascade marks the tiles under the workgroup's rectangles.
  if (pc.tileMarks != 0u && local < pc.boundsCount && sBand[local].y != 0.0) {
    const uint o = local * 4u;
    markTiles(local, sBounds[o], sBounds[o + 1u], sBounds[o + 2u], sBounds[o + 3u]);
    markTiles(local, sBandBounds[o], sBandBounds[o + 1u], sBandBounds[o + 2u],
              sBandBounds[o + 3u]);
  }
}
