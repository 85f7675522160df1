// csm.glsl: cascaded shadow maps for any lighting shader (fragment or compute).
//
//   #extension GL_GOOGLE_include_directive : require
//   #define CSM_SET 1            // the descriptor set the host binds the module's resources to
//   #include "csm.glsl"
//   ...
//   float s = csmShadow(posCr, normalWs, gl_FragCoord.xy);   // 1 lit, 0 in shadow
//
// Inputs are camera-relative world positions (posWs - cameraPositionWs, as float) and world
// normals (unit length). Resources (set CSM_SET): the CsmUniforms block at CSM_BINDING_UNIFORMS
// (C++: csm/gpu_layout.hpp), the shadow map through a comparison sampler at
// CSM_BINDING_SHADOW_MAP and through a plain nearest sampler at CSM_BINDING_SHADOW_DEPTH (debug
// outputs only). Variants are specialization constants: CSM_SPEC_KERNEL (PCF kernel) and
// CSM_SPEC_BLEND (0: hard switch at the split, 1: blend across the band).
// Define CSM_UNIFORMS_ONLY to declare only the uniform block (the depth pass does).
#ifndef CSM_GLSL
#define CSM_GLSL

#include "csm/shared_constants.h"
#include "csm/gpu_shared.h"

#ifndef CSM_SET
#error "csm.glsl: #define CSM_SET (descriptor set of the shadow resources, e.g. CSM_DEFAULT_SET) before #include"
#endif
#if CSM_BINDING_UNIFORMS == CSM_BINDING_SHADOW_MAP || CSM_BINDING_SHADOW_MAP == CSM_BINDING_SHADOW_DEPTH
#error "csm.glsl: CSM_BINDING_* must be distinct"
#endif

// Mirrors csm::CsmCascadeGpu / csm::CsmUniforms (std140; offsets pinned by static_assert there).
struct CsmCascade {
  mat4 viewProjCr;  // camera-relative world -> shadow clip (xy in [-1, 1], z depth in [0, 1])
  vec4 splitTexel;  // x split near (m), y split far (m), z texel size (m), w kernel scale
  vec4 depthInfo;   // x blend band start (view depth, m), y metres per unit of stored depth
};

layout(std140, set = CSM_SET, binding = CSM_BINDING_UNIFORMS) uniform CsmUniformBlock {
  CsmCascade cascades[CSM_MAX_CASCADES];
  vec4 cameraForward;   // xyz camera forward, w shadow far (m)
  vec4 lightDirection;  // xyz direction the light travels
  vec4 params;          // x blend band, y normal offset (texels), z resolution, w 1 / resolution
  uvec4 counts;         // x cascade count, y non-empty mask, z debug mode, w wrapped (cache)
} csmU;

#ifndef CSM_UNIFORMS_ONLY

layout(set = CSM_SET, binding = CSM_BINDING_SHADOW_MAP) uniform sampler2DArrayShadow csmShadowMap;
layout(set = CSM_SET, binding = CSM_BINDING_SHADOW_DEPTH) uniform sampler2DArray csmDepthMap;

layout(constant_id = CSM_SPEC_KERNEL) const int csmKernel = CSM_KERNEL_TENT3;
layout(constant_id = CSM_SPEC_BLEND) const int csmBlend = 1;

/// Which cascade shades a receiver (mirror of csm::selectCascade): index -1 = lit.
struct CsmSelection {
  int index;
  int blendIndex;
  float blendWeight;
};

/// View depth of a camera-relative position (distance along the camera's forward axis).
float csmViewDepth(vec3 posCr) { return dot(posCr, csmU.cameraForward.xyz); }

/// The run-time debug mode (CSM_DEBUG_*).
uint csmDebugMode() { return csmU.counts.z; }

/// Cascade i covers [split_i, split_i+1); in the last blendBand of its range the next cascade is
/// blended in linearly if it exists and is not empty. Outside every non-empty cascade: -1.
CsmSelection csmSelectCascade(float viewDepth) {
  CsmSelection sel = CsmSelection(-1, -1, 0.0);
  const uint count = min(csmU.counts.x, uint(CSM_MAX_CASCADES));
  const uint nonEmpty = csmU.counts.y;
  for (uint i = 0u; i < count; ++i) {
    const vec4 st = csmU.cascades[i].splitTexel;
    if ((nonEmpty & (1u << i)) != 0u && viewDepth >= st.x && viewDepth < st.y) {
      sel.index = int(i);
      break;
    }
  }
  if (sel.index < 0) return sel;
  const uint next = uint(sel.index) + 1u;
  const float bandStart = csmU.cascades[sel.index].depthInfo.x;
  const float splitFar = csmU.cascades[sel.index].splitTexel.y;
  if (next < count && (nonEmpty & (1u << next)) != 0u && bandStart < splitFar &&
      viewDepth >= bandStart) {
    sel.blendIndex = int(next);
    sel.blendWeight = clamp((viewDepth - bandStart) / (splitFar - bandStart), 0.0, 1.0);
  }
  return sel;
}

