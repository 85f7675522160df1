#version 450
// Sample world lit pass: instanced meshes, camera-relative. Per instance: the rows of the
// object -> camera-relative world affine transform and the colour (alpha: receives shadows).

layout(location = 0) in vec3 inPositionMs;
layout(location = 1) in vec3 inNormalMs;
layout(location = 2) in vec4 inModelRow0;
layout(location = 3) in vec4 inModelRow1;
layout(location = 4) in vec4 inModelRow2;
layout(location = 5) in vec4 inColor;

layout(std140, set = 0, binding = 0) uniform WorldFrame {
  mat4 viewProjCr;      // camera-relative world -> clip
  vec4 lightDirection;  // xyz direction the light travels
  vec4 lightColor;      // rgb
  vec4 ambientColor;    // rgb
  uvec4 overlay;        // x cascade tint, y texel checker
  mat4 invViewProjCr;   // clip -> camera-relative world (the deferred lighting pass)
} frame;

// The depth pre-pass runs this shader without a fragment stage and the lit pass tests its
// depths EQUAL: the position must be computed identically in both pipelines. `precise` (no
// contraction into fused multiply-adds, every operation that feeds gl_Position) gives that
// without `invariant`, whose decoration on the gl_PerVertex block Mesa's SPIR-V reader warns about.
precise gl_Position;

layout(location = 0) out vec3 outPositionCr;
layout(location = 1) out vec3 outNormalWs;
layout(location = 2) out vec4 outColor;

void main() {
  const mat4x3 model = transpose(mat3x4(inModelRow0, inModelRow1, inModelRow2));
  const vec3 posCr = model * vec4(inPositionMs, 1.0);
  // The linear part is a rotation times a uniform scale (cables also stretch along their own
  // axis, which leaves their cross-section normals perpendicular): it maps normals as it maps
  // directions, and the fragment shader normalises. No per-vertex inverse: on a CPU rasteriser
  // vertex work runs on one thread.
  outNormalWs = mat3(model) * inNormalMs;
  outPositionCr = posCr;
  outColor = inColor;
  gl_Position = frame.viewProjCr * vec4(posCr, 1.0);
}
