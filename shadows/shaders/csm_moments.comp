#version 460
// The prefiltered filters' resolve (ShadowSettings::kernel vsm, evsm or msm): after each shadow
// pass the renderer turns every layer's depths into moments (csm::depthMoments) and blurs them
// with a separable Gaussian whose radius is ShadowSettings::momentBlurM in metres, i.e.
// momentBlurM / texel texels in each cascade (capped at CSM_MOMENT_MAX_BLUR_TEXELS), so that a
// shadow's softness does not jump at a split. Pass 0 converts and blurs along x into the scratch
// image; pass 1 blurs the scratch along y into level 0 of the moment image (the renderer then
// builds its mips with pass 2, 2x2 means level by level). One invocation per texel of a
// rectangle of layer `layer` (the whole layer, or after a cached pass the tiles it changed); the
// renderer resolves the layers one after the other through a one-layer scratch.
// The blur works in the cascade's box coordinates: a cached cascade's layer is addressed
// toroidally (wrapOffset), and texels beyond the box's edge read as the far plane (depth 1, lit),
// as the comparison samplers' border does, never as the opposite edge of the layer.
#extension GL_GOOGLE_include_directive : require
#define CSM_SET 0
#define CSM_UNIFORMS_ONLY
#include "csm.glsl"

layout(local_size_x = CSM_MOMENT_GROUP, local_size_y = CSM_MOMENT_GROUP) in;

layout(set = 0, binding = 1) uniform sampler2DArray depthMap;
layout(set = 0, binding = 2, rgba32f) uniform image2DArray scratch;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2DArray momentsOut;

layout(push_constant) uniform Push {
  uint pass;    // 0: depth -> moments, blur along x; 1: blur along y; 2: a mip level
  uint kernel;  // CSM_KERNEL_VSM, _EVSM or _MSM
  float blurM;  // ShadowSettings::momentBlurM
  uint layer;   // the cascade
  ivec2 origin;  // the rectangle of the layer this dispatch covers (all of it, or the tiles a
  ivec2 extent;  // cached pass changed: each texel is computed alike either way)
} pc;

/// Mirror of csm::depthMoments.
vec4 momentsOf(float depth) {
  const float z = clamp(depth, 0.0, 1.0);
  if (pc.kernel == CSM_KERNEL_VSM) return vec4(z, z * z, 0.0, 0.0);
  if (pc.kernel == CSM_KERNEL_EVSM) {
    const float w = 2.0 * z - 1.0;
    const float pos = exp(csmU.moments.z * w);
    const float neg = -exp(-csmU.moments.w * w);
    return vec4(pos, pos * pos, neg, neg * neg);
  }
  const float w = 2.0 * z - 1.0;
  const float w2 = w * w;
  return vec4(w, w2, w2 * w, w2 * w2);
}

void main() {
  const int res = int(csmU.resolution);
  const int layer = int(pc.layer);
  if (any(greaterThanEqual(ivec2(gl_GlobalInvocationID.xy), pc.extent))) return;
  if (pc.pass == 2u) {
    // Mip level k from level k - 1 (bound as `scratch`, every layer): the mean of 2x2 texels.
    const ivec3 dst = ivec3(pc.origin + ivec2(gl_GlobalInvocationID.xy), int(pc.layer));
    const ivec3 src = ivec3(2 * dst.xy, dst.z);
    const vec4 top = imageLoad(scratch, src) + imageLoad(scratch, src + ivec3(1, 0, 0));
    const vec4 bottom = imageLoad(scratch, src + ivec3(0, 1, 0)) +
                        imageLoad(scratch, src + ivec3(1, 1, 0));
    const vec4 sum = top + bottom;
    imageStore(momentsOut, dst, 0.25 * sum);
    return;
  }
  const ivec3 id = ivec3(pc.origin + ivec2(gl_GlobalInvocationID.xy), layer);
  if (id.x >= res || id.y >= res) return;
  // Layer texel -> box texel (toroidal addressing of cached cascades).
  const ivec2 offset =
      csmU.wrappedLayers != 0u
          ? ivec2(mod(round(csmU.cascades[layer].wrapOffset), vec2(float(res))))
          : ivec2(0);
  const ivec2 box = (id.xy - offset + res) % res;  // offset in [0, res): never negative
  // The Gaussian: its 2-sigma radius is blurM metres (mirror of csm::momentBlurRadiusTexels).
  const float texelM = csmU.cascades[layer].texelSizeM;
  const float radius =
      (pc.blurM > 0.0 && texelM > 0.0) ? min(pc.blurM / texelM, float(CSM_MOMENT_MAX_BLUR_TEXELS))
                                       : 0.0;
  const int n = radius >= 0.5 ? int(ceil(radius)) : 0;
  const float inv2Sigma2 = n > 0 ? 2.0 / (radius * radius) : 0.0;  // 1 / (2 (r/2)^2)
  const int axis = pc.pass == 0u ? 0 : 1;
  const vec4 far = momentsOf(1.0);
  vec4 sum = vec4(0.0);
  float weights = 0.0;
  for (int k = -n; k <= n; ++k) {
    const float w = exp(-float(k * k) * inv2Sigma2);
    weights += w;
    const int b = box[axis] + k;
    if (b < 0 || b >= res) {
      sum += w * far;
      continue;
    }
    ivec2 t = id.xy;
    t[axis] = (b + offset[axis]) % res;
    sum += w * (pc.pass == 0u ? momentsOf(texelFetch(depthMap, ivec3(t, layer), 0).r)
                              : imageLoad(scratch, ivec3(t, 0)));
  }
  const vec4 result = sum / weights;
  if (pc.pass == 0u) {
    imageStore(scratch, ivec3(id.xy, 0), result);
  } else {
    imageStore(momentsOut, id, result);
  }
}
