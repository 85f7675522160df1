#version 460
// The view-depth range of the visible receivers in a host's depth buffer, for receiver-driven
// splits (csm::vk::DepthRangeReducer). Each workgroup reduces 16x16 pixels in shared memory and
// folds its min/max into the result slot with one atomic each. Positive floats compare like
// their bit patterns as unsigned integers, so the atomics work on floatBitsToUint.
// Pixels at the clear depth (sky) and non-finite or non-positive depths are skipped.
layout(local_size_x = 16, local_size_y = 16) in;

layout(set = 0, binding = 0) uniform sampler2D depthTex;
// Per slot: x = min depth bits, y = max depth bits, z = pixels counted, w = unused.
layout(set = 0, binding = 1, std430) buffer Result {
  uvec4 slots[];
} result;

layout(push_constant) uniform Push {
  uvec2 extent;
  // View depth from the depth buffer's value z: d = p32 / (z + p22), with p22 = P[2][2] and
  // p32 = P[3][2] of the host's projection (any perspective, standard or reversed depth).
  float p22;
  float p32;
  float clearDepth;
  uint slot;
} pc;

shared uint sMin;
shared uint sMax;
shared uint sCount;

void main() {
  if (gl_LocalInvocationIndex == 0u) {
    sMin = 0x7f7fffffu;  // FLT_MAX
    sMax = 0u;
    sCount = 0u;
  }
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
      }
    }
  }
  barrier();
  if (gl_LocalInvocationIndex == 0u && sCount > 0u) {
    atomicMin(result.slots[pc.slot].x, sMin);
    atomicMax(result.slots[pc.slot].y, sMax);
    atomicAdd(result.slots[pc.slot].z, sCount);
  }
}
