// csm.glsl: cascaded shadow maps for any lighting shader (fragment or compute).
//
//   #extension GL_GOOGLE_include_directive : require
//   #define CSM_SET 1            // the descriptor set the host binds the module's resources to
//   #include "csm.glsl"
//   ...
//   float s = csmShadow(posCr, normalWs);   // 1 lit, 0 in shadow
//
// Inputs are camera-relative world positions (posWs - cameraPositionWs, as float) and world
// normals (unit length) of the surface the shadow map holds: in a fragment shader pass the
// facet normal, csmGeometricNormal(dFdx(posCr), dFdy(posCr), n), and keep the smooth
// normal n for lighting (it only differs on coarse curved meshes, where it matters). Resources (set CSM_SET): the CsmUniforms block at CSM_BINDING_UNIFORMS
// (C++: csm/gpu_layout.hpp), the shadow map through a comparison sampler at
// CSM_BINDING_SHADOW_MAP and through a plain nearest sampler at CSM_BINDING_SHADOW_DEPTH (debug
// outputs and PCSS, whose taps compare texel by texel). Variants are specialization constants:
// CSM_SPEC_KERNEL (PCF kernel), CSM_SPEC_BLEND (0: hard switch at the split, 1: blend across the
// band) and CSM_SPEC_PCSS_TAPS (taps of the PCSS blocker search and filter).
// Define CSM_UNIFORMS_ONLY to declare only the uniform block (the depth pass does), and in a
// fragment shader CSM_IMPLICIT_LOD, so that the prefiltered filters read the mip level the pixel's
// footprint covers (dFdx/dFdy of posCr; without it they read level 0, as a compute shader does).
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
  mat4 viewProjCr;        // camera-relative world -> shadow clip (xy in [-1, 1], z depth in [0, 1])
  float splitNearM;       // split range (view depth, m)
  float splitFarM;
  float texelSizeM;       // side of one texel (m)
  float kernelScale;      // PCF tap spacing (texels)
  float blendStartM;      // view depth where the blend band toward the next cascade starts (m)
  float depthRangeM;      // metres of light-space depth per unit of stored depth
  vec2 worldTexelOrigin;  // world-grid index of texel (0, 0) mod CSM_WORLD_TEXEL_PERIOD
  vec2 wrapOffset;        // cached cascades: wrap offset (texels) of the box's texel (0, 0)
  vec2 cascadeReserved;   // unused (std140 padding)
};

layout(std140, set = CSM_SET, binding = CSM_BINDING_UNIFORMS) uniform CsmUniformBlock {
  CsmCascade cascades[CSM_MAX_CASCADES];
  vec3 cameraForwardWs;      // camera forward (world axes)
  float shadowFarM;          // how far shadows reach along the view (m)
  vec4 lightDirection;       // xyz direction the light travels
  float blendBand;           // fraction of a cascade's depth range
  float normalOffsetTexels;  // receiver's normal offset (texels)
  float resolution;          // shadow-map side (texels)
  float invResolution;       // 1 / resolution
  uint cascadeCount;
  uint nonEmptyMask;         // bit i: cascade i is not empty
  uint debugMode;            // CSM_DEBUG_*
  uint wrappedLayers;        // 1: layers addressed toroidally (cached cascades, wrapOffset)
  float depthFloorTexels;    // depth floor (texels of the receiver's cascade)
  float depthFloorQuantum;   // depth floor (units of stored depth: the format's quantum)
  float momentAnisotropy;    // the moment sampler's largest anisotropy (1: trilinear)
  uint momentQuantized;      // 1: MSM's moments are stored quantised (csmMsmDequantize)
  float tanHalfLightAngle;   // PCSS: tan(light angular diameter / 2)
  float maxPenumbraRadiusM;  // PCSS: largest penumbra radius (m)
  float fadeEndM;            // the fade to lit ends here (view depth, m)
  float invFadeLengthM;      // 1 / the fade's length (m); 0: no fade
  vec4 moments;              // prefiltered: bleeding reduction, MSM bias, EVSM c+, EVSM c-
  uint tilePartialMask;      // receiver-marked tiles: bit i, cascade i holds only tileBits' tiles
  float tileInvTexels;       // 1 / a tile's side (texels)
  uint tileReserved0;
  uint tileReserved1;
  vec4 tileGrid[CSM_MAX_CASCADES];       // grid offset (texels) x, y; filter reach (texels) z
  uvec4 tileBits[CSM_MAX_CASCADES * 3];  // tiles held, bit y * CSM_TILE_GRID_SIDE + x
} csmU;

/// Mirror of csm::msmQuantize: MSM's centred moments into the 64-bit image's [0, 1]^4.
vec4 csmMsmQuantize(vec4 centred) {
  return clamp(mat4(CSM_MSM_QUANTIZE_MATRIX) * centred + vec4(CSM_MSM_QUANTIZE_OFFSET), 0.0, 1.0);
}

/// Mirror of csm::msmDequantize: the centred moments from filtered quantised ones.
vec4 csmMsmDequantize(vec4 quantized) {
  return mat4(CSM_MSM_DEQUANTIZE_MATRIX) * (quantized - vec4(CSM_MSM_QUANTIZE_OFFSET));
}

#ifndef CSM_UNIFORMS_ONLY

layout(set = CSM_SET, binding = CSM_BINDING_SHADOW_MAP) uniform sampler2DArrayShadow csmShadowMap;
layout(set = CSM_SET, binding = CSM_BINDING_SHADOW_DEPTH) uniform sampler2DArray csmDepthMap;
// The prefiltered filters' blurred, mip-mapped moments (trilinear); with a percentage-closer
// kernel the renderer binds the depth map here (never read).
layout(set = CSM_SET, binding = CSM_BINDING_MOMENTS) uniform sampler2DArray csmMomentMap;

layout(constant_id = CSM_SPEC_KERNEL) const int csmKernel = CSM_KERNEL_TENT3;
layout(constant_id = CSM_SPEC_BLEND) const int csmBlend = 1;
layout(constant_id = CSM_SPEC_PCSS_TAPS) const int csmPcssTaps = CSM_PCSS_DEFAULT_TAPS;

