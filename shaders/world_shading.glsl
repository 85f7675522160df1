// The sample world's shading, shared by the forward lit pass (world.frag) and the deferred
// lighting pass (world_deferred.frag): Lambert + Blinn-Phong under the sun, shadowed through
// csm.glsl, with the cascade-visualisation overlay (cascade tint, blend bands as the mix of two
// tints, each cascade's shadow texels as a checker on the receivers) and csm.glsl's debug views.
// Include after csm.glsl (CSM_SET 1); declares the WorldFrame block at set 0, binding 0.
#ifndef WORLD_SHADING_GLSL
#define WORLD_SHADING_GLSL

layout(std140, set = 0, binding = 0) uniform WorldFrame {
  mat4 viewProjCr;
  vec4 lightDirection;
  vec4 lightColor;
  vec4 ambientColor;
  uvec4 overlay;
  mat4 invViewProjCr;  // clip -> camera-relative world (the deferred pass's pixel rays)
} frame;

/// The texel checker's contrast at a receiver of cascade i: full where a shadow-map texel covers
/// 4 pixels or more, fading to 0 where it covers 2 or fewer (a checker of smaller cells only
/// aliases into moire). `dPdx`, `dPdy`: the position's change to the next pixel along x and y;
/// through the cascade's affine matrix they give the texel coordinates' screen derivatives, so
/// `fw` is fwidth(texel coordinates).
float worldCheckerContrast(int i, vec3 dPdx, vec3 dPdy) {
  const mat3 toTexels = mat3(csmU.cascades[i].viewProjCr) * (0.5 * csmU.resolution);
  const vec2 fw = abs((toTexels * dPdx).xy) + abs((toTexels * dPdy).xy);
  const float pixelsPerTexel = 1.0 / max(max(fw.x, fw.y), 1e-6);
  return clamp(0.5 * (pixelsPerTexel - 2.0), 0.0, 1.0);
}

/// The colour of a surface point: `posCr` camera-relative, `n` the unit shading normal facing the
/// viewer, `ng` the facet normal the shadow bias follows (csmGeometricNormal), `base` the albedo,
/// `receives` whether it is shadowed at all, `pixel` gl_FragCoord.xy, `dPdx` and `dPdy` the change
/// of posCr to the next pixel along x and y (the texel checker's footprint; taken by the caller
/// in uniform control flow, or from neighbouring pixels where there are no derivatives).
vec3 worldShade(vec3 posCr, vec3 n, vec3 ng, vec3 base, bool receives, vec2 pixel, vec3 dPdx,
                vec3 dPdy) {
  const vec3 toLight = -normalize(frame.lightDirection.xyz);
  const vec3 toEye = normalize(-posCr);
  const float s = receives ? csmShadow(posCr, ng, pixel) : 1.0;
  const float lambert = max(dot(n, toLight), 0.0);
  const vec3 h = normalize(toLight + toEye);
  const float spec = lambert > 0.0 ? pow(max(dot(n, h), 0.0), 24.0) : 0.0;
  // Sky light from above, a little bounce from below.
  const float sky = 0.75 + 0.25 * n.y;
  vec3 color = base * frame.ambientColor.rgb * sky * mix(1.0, s, 0.4) +
               frame.lightColor.rgb * s * (base * lambert + 0.08 * spec);

  if (receives && (frame.overlay.x != 0u || frame.overlay.y != 0u)) {
    const CsmSelection sel = csmSelectCascade(csmViewDepth(posCr));
    if (sel.index >= 0) {
      if (frame.overlay.x != 0u) {
        vec3 tint = csmCascadeTint(sel.index);
        if (sel.blendIndex >= 0) tint = mix(tint, csmCascadeTint(sel.blendIndex), sel.blendWeight);
        color = mix(color, tint, 0.3);
      }
      if (frame.overlay.y != 0u) {
        const vec3 c = csmShadowCoord(sel.index, posCr, vec3(0.0));
        const vec2 cell = floor(c.xy);
        const float checker = mod(cell.x + cell.y, 2.0);
        color *= 1.0 - 0.22 * worldCheckerContrast(sel.index, dPdx, dPdy) * (1.0 - checker);
      }
    }
  }
  if (csmDebugMode() != CSM_DEBUG_NONE) color = csmDebugColor(posCr, n, pixel, s, color);
  return color;
}

/// A unit vector as two numbers in [-1, 1] (octahedral map: the octahedron |x|+|y|+|z| = 1
/// unfolded onto a square, its lower half folded over the corners), and back.
vec2 worldOctEncode(vec3 n) {
  n /= abs(n.x) + abs(n.y) + abs(n.z);
  const vec2 signs = vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
  return n.z >= 0.0 ? n.xy : (1.0 - abs(n.yx)) * signs;
}
vec3 worldOctDecode(vec2 e) {
  vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
  if (n.z < 0.0) {
    const vec2 signs = vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    n.xy = (1.0 - abs(n.yx)) * signs;
  }
  return normalize(n);
}

#endif