/// How far (texels) the chosen kernel reads from its centre (mirror of csm::kernelRadiusTexels).
float csmKernelRadius() {
  if (csmKernel == CSM_KERNEL_TENT3) return CSM_KERNEL_RADIUS_TENT3;
  if (csmKernel == CSM_KERNEL_TENT5) return CSM_KERNEL_RADIUS_TENT5;
  if (csmKernel == CSM_KERNEL_TENT7) return CSM_KERNEL_RADIUS_TENT7;
  if (csmKernel == CSM_KERNEL_POISSON16) return CSM_KERNEL_RADIUS_POISSON16;
  return CSM_KERNEL_RADIUS_1TAP;
}

/// Cached cascades (CsmUniforms.counts.w != 0) address each layer toroidally: texel t of the
/// cascade's box lives at layer texel t + wrap offset (depthInfo.zw), modulo the resolution, and
/// the samplers REPEAT. Box texel coordinates -> layer uv; identity when not cached.
vec2 csmWrapUv(vec2 t, int cascade) {
  const vec2 offset = csmU.counts.w != 0u ? csmU.cascades[cascade].depthInfo.zw : vec2(0.0);
  return (t + offset) * csmU.params.w;
}

/// One bilinear comparison tap at shadow-map texel coordinates `t` (texel centres at i + 0.5).
/// Explicit zero gradients: valid in every stage, compute included. Texels outside the
/// cascade's box read lit (depth 1, the border of the unwrapped map): in a wrapped layer a tap
/// that straddles the box's edge is filtered by hand from a gather, its outside texels lit.
float csmTap(vec2 t, float layer, float depth) {
  if (csmU.counts.w != 0u) {
    const float res = csmU.params.z;
    const vec2 f = t - 0.5;
    const vec2 i0 = floor(f);
    if (any(lessThan(i0, vec2(0.0))) || any(greaterThan(i0 + 1.0, vec2(res - 1.0)))) {
      // textureGather order: (i0, j1), (i1, j1), (i1, j0), (i0, j0).
      const vec4 g = textureGather(csmShadowMap, vec3(csmWrapUv(i0 + 1.0, int(layer)), layer),
                                   depth);
      const bvec2 in0 = bvec2(i0.x >= 0.0 && i0.x <= res - 1.0, i0.y >= 0.0 && i0.y <= res - 1.0);
      const bvec2 in1 = bvec2(i0.x + 1.0 >= 0.0 && i0.x + 1.0 <= res - 1.0,
                              i0.y + 1.0 >= 0.0 && i0.y + 1.0 <= res - 1.0);
      const float t00 = in0.x && in0.y ? g.w : 1.0;
      const float t10 = in1.x && in0.y ? g.z : 1.0;
      const float t01 = in0.x && in1.y ? g.x : 1.0;
      const float t11 = in1.x && in1.y ? g.y : 1.0;
      const vec2 w = f - i0;
      return mix(mix(t00, t10, w.x), mix(t01, t11, w.x), w.y);
    }
    return textureGrad(csmShadowMap, vec4(csmWrapUv(t, int(layer)), layer, depth), vec2(0.0),
                       vec2(0.0));
  }
  return textureGrad(csmShadowMap, vec4(t * csmU.params.w, layer, depth), vec2(0.0), vec2(0.0));
}

// Tent kernels from bilinear comparison taps (weights and positions: "Optimized PCF",
// M. Pettineo's Shadows sample, after The Witness): an NxN tent costs ((N+1)/2)^2 taps.
// `scale` spaces the taps about `t` (kernels of constant world size); 1 = exact tent.
float csmTentTap(vec2 t, vec2 base, vec2 o, float scale, float layer, float depth) {
  return csmTap(t + (base + o - t) * scale, layer, depth);
}

