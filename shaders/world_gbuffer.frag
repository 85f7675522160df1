#version 450
// Sample world G-buffer pass (view.deferred): what world_deferred.frag shades, per pixel of the
// nearest surface (depth test LESS). The facet normal needs this fragment's derivatives, so it is
// taken here; normals are stored octahedral in RGBA16F, the view depth in R32F (the lighting
// pass puts the point back on its pixel's ray: the point the forward pass shades, to float
// rounding; 0, the clear value, where the sky remains).
#extension GL_GOOGLE_include_directive : require

#define CSM_SET 1
#include "csm.glsl"
#include "world_shading.glsl"

layout(location = 0) in vec3 inPositionCr;
layout(location = 1) in vec3 inNormalWs;
layout(location = 2) in vec4 inColor;
layout(location = 0) out vec4 outAlbedo;    // rgb albedo, a: receives shadows
layout(location = 1) out vec4 outNormals;   // xy shading normal, zw facet normal (octahedral)
layout(location = 2) out float outViewDepth;  // csmViewDepth of the position (> 0)

void main() {
  vec3 n = normalize(inNormalWs);
  if (!gl_FrontFacing) n = -n;  // open and thin meshes are seen from both sides
  const vec3 ng = csmGeometricNormal(dFdx(inPositionCr), dFdy(inPositionCr), n);
  outAlbedo = vec4(inColor.rgb, inColor.a > 0.5 ? 1.0 : 0.0);
  outNormals = vec4(worldOctEncode(n), worldOctEncode(ng));
  outViewDepth = csmViewDepth(inPositionCr);
}
