#version 460
// The prefiltered filters' resolve (ShadowSettings::kernel vsm, evsm or msm): after each shadow
// pass the renderer turns every layer's depths into moments (csm::depthMoments) and blurs them
// with a separable Gaussian whose radius is ShadowSettings::momentBlurM in metres, i.e.
// momentBlurM / texel texels in each cascade (capped at CSM_MOMENT_MAX_BLUR_TEXELS), so that a
// shadow's softness does not jump at a split. Pass 0 covers a rectangle of layer `layer` (the
// whole layer, or after a cached pass the tiles it changed): each workgroup reads the depths of
// its tile and of the blur's reach around it into shared memory once, blurs their moments along
// x, then along y into level 0 of the moment image; the renderer then builds the mips with
// pass 2 (2x2 means, level by level). Every texel is computed alike whichever rectangle and
// workgroup covers it, and in the same order as a blur along x into an image and then along y
// from it (the previous two-pass form): the same bits.
// The blur works in the cascade's box coordinates: a cached cascade's layer is addressed
// toroidally (wrapOffset), and texels beyond the box's edge read as the far plane (depth 1, lit),
// as the comparison samplers' border does, never as the opposite edge of the layer.
#extension GL_GOOGLE_include_directive : require
#define CSM_SET 0
#define CSM_UNIFORMS_ONLY
#include "csm.glsl"

layout(local_size_x = CSM_MOMENT_GROUP_X, local_size_y = CSM_MOMENT_GROUP_Y) in;

layout(set = 0, binding = 1) uniform sampler2DArray depthMap;
// The moment image's format: RGBA32F, or RG32F for vsm's two moments (compiled with
// CSM_MOMENTS_RG; needs shaderStorageImageExtendedFormats). Loads of RG32F read (r, g, 0, 1) and
// stores keep r, g: the same bits in those channels as the RGBA32F image's. Or RGBA16_UNORM for
// msm's moments quantised (CSM_MOMENTS_Q16, the same feature): level 0 stores csmMsmQuantize of
// the blurred moments (the blur in float, as for RGBA32F); the mips average the quantised values,
// which is the quantisation of the average (the map is affine) up to the format's rounding.
#if defined(CSM_MOMENTS_RG)
layout(set = 0, binding = 2, rg32f) uniform readonly image2DArray mipSource;  // pass 2
layout(set = 0, binding = 3, rg32f) uniform writeonly image2DArray momentsOut;
#elif defined(CSM_MOMENTS_Q16)
layout(set = 0, binding = 2, rgba16) uniform readonly image2DArray mipSource;  // pass 2
layout(set = 0, binding = 3, rgba16) uniform writeonly image2DArray momentsOut;
#else
layout(set = 0, binding = 2, rgba32f) uniform readonly image2DArray mipSource;  // pass 2
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2DArray momentsOut;
#endif