float csmPcfTent(vec2 t, float scale, float layer, float depth) {
  const vec2 base = floor(t + 0.5);
  const vec2 st = t + 0.5 - base;
  const float s = st.x;
  const float r = st.y;
  float sum = 0.0;
  if (csmKernel == CSM_KERNEL_TENT3) {
    const vec2 w0 = vec2(3.0 - 2.0 * s, 3.0 - 2.0 * r);
    const vec2 w1 = vec2(1.0 + 2.0 * s, 1.0 + 2.0 * r);
    const vec2 p0 = vec2((2.0 - s) / w0.x, (2.0 - r) / w0.y) - 1.0;
    const vec2 p1 = vec2(s / w1.x, r / w1.y) + 1.0;
    sum += w0.x * w0.y * csmTentTap(t, base, vec2(p0.x, p0.y), scale, layer, depth);
    sum += w1.x * w0.y * csmTentTap(t, base, vec2(p1.x, p0.y), scale, layer, depth);
    sum += w0.x * w1.y * csmTentTap(t, base, vec2(p0.x, p1.y), scale, layer, depth);
    sum += w1.x * w1.y * csmTentTap(t, base, vec2(p1.x, p1.y), scale, layer, depth);
    return sum / 16.0;
  }
  if (csmKernel == CSM_KERNEL_TENT5) {
    const vec3 wu = vec3(4.0 - 3.0 * s, 7.0, 1.0 + 3.0 * s);
    const vec3 wv = vec3(4.0 - 3.0 * r, 7.0, 1.0 + 3.0 * r);
    const vec3 pu = vec3((3.0 - 2.0 * s) / wu.x - 2.0, (3.0 + s) / wu.y, s / wu.z + 2.0);
    const vec3 pv = vec3((3.0 - 2.0 * r) / wv.x - 2.0, (3.0 + r) / wv.y, r / wv.z + 2.0);
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 3; ++i) {
        sum += wu[i] * wv[j] * csmTentTap(t, base, vec2(pu[i], pv[j]), scale, layer, depth);
      }
    }
    return sum / 144.0;
  }
  // CSM_KERNEL_TENT7
  const vec4 wu = vec4(5.0 * s - 6.0, 11.0 * s - 28.0, -(11.0 * s + 17.0), -(5.0 * s + 1.0));
  const vec4 wv = vec4(5.0 * r - 6.0, 11.0 * r - 28.0, -(11.0 * r + 17.0), -(5.0 * r + 1.0));
  const vec4 pu = vec4((4.0 * s - 5.0) / wu.x - 3.0, (4.0 * s - 16.0) / wu.y - 1.0,
                       -(7.0 * s + 5.0) / wu.z + 1.0, -s / wu.w + 3.0);
  const vec4 pv = vec4((4.0 * r - 5.0) / wv.x - 3.0, (4.0 * r - 16.0) / wv.y - 1.0,
                       -(7.0 * r + 5.0) / wv.z + 1.0, -r / wv.w + 3.0);
  for (int j = 0; j < 4; ++j) {
    for (int i = 0; i < 4; ++i) {
      sum += wu[i] * wv[j] * csmTentTap(t, base, vec2(pu[i], pv[j]), scale, layer, depth);
    }
  }
  return sum / 2704.0;
}

// 16-point Poisson disk in the unit circle.
const vec2 kCsmPoisson[16] = vec2[16](
    vec2(-0.94201624, -0.39906216), vec2(0.94558609, -0.76890725), vec2(-0.09418410, -0.92938870),
    vec2(0.34495938, 0.29387760), vec2(-0.91588581, 0.45771432), vec2(-0.81544232, -0.87912464),
    vec2(-0.38277543, 0.27676845), vec2(0.97484398, 0.75648379), vec2(0.44323325, -0.97511554),
    vec2(0.53742981, -0.47373420), vec2(-0.26496911, -0.41893023), vec2(0.79197514, 0.19090188),
    vec2(-0.24188840, 0.99706507), vec2(-0.81409955, 0.91437590), vec2(0.19984126, 0.78641367),
    vec2(0.14383161, -0.14100790));

/// Per-pixel rotation angle in [0, 2 pi): interleaved gradient noise (Jimenez 2014).
float csmNoiseAngle(vec2 pixel) {
  return 6.28318531 * fract(52.9829189 * fract(dot(floor(pixel), vec2(0.06711056, 0.00583715))));
}

float csmPcfPoisson(vec2 t, float scale, float layer, float depth, vec2 pixel) {
  const float a = csmNoiseAngle(pixel);
  const float radius = 2.0 * scale;  // disk radius in texels; the bilinear tap adds ~0.5
  const mat2 rot = mat2(cos(a), sin(a), -sin(a), cos(a)) * radius;
  float sum = 0.0;
  for (int i = 0; i < 16; ++i) sum += csmTap(t + rot * kCsmPoisson[i], layer, depth);
  return sum / 16.0;
}

