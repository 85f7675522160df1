#version 450
// Sample world deferred lighting pass (view.deferred): world_shading.glsl once per pixel from the
// G-buffer (world_gbuffer.frag), so the shadow lookup runs once per pixel at full SIMD width
// instead of once per rasterised fragment of the geometry (a CPU rasteriser shades whole 4x4
// blocks of pixel-sized triangles). Sky pixels (view depth 0) keep the cleared colour.
#extension GL_GOOGLE_include_directive : require

#define CSM_SET 1
#define CSM_IMPLICIT_LOD  // fragment stage: implicit-derivative taps (csmCompareTap)
#include "csm.glsl"
#include "world_shading.glsl"

layout(set = 2, binding = 0) uniform sampler2D gAlbedo;
layout(set = 2, binding = 1) uniform sampler2D gNormals;
layout(set = 2, binding = 2) uniform sampler2D gViewDepth;

layout(location = 0) out vec4 outColor;

void main() {
  const ivec2 p = ivec2(gl_FragCoord.xy);
  const float viewDepth = texelFetch(gViewDepth, p, 0).r;
  if (!(viewDepth > 0.0)) discard;
  // The pixel centre's ray through the far plane, scaled to the stored view depth.
  const vec2 ndc = gl_FragCoord.xy / vec2(textureSize(gViewDepth, 0)) * 2.0 - 1.0;
  const vec4 far = frame.invViewProjCr * vec4(ndc, 1.0, 1.0);
  const vec3 ray = far.xyz / far.w;
  const vec3 posCr = ray * (viewDepth / csmViewDepth(ray));
  const vec4 albedo = texelFetch(gAlbedo, p, 0);
  const vec4 normals = texelFetch(gNormals, p, 0);
  outColor = vec4(worldShade(posCr, worldOctDecode(normals.xy), worldOctDecode(normals.zw),
                             albedo.rgb, albedo.a > 0.5, gl_FragCoord.xy),
                  1.0);
}