/// Which cascade shades a receiver (mirror of csm::selectCascade): index -1 = lit.
struct CsmSelection {
  int index;
  int blendIndex;
  float blendWeight;
};

/// View depth of a camera-relative position (distance along the camera's forward axis).
float csmViewDepth(vec3 posCr) { return dot(posCr, csmU.cameraForwardWs); }

/// How far a receiver at `viewDepth` has faded to lit at the end of the shadows, in [0, 1]
/// (mirror of csm::shadowFade): smoothstep over the fade's length up to fadeEndM; 0 with no fade.
float csmFade(float viewDepth) {
  if (!(csmU.invFadeLengthM > 0.0)) return 0.0;
  const float t = clamp(1.0 - (csmU.fadeEndM - viewDepth) * csmU.invFadeLengthM, 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

/// The run-time debug mode (CSM_DEBUG_*).
uint csmDebugMode() { return csmU.debugMode; }

/// Cascade i covers [split_i, split_i+1); in the last blendBand of its range the next cascade is
/// blended in linearly if it exists and is not empty. Outside every non-empty cascade: -1.
CsmSelection csmSelectCascade(float viewDepth) {
  CsmSelection sel = CsmSelection(-1, -1, 0.0);
  const uint count = min(csmU.cascadeCount, uint(CSM_MAX_CASCADES));
  const uint nonEmpty = csmU.nonEmptyMask;
  for (uint i = 0u; i < count; ++i) {
    if ((nonEmpty & (1u << i)) != 0u && viewDepth >= csmU.cascades[i].splitNearM &&
        viewDepth < csmU.cascades[i].splitFarM) {
      sel.index = int(i);
      break;
    }
  }
  if (sel.index < 0) return sel;
  const uint next = uint(sel.index) + 1u;
  const float bandStart = csmU.cascades[sel.index].blendStartM;
  const float splitFar = csmU.cascades[sel.index].splitFarM;
  if (next < count && (nonEmpty & (1u << next)) != 0u && bandStart < splitFar &&
      viewDepth >= bandStart) {
    sel.blendIndex = int(next);
    sel.blendWeight = clamp((viewDepth - bandStart) / (splitFar - bandStart), 0.0, 1.0);
  }
  return sel;
}

/// How far (texels) the chosen kernel reads from its centre, one texel beyond its bilinear taps'
/// centres (mirror of csm::kernelRadiusTexels; see CSM_KERNEL_RADIUS_*).
float csmKernelRadius() {
  if (csmKernel == CSM_KERNEL_TENT3) return CSM_KERNEL_RADIUS_TENT3;
  if (csmKernel == CSM_KERNEL_TENT5) return CSM_KERNEL_RADIUS_TENT5;
  if (csmKernel == CSM_KERNEL_TENT7) return CSM_KERNEL_RADIUS_TENT7;
  if (csmKernel == CSM_KERNEL_POISSON16) return CSM_KERNEL_RADIUS_POISSON16;
  if (csmKernel == CSM_KERNEL_PCSS) return CSM_KERNEL_RADIUS_PCSS;
  if (csmKernel >= CSM_KERNEL_VSM) return CSM_KERNEL_RADIUS_MOMENTS;
  return CSM_KERNEL_RADIUS_1TAP;
}

/// Cached cascades (CsmUniforms.wrappedLayers != 0) address each layer toroidally: texel t of the
/// cascade's box lives at layer texel t + wrap offset (wrapOffset), modulo the resolution, and
/// the samplers REPEAT. Box texel coordinates -> layer uv; identity when not cached.
vec2 csmWrapUv(vec2 t, int cascade) {
  const vec2 offset = csmU.wrappedLayers != 0u ? csmU.cascades[cascade].wrapOffset : vec2(0.0);
  return (t + offset) * csmU.invResolution;
}

/// One bilinear comparison tap at shadow-map texel coordinates `t` (texel centres at i + 0.5),
/// filtered by hand from a comparison gather: the weights are the float fraction of `t`, not the
/// sampler's fixed-point sub-texel weights (8 bits on the GPUs we measured: a receiver whose
/// coordinate differs by float rounding from one frame to the next could cross a 1/256 step and
/// change its factor by up to 1/256 of a tap, visible through the wider kernels' sums). The
/// gather reads level 0 without derivatives, so this is valid in every stage. Texels outside the
/// cascade's box read lit (depth 1, the border of the unwrapped map; in a wrapped layer, the
/// toroidal neighbours are masked to lit).
float csmTap(vec2 t, float layer, float depth) {
  const vec2 f = t - 0.5;
  const vec2 i0 = floor(f);
  const vec2 w = f - i0;
  // At the corner shared by the four texels: the gather's footprint is unambiguous.
  // textureGather order: (i0, j1), (i1, j1), (i1, j0), (i0, j0).
  const vec4 g =
      textureGather(csmShadowMap, vec3(csmWrapUv(i0 + 1.0, int(layer)), layer), depth);
  vec4 v = g;
  if (csmU.wrappedLayers != 0u) {
    const float res = csmU.resolution;
    if (any(lessThan(i0, vec2(0.0))) || any(greaterThan(i0 + 1.0, vec2(res - 1.0)))) {
      const bvec2 in0 = bvec2(i0.x >= 0.0 && i0.x <= res - 1.0, i0.y >= 0.0 && i0.y <= res - 1.0);
      const bvec2 in1 = bvec2(i0.x + 1.0 >= 0.0 && i0.x + 1.0 <= res - 1.0,
                              i0.y + 1.0 >= 0.0 && i0.y + 1.0 <= res - 1.0);
      v = vec4(in0.x && in1.y ? g.x : 1.0, in1.x && in1.y ? g.y : 1.0,
               in1.x && in0.y ? g.z : 1.0, in0.x && in0.y ? g.w : 1.0);
    }
  }
  return mix(mix(v.w, v.z, w.x), mix(v.x, v.y, w.x), w.y);
}

/// The receiver's plane in the map of cascade i: change of stored depth per texel of offset along
/// the map's x and y (from the normal, so it also works in compute shaders). Every filter compares
/// each tap with this plane at the tap (receiver-plane depth bias): a wide kernel on a slope does
/// not read its own receiver's texels as blockers, at every orientation against the texel grid,
/// without moving the receiver sideways by the kernel's width.
vec2 csmReceiverDepthSlope(int i, vec3 normalWs) {
  const mat4 m = csmU.cascades[i].viewProjCr;
  const vec3 rightWs = normalize(vec3(m[0][0], m[1][0], m[2][0]));
  const vec3 upWs = normalize(vec3(m[0][1], m[1][1], m[2][1]));
  // Light-space normal; lit surfaces face against the light (z < 0). Slopes beyond 1:100 from
  // the light direction (a sun under 0.6 degrees over a plane) are clamped: every receiver a
  // sun of 1 degree or more lights keeps its exact plane (a clamp at 1:8 shadowed planes under
  // a 2-degree sun by up to 0.5).
  const vec3 nLs = vec3(dot(normalWs, rightWs), dot(normalWs, upWs),
                        dot(normalWs, csmU.lightDirection.xyz));
  const float nz = min(nLs.z, -0.01);
  const float texelM = csmU.cascades[i].texelSizeM;
  const float metresPerDepth = max(csmU.cascades[i].depthRangeM, 1e-6);
  return -(nLs.xy / nz) * (texelM / metresPerDepth);
}

// Tent kernels from bilinear comparison taps (weights and positions: "Optimized PCF",
// M. Pettineo's Shadows sample, after The Witness): an NxN tent costs ((N+1)/2)^2 taps.
// `base` is the texel corner nearest t (texel centres at i + 0.5); the tap offsets o are relative
// to the centre of the texel below and left of it, base - 0.5, so that the tent is centred on t.
// `scale` spaces the taps about `t` (kernels of constant world size); 1 = exact tent. Each tap
// compares with the receiver's plane at the tap (`slope`: csmReceiverDepthSlope).
float csmTentTap(vec2 t, vec2 base, vec2 o, float scale, float layer, float depth, vec2 slope) {
  const vec2 q = t + (base - 0.5 + o - t) * scale;
  return csmTap(q, layer, depth + dot(slope, q - t));
}

float csmPcfTent(vec2 t, float scale, float layer, float depth, vec2 slope) {
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
    sum += w0.x * w0.y * csmTentTap(t, base, vec2(p0.x, p0.y), scale, layer, depth, slope);
    sum += w1.x * w0.y * csmTentTap(t, base, vec2(p1.x, p0.y), scale, layer, depth, slope);
    sum += w0.x * w1.y * csmTentTap(t, base, vec2(p0.x, p1.y), scale, layer, depth, slope);
    sum += w1.x * w1.y * csmTentTap(t, base, vec2(p1.x, p1.y), scale, layer, depth, slope);
    return sum / 16.0;
  }
  if (csmKernel == CSM_KERNEL_TENT5) {
    const vec3 wu = vec3(4.0 - 3.0 * s, 7.0, 1.0 + 3.0 * s);
    const vec3 wv = vec3(4.0 - 3.0 * r, 7.0, 1.0 + 3.0 * r);
    const vec3 pu = vec3((3.0 - 2.0 * s) / wu.x - 2.0, (3.0 + s) / wu.y, s / wu.z + 2.0);
    const vec3 pv = vec3((3.0 - 2.0 * r) / wv.x - 2.0, (3.0 + r) / wv.y, r / wv.z + 2.0);
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 3; ++i) {
        sum += wu[i] * wv[j] * csmTentTap(t, base, vec2(pu[i], pv[j]), scale, layer, depth, slope);
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
      sum += wu[i] * wv[j] * csmTentTap(t, base, vec2(pu[i], pv[j]), scale, layer, depth, slope);
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

/// Rotation of a tap pattern (the Poisson disk, PCSS) at map texel t of cascade i: a hash of the
/// WORLD texel (the map's texel index plus the world-grid index of its texel 0), so the pattern
/// stays on the ground when the camera moves and the stabilised map slides by whole texels.
float csmWorldTexelAngle(int i, vec2 t) {
  const vec2 g = mod(floor(t) + csmU.cascades[i].worldTexelOrigin, CSM_WORLD_TEXEL_PERIOD);
  uint h = uint(g.x) * 0x8da6b343u ^ uint(g.y) * 0xd8163841u ^ uint(i) * 0xcb1ab31fu;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return float(h) * (6.28318531 / 4294967296.0);
}

/// The Poisson disk, rotated by the receiver's world texel (csmWorldTexelAngle): its noise stays
/// on the ground as the camera moves (a rotation keyed to the screen pixel would stay on the
/// screen while the world slid under it: a crawl).
float csmPcfPoisson(int i, vec2 t, float scale, float depth, vec2 slope) {
  const float layer = float(i);
  const float a = csmWorldTexelAngle(i, t);
  const float radius = 2.0 * scale;  // disk radius in texels; the bilinear tap adds one
  const mat2 rot = mat2(cos(a), sin(a), -sin(a), cos(a)) * radius;
  float sum = 0.0;
  for (int k = 0; k < 16; ++k) {
    const vec2 o = rot * kCsmPoisson[k];
    sum += csmTap(t + o, layer, depth + dot(slope, o));
  }
  return sum / 16.0;
}

// ---- PCSS: percentage-closer soft shadows ---------------------------------------------------
// The sun is a disk of angular radius a. Seen from a receiver, a blocker d metres nearer the light
// hides the part of the disk that its outline covers inside a circle of radius d tan(a) about the
// receiver's own texel (similar triangles, measured in light space, i.e. on the shadow map's
// plane). So: (1) search the raw depths around the receiver for blockers and average their
// distance d, (2) filter with bilinear taps spread uniformly over a disk of radius d tan(a).
// Radii are in metres and converted with each cascade's texel size, so the penumbra is the same
// in every cascade and across a blend band. Every texel a tap reads is compared with the
// receiver's plane at that texel's centre (the plane from the normal, so it also works in compute
// shaders), not with one depth per tap: wide kernels on slopes do not shadow themselves, and no
// normal offset moves the receiver (and so the shadow edge) sideways.

/// Point k of n on a unit disk, spread uniformly (Vogel's golden-angle spiral), rotated by `a`.
vec2 csmVogel(int k, int n, float a) {
  const float r = sqrt((float(k) + 0.5) / float(n));
  const float phi = float(k) * 2.39996323 + a;
  return r * vec2(cos(phi), sin(phi));
}

/// Raw depths of the 2x2 texels (base, base + 1) of cascade i, in textureGather order: (i0, j1),
/// (i1, j1), (i1, j0), (i0, j0). A wrapped layer repeats: texels outside the cascade's box read
/// the far plane (no blocker, lit), as the border of an unwrapped map does.
vec4 csmPcssGather(int i, vec2 base) {
  const vec4 d = textureGather(csmDepthMap, vec3(csmWrapUv(base + 1.0, i), float(i)));
  if (csmU.wrappedLayers == 0u) return d;
  const float res = csmU.resolution;
  const bvec2 in0 =
      bvec2(base.x >= 0.0 && base.x <= res - 1.0, base.y >= 0.0 && base.y <= res - 1.0);
  const bvec2 in1 = bvec2(base.x + 1.0 >= 0.0 && base.x + 1.0 <= res - 1.0,
                          base.y + 1.0 >= 0.0 && base.y + 1.0 <= res - 1.0);
  return vec4(in0.x && in1.y ? d.x : 1.0, in1.x && in1.y ? d.y : 1.0,
              in1.x && in0.y ? d.z : 1.0, in0.x && in0.y ? d.w : 1.0);
}

/// The receiver's plane at the centres of the 2x2 texels (base, base + 1), gather order: the
/// depth to compare each texel with (c: the receiver's map coordinates, slope: csmPcssDepthSlope).
vec4 csmPcssPlaneDepth(vec3 c, vec2 slope, vec2 base) {
  const vec2 o = base + 0.5 - c.xy;
  return c.z + vec4(dot(slope, o + vec2(0.0, 1.0)), dot(slope, o + vec2(1.0, 1.0)),
                    dot(slope, o + vec2(1.0, 0.0)), dot(slope, o));
}

/// A bilinear comparison tap at map point p of cascade i whose four texels are each compared with
/// the receiver's plane at their OWN centre (a comparison sampler compares all four with one
/// depth). A sloped receiver then never shadows itself within the tap's footprint, so PCSS needs
/// no normal offset, which would move every shadow edge toward its caster.
float csmPcssTap(int i, vec3 c, vec2 slope, vec2 p) {
  const vec2 f = p - 0.5;
  const vec2 base = floor(f);
  const vec4 lit =
      vec4(lessThanEqual(csmPcssPlaneDepth(c, slope, base), csmPcssGather(i, base)));
  const vec2 w = f - base;
  return mix(mix(lit.w, lit.z, w.x), mix(lit.x, lit.y, w.x), w.y);
}

/// Average distance (m) between the receiver's plane and the blockers found within `radius`
/// texels of t (raw depths, 2x2 texels per gather) whose penumbra reaches t; negative when there
/// is none.
float csmPcssBlockerDistance(int i, vec3 c, vec2 slope, float radius, float angle) {
  const float metresPerDepth = csmU.cascades[i].depthRangeM;
  // Texels of penumbra radius per metre between blocker and receiver.
  const float reachPerMetre = csmU.tanHalfLightAngle / max(csmU.cascades[i].texelSizeM, 1e-9);
  // A blocker must lie a texel's width (in metres) above the plane: the raster bias keeps the
  // receiver's own surface behind it, this keeps curved receivers from finding themselves.
  const float minGap = csmU.cascades[i].texelSizeM / max(metresPerDepth, 1e-6);
  float count = 0.0;
  float sum = 0.0;
  for (int k = 0; k < csmPcssTaps; ++k) {
    const vec2 p = c.xy + csmVogel(k, csmPcssTaps, angle) * radius;
    const vec2 base = floor(p - 0.5);  // texel (i0, j0) of the 2x2 footprint about p
    const vec2 o = base + 0.5 - c.xy;   // texel centres at index + 0.5
    const vec4 gap = csmPcssPlaneDepth(c, slope, base) - csmPcssGather(i, base);
    // Only blockers whose penumbra cone reaches the receiver count: lateral distance (texels)
    // within gap * tan(a), plus a texel of slack. A tall wall a few texels away does not widen
    // the penumbra at its own foot.
    const vec4 reach = gap * (metresPerDepth * reachPerMetre) + 1.0;
    const vec4 dist2 = vec4(dot(o + vec2(0.0, 1.0), o + vec2(0.0, 1.0)),
                            dot(o + vec2(1.0, 1.0), o + vec2(1.0, 1.0)),
                            dot(o + vec2(1.0, 0.0), o + vec2(1.0, 0.0)), dot(o, o));
    const vec4 isBlocker =
        vec4(greaterThan(gap, vec4(minGap))) * vec4(lessThanEqual(dist2, reach * reach));
    count += dot(isBlocker, vec4(1.0));
    sum += dot(isBlocker, gap);
  }
  return count > 0.0 ? sum / count * metresPerDepth : -1.0;
}

/// Map coordinates of a receiver for PCSS: xy where the receiver itself projects, z its depth
/// less the bias. Every comparison is against the receiver's plane texel by texel (csmPcssTap),
/// so a plane needs no offset to clear its own texels; what remains is a second surface rising
/// from the plane (the foot of a lit wall), whose first texels lie above the plane's
/// extrapolation. So the plane is lifted along the normal by normalOffsetTexels x texel x sin(theta), as
/// the normal offset lifts it for the single tap (the same leak bound at contacts), but only in
/// depth (normalOffsetTexels texels of the plane's slope): the receiver is not moved sideways, and the
/// shadow edge stays where the caster puts it (a normal offset moves every edge toward its
/// caster, by normalOffsetTexels x texel x sin^2(theta)). Plus the depth floor, as csmShadowCoord.
vec3 csmPcssCoord(int i, vec3 posCr, vec2 slope) {
  const vec4 clip = csmU.cascades[i].viewProjCr * vec4(posCr, 1.0);
  const float metresPerDepth = max(csmU.cascades[i].depthRangeM, 1e-30);
  const float floorDepth =
      csmU.depthFloorTexels * csmU.cascades[i].texelSizeM / metresPerDepth + csmU.depthFloorQuantum;
  const float lift = csmU.normalOffsetTexels * length(slope);
  return vec3((clip.xy * 0.5 + 0.5) * csmU.resolution, clip.z - floorDepth - lift);
}

/// PCSS shadow factor of cascade i at a receiver.
float csmPcss(int i, vec3 posCr, vec3 normalWs) {
  const vec2 slope = csmReceiverDepthSlope(i, normalWs);
  const vec3 c = csmPcssCoord(i, posCr, slope);
  const float texelM = max(csmU.cascades[i].texelSizeM, 1e-9);
  const float tanHalf = csmU.tanHalfLightAngle;
  const float maxRadiusM = csmU.maxPenumbraRadiusM;
  const float angle = csmWorldTexelAngle(i, c.xy);
  // Search as far as the widest penumbra: the setting, in metres. (Not the distance to the near
  // side of the cascade's depth range: that moves in steps as the camera turns, and the search
  // with it, which shimmers.)
  const float searchTexels = max(maxRadiusM / texelM, 1.0);
  const float blockerM = csmPcssBlockerDistance(i, c, slope, searchTexels, angle);
  // No blocker above the plane: what the bilinear comparison at the centre says (near contact a
  // blocker may sit within the plane's tolerance).
  if (blockerM < 0.0) return csmPcssTap(i, c, slope, c.xy);
  const float radiusM = min(blockerM * tanHalf, maxRadiusM);
  // Each bilinear tap blurs by a tent of +-1 texel (variance 1/6 texel^2 per axis); a uniform
  // disk of radius r has r^2 / 4. Shrink the disk so that the two together spread as far as the
  // true penumbra. A penumbra narrower than the bilinear tap's own is the single tap.
  const float radiusTexels = radiusM / texelM;
  const float radius = sqrt(max(radiusTexels * radiusTexels - 0.6667, 0.0));
  if (radius < 0.05) return csmPcssTap(i, c, slope, c.xy);
  float sum = 0.0;
  for (int k = 0; k < csmPcssTaps; ++k) {
    sum += csmPcssTap(i, c, slope, c.xy + csmVogel(k, csmPcssTaps, angle) * radius);
  }
  return sum / float(csmPcssTaps);
}

/// Shadow-map coordinates of a receiver in cascade i, bias applied: xy in texels, z the depth to
/// compare. The bias needs no tuning per scene, light angle, resolution, depth format or kernel:
///  - receiver plane: every tap of a filter compares with the receiver's plane extended to the tap
///    (csmReceiverDepthSlope), so a wide kernel does not find its own receiver in its footprint;
///  - normal offset: what remains is the bilinear tap itself, which compares its 2x2 texels (up to
///    one texel from the tap along each of the map's axes) with one depth. The receiver moves along
///    its normal by normalOffsetTexels x texel x (|n_x| + |n_y|) (n_x, n_y: the normal's parts
///    along the map's texel axes), which puts it texel x (|n_x| + |n_y|) / |n_z| in front of its
///    own plane along the light: exactly how much the plane's stored depth varies over a texel in
///    x and one in y, whatever the plane's orientation against the texel grid (on the grid's
///    diagonal sqrt(2) times more than along an axis); it moves sideways by at most
///    normalOffsetTexels x texel x sqrt(2), bounded even at grazing light;
///  - depth floor: depthFloorTexels texels of the cascade (metres) plus depthFloorQuantum units of
///    stored depth (the format's quantum: a D16 step or 16 ulp of D32), toward the light. It is
///    all that remains when the light hits a surface head-on (theta = 0).
/// Receivers facing away from the light (cos theta <= 0) are not sampled (csmShadow).
vec3 csmShadowCoord(int i, vec3 posCr, vec3 normalWs) {
  const float texelM = csmU.cascades[i].texelSizeM;
  // The normal's components along the map's texel axes (the rows of the cascade's matrix).
  const mat4 m = csmU.cascades[i].viewProjCr;
  const float nx = dot(normalWs, normalize(vec3(m[0][0], m[1][0], m[2][0])));
  const float ny = dot(normalWs, normalize(vec3(m[0][1], m[1][1], m[2][1])));
  const float offsetM = csmU.normalOffsetTexels * texelM * (abs(nx) + abs(ny));
  const vec4 clip = csmU.cascades[i].viewProjCr * vec4(posCr + normalWs * offsetM, 1.0);
  const float metresPerDepth = max(csmU.cascades[i].depthRangeM, 1e-30);
  const float floorDepth =
      csmU.depthFloorTexels * texelM / metresPerDepth + csmU.depthFloorQuantum;
  return vec3((clip.xy * 0.5 + 0.5) * csmU.resolution, clip.z - floorDepth);
}

/// The geometric (facet) normal of the triangle a receiver lies on, for the bias: what the shadow
/// map holds is that facet, so the normal offset, the facing test and the PCSS receiver plane
/// must use its normal. A smooth (interpolated) shading normal on a coarse mesh (a 10-sided tree
/// cone whose rim normals average the base cap in) can be tilted by tens of degrees from it: near
/// the light/dark boundary the bias then follows the wrong plane and the surface hatches itself.
/// Pass the screen-space derivatives of the camera-relative position (in a fragment shader:
/// dFdx(posCr), dFdy(posCr); exact on a triangle, the quad's helper lanes extrapolate the same
/// plane). The result is turned to the side of `shadingNormal` (as the host shades it: flipped
/// for back faces of open meshes, say); where the facet is seen nearly edge-on (the derivatives
/// nearly parallel, so float rounding could turn the cross product) `shadingNormal` is returned.
///   float s = csmShadow(posCr, csmGeometricNormal(dFdx(posCr), dFdy(posCr), n), px);
vec3 csmGeometricNormal(vec3 dPdx, vec3 dPdy, vec3 shadingNormal) {
  const vec3 c = cross(dPdx, dPdy);
  const float len = length(c);
  if (!(len > 1e-3 * length(dPdx) * length(dPdy))) return shadingNormal;
  const vec3 ng = c / len;
  return dot(ng, shadingNormal) < 0.0 ? -ng : ng;
}

// ---- Prefiltered filters: VSM, EVSM, MSM ------------------------------------------------------
// The map's depths were turned into moments, blurred and mip-mapped (csm_moments.comp); one
// trilinear tap of them per cascade bounds the lit fraction. Each function mirrors its C++
// twin in csm/moments.hpp. The receiver's depth is csmShadowCoord's (normal offset and depth
// floor): the same bias as the percentage-closer kernels, no per-scene tuning.

/// Mirror of csm::chebyshevUpperBound.
float csmChebyshev(float mean, float meanSquare, float depth, float minVariance) {
  if (!(depth > mean)) return 1.0;
  const float variance = max(meanSquare - mean * mean, minVariance);
  const float d = depth - mean;
  return clamp(variance / (variance + d * d), 0.0, 1.0);
}

/// Mirror of csm::hamburgerShadowIntensity: MSM's occluded fraction from four biased moments.
float csmHamburger(vec4 b, float zf) {
  const float d22 = b.y - b.x * b.x;
  if (!(d22 > 0.0)) return 0.0;
  const float l32 = (b.z - b.x * b.y) / d22;
  const float d33 = b.w - b.y * b.y - l32 * l32 * d22;
  if (!(d33 > 0.0)) return 0.0;
  const float y2 = zf - b.x;
  const float y3 = zf * zf - b.y - l32 * y2;
  const float c3 = y3 / d33;
  const float c2 = y2 / d22 - l32 * c3;
  const float c1 = 1.0 - b.x * c2 - b.y * c3;
  if (c3 == 0.0) return 0.0;
  const float p = c2 / c3;
  const float q = c1 / c3;
  const float r = sqrt(max(0.25 * p * p - q, 0.0));
  const float z2 = -0.5 * p - r;
  const float z3 = -0.5 * p + r;
  float g = 0.0;
  if (zf <= z2) {
    g = 0.0;
  } else if (zf <= z3) {
    g = (zf * z3 - b.x * (zf + z3) + b.y) / ((z3 - z2) * (zf - z2));
  } else {
    g = 1.0 - (z2 * z3 - b.x * (z2 + z3) + b.y) / ((zf - z2) * (zf - z3));
  }
  return clamp(g, 0.0, 1.0);
}

/// Mirror of csm::momentLitFraction (the kernel is csmKernel).
float csmMomentLit(vec4 moments, float depth, float minVariance) {
  const float z = clamp(depth, 0.0, 1.0);
  float lit = 1.0;
  if (csmKernel == CSM_KERNEL_VSM) {
    lit = csmChebyshev(moments.x, moments.y, z, max(minVariance, CSM_VSM_MIN_VARIANCE));
  } else if (csmKernel == CSM_KERNEL_EVSM) {
    const float w = 2.0 * z - 1.0;
    const float cp = csmU.moments.z;
    const float cn = csmU.moments.w;
    const float pos = exp(cp * w);
    const float neg = -exp(-cn * w);
    const float posSlope = 2.0 * cp * pos;
    const float negSlope = 2.0 * cn * neg;
    lit = min(csmChebyshev(moments.x, moments.y, pos, minVariance * posSlope * posSlope),
              csmChebyshev(moments.z, moments.w, neg, minVariance * negSlope * negSlope));
  } else {
    const float a = csmU.moments.y;
    const vec4 biased = (1.0 - a) * moments + a * vec4(0.0, 1.0 / 3.0, 0.0, 0.2);
    lit = 1.0 - csmHamburger(biased, 2.0 * z - 1.0);
  }
  const float reduction = csmU.moments.x;
  return clamp((lit - reduction) / (1.0 - reduction), 0.0, 1.0);
}

/// Mirror of csm::momentReadFootprint: the footprint (level-0 texels) a mip read may
/// take at box texel distance `edgeTexels` from the box's edge, for a receiver at stored depth
/// `depth` on a plane of `slopePerTexel`.
float csmMomentReadFootprint(float wanted, float edgeTexels, float depth, vec2 slopePerTexel) {
  const float slope = length(slopePerTexel);
  const float byDepth = slope > 0.0 ? depth / slope : edgeTexels;
  const float cap = max(min(edgeTexels, byDepth) / 3.0, 1.0);
  return min(wanted, cap);
}

/// Mirror of csm::momentReceiverShift (csm::momentFootprintSpread): how far toward the light the
/// receiver's compared depth moves when it reads a mip of footprint `footprintTexels` (level-0
/// texels), so that a lit plane whose depths the mip spreads reads lit.
float csmMomentReceiverShift(vec2 slopePerTexel, float footprintTexels) {
  if (!(footprintTexels > 1.0)) return 0.0;
  const float texels = sqrt((footprintTexels * footprintTexels - 1.0) / 3.0);
  const float spread = texels * length(slopePerTexel);
  if (csmKernel == CSM_KERNEL_MSM) return spread;
  if (csmKernel != CSM_KERNEL_EVSM) return 0.0;
  return min(csmU.moments.w * spread, 1.0) * spread;
}

/// Level 0 of the moments of cascade i at box texel coordinates `t`, bilinear by hand from four
/// gathers (one per channel): float weights, so that a receiver whose coordinate differs by float
/// rounding between frames reads the same moments to within that rounding. The sampler's
/// fixed-point sub-texel weights (8 bits on the GPUs we measured) changed a factor through the
/// reconstruction by up to 1.3/255 there.
vec4 csmMomentBilinear(int i, vec2 t) {
  const vec2 f = t - 0.5;
  const vec2 i0 = floor(f);
  const vec2 w = f - i0;
  // At the corner shared by the four texels (order (i0, j1), (i1, j1), (i1, j0), (i0, j0)).
  const vec3 uvw = vec3(csmWrapUv(i0 + 1.0, i), float(i));
  const mat4 g = mat4(textureGather(csmMomentMap, uvw, 0), textureGather(csmMomentMap, uvw, 1),
                      textureGather(csmMomentMap, uvw, 2), textureGather(csmMomentMap, uvw, 3));
  // Rows of g: the four texels' moments (g[c][k]: channel c of texel k).
  const vec4 t01 = vec4(g[0].x, g[1].x, g[2].x, g[3].x);
  const vec4 t11 = vec4(g[0].y, g[1].y, g[2].y, g[3].y);
  const vec4 t10 = vec4(g[0].z, g[1].z, g[2].z, g[3].z);
  const vec4 t00 = vec4(g[0].w, g[1].w, g[2].w, g[3].w);
  return mix(mix(t00, t10, w.x), mix(t01, t11, w.x), w.y);
}

/// Prefiltered shadow factor of cascade i: the moments the receiver's footprint covers. dPdx,
/// dPdy: the receiver's screen-space derivatives (zero outside a fragment shader). Where the
/// footprint is at most a texel (magnification: level 0, bilinear), the moments are filtered by
/// hand (csmMomentBilinear); where it is larger, one trilinear (or anisotropic) tap reads the
/// mip it covers, so a far or grazing receiver does not alias. The footprint stays inside the box
/// and the stored depth range (csmMomentReadFootprint), and the receiver compares in front of the
/// spread the mip gives its own plane (csmMomentReceiverShift): lit ground stays lit at every sun
/// elevation.
float csmMomentShadow(int i, vec3 posCr, vec3 normalWs, vec3 dPdx, vec3 dPdy) {
  const vec3 c = csmShadowCoord(i, posCr, normalWs);
  const mat4 m = csmU.cascades[i].viewProjCr;
  const vec2 gx = (m * vec4(dPdx, 0.0)).xy * 0.5;
  const vec2 gy = (m * vec4(dPdy, 0.0)).xy * 0.5;
  const float res = csmU.resolution;
  const vec2 slope = csmReceiverDepthSlope(i, normalWs);
  // The footprint in level-0 texels: an anisotropic sampler takes it as it is (its long axis;
  // the sampler reads the short axis's mip along it); a trilinear one would read the long axis's
  // mip and blur a grazing footprint across, so it reads the mip of the geometric-mean axis
  // (sharper, and steadier than level 0 by far). No wider than the box and the depth range
  // allow (csmMomentReadFootprint); the gradients are scaled to match.
  const float longAxis = sqrt(max(dot(gx, gx), dot(gy, gy))) * res;
  const float meanAxis = sqrt(abs(gx.x * gy.y - gx.y * gy.x)) * res;
  const float wanted = csmU.momentAnisotropy > 1.0 ? longAxis : meanAxis;
  const float edge = min(min(c.x, c.y), min(res - c.x, res - c.y));
  const float footprint = csmMomentReadFootprint(wanted, edge, c.z, slope);
  const float k = longAxis > footprint ? footprint / longAxis : 1.0;
  const vec4 read =
      footprint <= 1.0
          ? csmMomentBilinear(i, c.xy)
          : textureGrad(csmMomentMap, vec3(csmWrapUv(c.xy, i), float(i)), gx * k, gy * k);
  // 64-bit MSM moments are stored quantised; the quantisation is affine, so the filtered
  // quantised moments decode to the filtered moments.
  const vec4 moments = csmU.momentQuantized != 0u ? csmMsmDequantize(read) : read;
  // The variance floor: a quarter texel of depth at 45 degrees (units of stored depth).
  const float texelDepth =
      0.5 * csmU.cascades[i].texelSizeM / max(csmU.cascades[i].depthRangeM, 1e-6);
  // A mip spreads the receiver's own plane over its footprint: compare in front of the spread.
  const float shift = csmMomentReceiverShift(slope, footprint);
  return csmMomentLit(moments, c.z - shift, texelDepth * texelDepth);
}

/// Filtered shadow factor of cascade i at a receiver: 1 lit, 0 in shadow. dPdx, dPdy: see
/// csmMomentShadow (only the prefiltered filters read them).
float csmSampleCascade(int i, vec3 posCr, vec3 normalWs, vec3 dPdx, vec3 dPdy) {
  if (csmKernel >= CSM_KERNEL_VSM) return csmMomentShadow(i, posCr, normalWs, dPdx, dPdy);
  if (csmKernel == CSM_KERNEL_PCSS) return csmPcss(i, posCr, normalWs);
  const vec3 c = csmShadowCoord(i, posCr, normalWs);
  const float layer = float(i);
  const float scale = csmU.cascades[i].kernelScale;
  if (csmKernel == CSM_KERNEL_1TAP) return csmTap(c.xy, layer, c.z);
  const vec2 slope = csmReceiverDepthSlope(i, normalWs);
  if (csmKernel == CSM_KERNEL_POISSON16) {
    return csmPcfPoisson(i, c.xy, scale, c.z, slope);
  }
  return csmPcfTent(c.xy, scale, layer, c.z, slope);
}

/// Receiver-marked tiles (RendererOptions::tiles): whether cascade i's layer holds every texel
/// of its box that its filter can read around the receiver at camera-relative `posCr` (every
/// tile under the reach, clamped to the box, drawn; what lies outside the box reads lit as
/// always). Always true for a cascade drawn whole.
bool csmTilesHold(int i, vec3 posCr) {
  if ((csmU.tilePartialMask & (1u << uint(i))) == 0u) return true;
  const vec4 clip = csmU.cascades[i].viewProjCr * vec4(posCr, 1.0);
  const vec2 t = (clip.xy * 0.5 + 0.5) * csmU.resolution;
  const vec4 g = csmU.tileGrid[i];
  const vec2 lastTexel = vec2(csmU.resolution - 1.0);
  const vec2 a = clamp(t - g.z, vec2(0.0), lastTexel);
  const vec2 b = clamp(t + g.z, vec2(0.0), lastTexel);
  const ivec2 lo = ivec2(floor((a + g.xy) * csmU.tileInvTexels));
  const ivec2 hi = ivec2(floor((b + g.xy) * csmU.tileInvTexels));
  if (any(lessThan(lo, ivec2(0))) || any(greaterThan(hi, ivec2(CSM_TILE_GRID_SIDE - 1)))) {
    return false;
  }
  for (int y = lo.y; y <= hi.y; ++y) {
    for (int x = lo.x; x <= hi.x; ++x) {
      const int b = y * CSM_TILE_GRID_SIDE + x;
      const uint word = csmU.tileBits[i * 3 + b / 128][(b / 32) % 4];
      if ((word & (1u << uint(b % 32))) == 0u) return false;
    }
  }
  return true;
}

/// Whether cascade j's box holds the receiver with its filter's reach, and its depth window the
/// receiver's depth (a cascade it falls back to).
bool csmBoxHolds(int j, vec3 posCr) {
  const vec4 clip = csmU.cascades[j].viewProjCr * vec4(posCr, 1.0);
  const vec2 t = (clip.xy * 0.5 + 0.5) * csmU.resolution;
  const float reach = csmU.tileGrid[j].z;
  return all(greaterThanEqual(t, vec2(reach))) &&
         all(lessThanEqual(t, vec2(csmU.resolution - reach))) && clip.z >= 0.0 && clip.z <= 1.0;
}

/// The cascade a receiver selected in cascade i is sampled in: i where its layer holds the
/// receiver (always without receiver-marked tiles), else the next non-empty cascade that does
/// (as virtual shadow maps fall back to coarser pages). The renderer keeps the last cascade
/// whole and only lets a cascade be partial whose slice lies inside it, so the search ends there.
int csmTileCascade(int i, vec3 posCr) {
  if (csmU.tilePartialMask == 0u || csmTilesHold(i, posCr)) return i;
  const int count = int(min(csmU.cascadeCount, uint(CSM_MAX_CASCADES)));
  int last = i;
  for (int j = i + 1; j < count; ++j) {
    if ((csmU.nonEmptyMask & (1u << uint(j))) == 0u) continue;
    last = j;
    if (csmBoxHolds(j, posCr) && csmTilesHold(j, posCr)) return j;
  }
  return last;
}

/// The shadow factor of a receiver: 1 lit, 0 in shadow; outside every cascade 1; 0 where the
/// normal faces away from the light (N.L <= 0), inside or outside the cascades.
float csmShadow(vec3 posCr, vec3 normalWs) {
  // Facing away from the light: in shadow by its own shading. 0 without sampling, so that the
  // shadow test can neither light such a surface nor add noise to it (the map holds the
  // surface's own depth there, or that of the lit side in front of it: a near tie).
  // Outside every cascade (and before the first shadow pass, when the block holds no cascade and
  // no light): lit, whatever the normal.
  // Toward the shadow distance the factor fades to lit (ShadowSettings::fadeFraction), so the
  // shadows end without a line.
#ifdef CSM_IMPLICIT_LOD
  // Before any branch: derivatives are defined in uniform control flow only.
  const vec3 dPdx = dFdx(posCr);
  const vec3 dPdy = dFdy(posCr);
#else
  const vec3 dPdx = vec3(0.0);
  const vec3 dPdy = vec3(0.0);
#endif
  const float viewDepth = csmViewDepth(posCr);
  const CsmSelection sel = csmSelectCascade(viewDepth);
  if (sel.index < 0) return 1.0;
  if (!(dot(normalWs, -csmU.lightDirection.xyz) > 0.0)) return 0.0;
  const float fade = csmFade(viewDepth);
  if (fade >= 1.0) return 1.0;
  const int first = csmTileCascade(sel.index, posCr);
  float s = csmSampleCascade(first, posCr, normalWs, dPdx, dPdy);
  if (csmBlend != 0 && sel.blendIndex >= 0 && sel.blendWeight > 0.0) {
    const int second = csmTileCascade(sel.blendIndex, posCr);
    if (second != first) {
      s = mix(s, csmSampleCascade(second, posCr, normalWs, dPdx, dPdy), sel.blendWeight);
    }
  }
  return mix(s, 1.0, fade);
}

/// The same, for hosts written when the Poisson disk rotated by the screen pixel: `pixel` is no
/// longer read (every filter's noise is keyed to the world texel, so it stays on the ground).
float csmShadow(vec3 posCr, vec3 normalWs, vec2 pixel) { return csmShadow(posCr, normalWs); }

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
  if (mode == CSM_DEBUG_TILES) {
    if (sel.index < 0) return vec3(0.0);
    const bool own = csmTileCascade(sel.index, posCr) == sel.index &&
                     (sel.blendIndex < 0 || csmTileCascade(sel.blendIndex, posCr) == sel.blendIndex);
    return own ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);
  }
  if (mode == CSM_DEBUG_LIGHT_COORDS || mode == CSM_DEBUG_SAMPLED_DEPTH ||
      mode == CSM_DEBUG_DEPTH_DIFF) {
    if (sel.index < 0) return vec3(0.0);
    const vec3 c = csmShadowCoord(sel.index, posCr, normalWs);
    const vec2 uv = c.xy * csmU.invResolution;
    if (mode == CSM_DEBUG_LIGHT_COORDS) return vec3(uv, c.z);
    const float stored =
        textureLod(csmDepthMap, vec3(csmWrapUv(c.xy, sel.index), float(sel.index)), 0.0).r;
    if (mode == CSM_DEBUG_SAMPLED_DEPTH) return vec3(stored);
    // Depth difference in texels of this cascade: red behind the stored depth, green in front.
    const float diffTexels = (c.z - stored) * csmU.cascades[sel.index].depthRangeM /
                             max(csmU.cascades[sel.index].texelSizeM, 1e-6);
    const float v = clamp(0.25 + abs(diffTexels) / 8.0, 0.0, 1.0);
    return diffTexels > 0.0 ? vec3(v, 0.0, 0.0) : vec3(0.0, v, 0.0);
  }
  return shaded;
}

#endif  // !CSM_UNIFORMS_ONLY
#endif  // CSM_GLSL