layout(push_constant) uniform Push {
  uint pass;    // 0: depth -> moments, blurred along x and y into level 0; 2: a mip level
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

/// Level 0's texel as the image holds it: the blurred moments, quantised for RGBA16_UNORM.
vec4 stored(vec4 blurred) {
#ifdef CSM_MOMENTS_Q16
  return csmMsmQuantize(blurred);
#else
  return blurred;
#endif
}

// Pass 0's workgroup tile (CSM_MOMENT_GROUP_X x kRows texels): the depths of its texels and of
// the blur's reach around them (at most CSM_MOMENT_MAX_BLUR_TEXELS each side), then their moments
// blurred along x, for every row the blur along y reads; and the Gaussian's weights. Each depth
// is fetched once per workgroup, not once per tap; each invocation writes CSM_MOMENT_ROWS texels
// of its column (lavapipe spends about as long starting an invocation as resolving a texel).
const int kReachMax = CSM_MOMENT_MAX_BLUR_TEXELS;
const int kTileW = CSM_MOMENT_GROUP_X + 2 * kReachMax;
const int kRows = CSM_MOMENT_GROUP_Y * CSM_MOMENT_ROWS;  // texel rows of a workgroup
const int kTileH = kRows + 2 * kReachMax;
shared float sDepth[kTileH * kTileW];
shared vec4 sRowBlur[kTileH * CSM_MOMENT_GROUP_X];
shared float sWeight[kReachMax + 1];

void main() {
  const ivec2 local = ivec2(gl_LocalInvocationID.xy);
  if (pc.pass == 2u) {
    const ivec2 texel = ivec2(gl_GlobalInvocationID.xy);  // in the dispatch's rectangle
    if (any(greaterThanEqual(texel, pc.extent))) return;
    // Mip level k from level k - 1 (bound as `mipSource`): the mean of 2x2 texels.
    const ivec3 dst = ivec3(pc.origin + texel, int(pc.layer));
    const ivec3 src = ivec3(2 * dst.xy, dst.z);
    const vec4 top = imageLoad(mipSource, src) + imageLoad(mipSource, src + ivec3(1, 0, 0));
    const vec4 bottom = imageLoad(mipSource, src + ivec3(0, 1, 0)) +
                        imageLoad(mipSource, src + ivec3(1, 1, 0));
    const vec4 sum = top + bottom;
    imageStore(momentsOut, dst, 0.25 * sum);
    return;
  }
  const int res = int(csmU.resolution);
  const int layer = int(pc.layer);
  // The Gaussian: its 2-sigma radius is blurM metres (mirror of csm::momentBlurRadiusTexels).
  const float texelM = csmU.cascades[layer].texelSizeM;
  const float radius =
      (pc.blurM > 0.0 && texelM > 0.0) ? min(pc.blurM / texelM, float(CSM_MOMENT_MAX_BLUR_TEXELS))
                                       : 0.0;
  const int n = radius >= 0.5 ? int(ceil(radius)) : 0;
  const float inv2Sigma2 = n > 0 ? 2.0 / (radius * radius) : 0.0;  // 1 / (2 (r/2)^2)
  // The workgroup's first texel in the dispatch's rectangle.
  const ivec2 tile = ivec2(gl_WorkGroupID.xy) * ivec2(CSM_MOMENT_GROUP_X, kRows);
  if (n == 0) {
    // No blur (a cascade whose texels are wider than twice momentBlurM): each texel's own moments,
    // through the same arithmetic as the blur's single tap along x and then along y. No shared
    // memory, which lavapipe reads and writes lane by lane.
    const float w0 = exp(-0.0 * inv2Sigma2);
    for (int r = local.y; r < kRows; r += CSM_MOMENT_GROUP_Y) {
      const ivec2 texel = tile + ivec2(local.x, r);  // in the dispatch's rectangle
      if (any(greaterThanEqual(texel, pc.extent))) break;
      const ivec3 id = ivec3(pc.origin + texel, layer);
      const vec4 alongX = (w0 * momentsOf(texelFetch(depthMap, id, 0).r)) / w0;
      imageStore(momentsOut, id, stored((w0 * alongX) / w0));
    }
    return;
  }
  // Layer texel -> box texel (toroidal addressing of cached cascades). A layer texel's neighbour
  // in the box is its neighbour in the layer (modulo res); only the test of the box's edge needs
  // box coordinates.
  const ivec2 offset =
      csmU.wrappedLayers != 0u
          ? ivec2(round(csmU.cascades[layer].wrapOffset)) & (res - 1)
          : ivec2(0);
  const vec4 far = momentsOf(1.0);
  // The shared tile's first texel (the workgroup's, less the reach), in layer coordinates.
  const ivec2 group = pc.origin + tile - ivec2(n);
  const int w = CSM_MOMENT_GROUP_X + 2 * n, h = kRows + 2 * n;
  // The resolution is a power of two (ShadowSettings::resolution): wrapping is a mask, where an
  // integer modulo costs lavapipe a scalar division per lane.
  const int wrap = res - 1;
  const int lane = local.y * CSM_MOMENT_GROUP_X + local.x;
  if (lane <= n) sWeight[lane] = exp(-float(lane * lane) * inv2Sigma2);
  for (int row = local.y; row < h; row += CSM_MOMENT_GROUP_Y) {
    for (int col = local.x; col < w; col += CSM_MOMENT_GROUP_X) {
      const ivec2 t = (group + ivec2(col, row)) & wrap;
      sDepth[row * kTileW + col] = texelFetch(depthMap, ivec3(t, layer), 0).r;
    }
  }
  barrier();
  // Along x, for every row of the tile: the texels beyond the box's edge read as the far plane.
  const int col = local.x;
  const int boxX = (group.x + n + col - offset.x) & wrap;
  for (int row = local.y; row < h; row += CSM_MOMENT_GROUP_Y) {
    vec4 sum = vec4(0.0);
    float weights = 0.0;
    for (int k = -n; k <= n; ++k) {
      const float wk = sWeight[abs(k)];
      weights += wk;
      const int b = boxX + k;
      sum += wk * (b < 0 || b >= res ? far : momentsOf(sDepth[row * kTileW + n + col + k]));
    }
    sRowBlur[row * CSM_MOMENT_GROUP_X + col] = sum / weights;
  }
  barrier();
  // Along y into level 0: CSM_MOMENT_ROWS texels of the column, CSM_MOMENT_GROUP_Y rows apart.
  for (int r = local.y; r < kRows; r += CSM_MOMENT_GROUP_Y) {
    const ivec2 texel = tile + ivec2(col, r);  // in the dispatch's rectangle
    if (any(greaterThanEqual(texel, pc.extent))) break;
    const ivec3 id = ivec3(pc.origin + texel, layer);
    const int boxY = (id.y - offset.y) & wrap;
    vec4 sum = vec4(0.0);
    float weights = 0.0;
    for (int k = -n; k <= n; ++k) {
      const float wk = sWeight[abs(k)];
      weights += wk;
      const int b = boxY + k;
      sum += wk * (b < 0 || b >= res ? far : sRowBlur[(r + n + k) * CSM_MOMENT_GROUP_X + col]);
    }
    imageStore(momentsOut, id, stored(sum / weights));
  }
}
