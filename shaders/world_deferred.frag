#version 450
// Sample world deferred lighting pass (view.deferred): world_shading.glsl once per pixel from the
// G-buffer (world_gbuffer.frag), so the shadow lookup runs once per pixel at full SIMD width
// instead of once per rasterised fragment of the geometry (a CPU rasteriser shades whole 4x4
// blocks of pixel-sized triangles). Sky pixels (view depth 0) keep the cleared colour.
#extension GL_GOOGLE_include_directive : require

#define CSM_SET 1
#define CSM_IMPLICIT_LOD  // fragment stage: the prefiltered filters read the footprint's mip
#include "csm.glsl"
#include "world_shading.glsl"

layout(set = 2, binding = 0) uniform sampler2D gAlbedo;
layout(set = 2, binding = 1) uniform sampler2D gNormals;
layout(set = 2, binding = 2) uniform sampler2D gViewDepth;

layout(location = 0) out vec4 outColor;

/// The camera-relative position of pixel q's surface at view depth `viewDepth`: the pixel
/// centre's ray through the far plane, scaled to that depth.
vec3 positionAt(ivec2 q, float viewDepth) {
  const vec2 ndc = (vec2(q) + 0.5) / vec2(textureSize(gViewDepth, 0)) * 2.0 - 1.0;
  const vec4 far = frame.invViewProjCr * vec4(ndc, 1.0, 1.0);
  const vec3 ray = far.xyz / far.w;
  return ray * (viewDepth / csmViewDepth(ray));
}

/// The change of the surface position to the next pixel along `axis`, from the G-buffer (this
/// full-screen pass has no derivatives of the surface): the difference to the neighbour on either
/// side whose view depth is closer (so one-sided across a depth edge or at the border of the
/// view); 0 where neither neighbour holds a surface.
vec3 positionStep(ivec2 p, ivec2 axis, vec3 posCr, float viewDepth) {
  const ivec2 size = textureSize(gViewDepth, 0);
  vec3 step = vec3(0.0);
  float bestGap = 1e30;
  for (int side = -1; side <= 1; side += 2) {
    const ivec2 q = p + side * axis;
    if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
    const float d = texelFetch(gViewDepth, q, 0).r;
    if (!(d > 0.0) || !(abs(d - viewDepth) < bestGap)) continue;
    bestGap = abs(d - viewDepth);
    step = float(side) * (positionAt(q, d) - posCr);
  }
  return step;
}

void main() {
  const ivec2 p = ivec2(gl_FragCoord.xy);
  const float viewDepth = texelFetch(gViewDepth, p, 0).r;
  if (!(viewDepth > 0.0)) discard;
  const vec3 posCr = positionAt(p, viewDepth);
  const vec4 albedo = texelFetch(gAlbedo, p, 0);
  const vec4 normals = texelFetch(gNormals, p, 0);
  // Only the texel checker reads the position's steps to the neighbouring pixels.
  vec3 dPdx = vec3(0.0), dPdy = vec3(0.0);
  if (frame.overlay.y != 0u) {
    dPdx = positionStep(p, ivec2(1, 0), posCr, viewDepth);
    dPdy = positionStep(p, ivec2(0, 1), posCr, viewDepth);
  }
  outColor = vec4(worldShade(posCr, worldOctDecode(normals.xy), worldOctDecode(normals.zw),
                             albedo.rgb, albedo.a > 0.5, gl_FragCoord.xy, dPdx, dPdy),
                  1.0);
}