/// Shadow-map coordinates of a receiver in cascade i, normal offset applied: xy in texels, z the
/// depth to compare. The offset grows with the cascade's texel size, the kernel's radius and the
/// sine of the angle between normal and light (zero when the light hits head-on).
vec3 csmShadowCoord(int i, vec3 posCr, vec3 normalWs) {
  const vec4 st = csmU.cascades[i].splitTexel;
  const float cosTheta = clamp(dot(normalWs, -csmU.lightDirection.xyz), -1.0, 1.0);
  const float sinTheta = sqrt(max(1.0 - cosTheta * cosTheta, 0.0));
  const float radiusTexels = max(csmKernelRadius() * st.w, 1.0);
  const float offsetM = csmU.params.y * st.z * radiusTexels * sinTheta;
  const vec4 clip = csmU.cascades[i].viewProjCr * vec4(posCr + normalWs * offsetM, 1.0);
  return vec3((clip.xy * 0.5 + 0.5) * csmU.params.z, clip.z);
}

/// Filtered shadow factor of cascade i at a receiver: 1 lit, 0 in shadow.
float csmSampleCascade(int i, vec3 posCr, vec3 normalWs, vec2 pixel) {
  const vec3 c = csmShadowCoord(i, posCr, normalWs);
  const float layer = float(i);
  const float scale = csmU.cascades[i].splitTexel.w;
  if (csmKernel == CSM_KERNEL_1TAP) return csmTap(c.xy, layer, c.z);
  if (csmKernel == CSM_KERNEL_POISSON16) return csmPcfPoisson(c.xy, scale, layer, c.z, pixel);
  return csmPcfTent(c.xy, scale, layer, c.z);
}

/// The shadow factor of a receiver: 1 lit, 0 in shadow; outside every cascade 1. `pixel` seeds
/// the Poisson rotation (gl_FragCoord.xy in a fragment shader, the invocation's 2D id elsewhere).
float csmShadow(vec3 posCr, vec3 normalWs, vec2 pixel) {
  const CsmSelection sel = csmSelectCascade(csmViewDepth(posCr));
  if (sel.index < 0) return 1.0;
  float s = csmSampleCascade(sel.index, posCr, normalWs, pixel);
  if (csmBlend != 0 && sel.blendIndex >= 0 && sel.blendWeight > 0.0) {
    s = mix(s, csmSampleCascade(sel.blendIndex, posCr, normalWs, pixel), sel.blendWeight);
  }
  return s;
}

/// The tint of cascade i (CSM_TINT_i), black for -1.
vec3 csmCascadeTint(int i) {
  const vec3 tints[CSM_TINT_COUNT] = vec3[CSM_TINT_COUNT](vec3(CSM_TINT_0), vec3(CSM_TINT_1), vec3(CSM_TINT_2),
                                vec3(CSM_TINT_3), vec3(CSM_TINT_4), vec3(CSM_TINT_5),
                                vec3(CSM_TINT_6), vec3(CSM_TINT_7));
  return i < 0 ? vec3(0.0) : tints[i % 8];
}

/// The colour of the run-time debug output (csmDebugMode() != CSM_DEBUG_NONE) for a receiver
/// whose shadow factor is `shadow`; `shaded` is returned for CSM_DEBUG_NONE.
vec3 csmDebugColor(vec3 posCr, vec3 normalWs, vec2 pixel, float shadow, vec3 shaded) {
  const uint mode = csmDebugMode();
  if (mode == CSM_DEBUG_NORMAL) return normalWs * 0.5 + 0.5;
  if (mode == CSM_DEBUG_SHADOW) return vec3(shadow);
  const CsmSelection sel = csmSelectCascade(csmViewDepth(posCr));
  if (mode == CSM_DEBUG_CASCADE) return csmCascadeTint(sel.index);
  if (mode == CSM_DEBUG_LIGHT_COORDS || mode == CSM_DEBUG_SAMPLED_DEPTH ||
      mode == CSM_DEBUG_DEPTH_DIFF) {
    if (sel.index < 0) return vec3(0.0);
    const vec3 c = csmShadowCoord(sel.index, posCr, normalWs);
    const vec2 uv = c.xy * csmU.params.w;
    if (mode == CSM_DEBUG_LIGHT_COORDS) return vec3(uv, c.z);
    const float stored =
        textureLod(csmDepthMap, vec3(csmWrapUv(c.xy, sel.index), float(sel.index)), 0.0).r;
    if (mode == CSM_DEBUG_SAMPLED_DEPTH) return vec3(stored);
    // Depth difference in texels of this cascade: red behind the stored depth, green in front.
    const vec4 st = csmU.cascades[sel.index].splitTexel;
    const float diffTexels =
        (c.z - stored) * csmU.cascades[sel.index].depthInfo.y / max(st.z, 1e-6);
    const float v = clamp(0.25 + abs(diffTexels) / 8.0, 0.0, 1.0);
    return diffTexels > 0.0 ? vec3(v, 0.0, 0.0) : vec3(0.0, v, 0.0);
  }
  return shaded;
}

#endif  // !CSM_UNIFORMS_ONLY
#endif  // CSM_GLSL
