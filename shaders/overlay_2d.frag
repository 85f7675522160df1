#version 450
// Overlay: solid colour, or a cascade's shadow-map thumbnail: the cascade's light box as the
// lighting pass reads it (box texels unwrapped through csmWrapUv, so a toroidally addressed layer
// is not torn at its wrap), casters dark on a light ground.
//
// Why the depth is shown against the local ground and not through one linear remap of the layer:
// the ground itself spans most of a layer's depth. With the sun e degrees high, flat ground seen
// from the light recedes by 1/tan(e) metres of depth per metre across the box (1.6 at 32 degrees:
// 3.2 r over a box of side 2 r), while a tree of height H stands only H / sin(e) nearer than the
// ground behind it (1.9 H). Any global range [nearest caster, farthest receiver] therefore turns
// the ground into a gradient across the thumbnail and a 10 m tree in a 90 m cascade into 6 % of it
// (2 % in a 500 m one): flat blocks at 8 bits. So each stored texel is turned back into the world
// height of the surface it holds (linear in box texel and depth: `inRelief`, from the cascade's
// matrix on the CPU), which removes the tilt, and a pixel shows how high the highest of 4 texels
// across its footprint stands above the ground around that texel: the lowest mean of pairs of
// taps at opposite points (a pair's mean cancels the terrain's slope; the lowest pair is the one
// on bare ground). The footprint's taps keep casters smaller than a pixel (the far cascades: a
// tree is a fraction of a pixel) and each is judged against its own ground, so that the slope
// across a pixel is not read as height. Casters read dark by their height, the ground light,
// toned by its height across the cascade's bounding sphere (the window the receivers lie in);
// where nothing was drawn, white. With a prefiltered filter (vsm, evsm, msm) the thumbnail shows
// the moment layer the lighting reads instead (level 0, blurred), its first moment turned back
// into depth, so the casters' edges show the blur.
#extension GL_GOOGLE_include_directive : require

#define CSM_SET 0
#include "csm.glsl"

layout(location = 0) in vec2 inUv;  // thumbnails: uv across the cascade's box (0..1)
// Thumbnails: rgb white, a = 1 for the depth layer, 2 + the kernel (CSM_KERNEL_VSM, _EVSM, _MSM)
// for the moment layer.
layout(location = 1) in vec4 inColor;
// x: cascade (< 0: solid colour), y: world height (m) of box texel (0, 0) at stored depth 0 above
// the bounding sphere's centre, z: the sphere's radius (m), w: the thumbnail's side in pixels.
layout(location = 2) flat in vec4 inThumb;
// World height (m) per box texel along x, y and per unit of stored depth.
layout(location = 3) flat in vec3 inRelief;
layout(location = 0) out vec4 outColor;

// Distances (metres across the box) of the ground taps from a texel: about a tree's footprint in
// the light's view (its crown and its height foreshortened along the light), and a wider ring for
// buildings and groups of trees. Short on purpose: a pair's mean follows the terrain's slope but
// not its curvature, so ridges and hill tops read raised by about r^2/2 times their curvature (the
// thin dark lines along ridges, which do cast shadows behind them).
const float kGroundRadiusM = 6.0;
const float kWideGroundRadiusM = 16.0;
// Height above the local ground at which a caster reads fully dark (a bush); half a metre and
// less reads as ground.
const float kDarkAboveM = 4.0;
const float kGroundAboveM = 0.5;
const float kNothing = -1e30;

// The filter whose moments the thumbnail shows, or -1 for the depth layer.
int gMomentKernel = -1;

// The depth stored at box texel `centre` of cascade c, and the far plane's value there: from the
// depth layer, or the mean depth of the moment layer (inverting csm::depthMoments' first moment).
float storedDepth(vec2 centre, int c, out float far) {
  const vec3 uvw = vec3(csmWrapUv(centre, c), float(c));
  far = 1.0;
  if (gMomentKernel < 0) return textureLod(csmDepthMap, uvw, 0.0).r;
  far = 0.9999;  // the blur and the exponential's rounding leave the far plane just below 1
  const vec4 read = textureLod(csmMomentMap, uvw, 0.0);
  const float m = (csmU.momentQuantized != 0u ? csmMsmDequantize(read) : read).x;
  if (gMomentKernel == CSM_KERNEL_VSM) return m;
  if (gMomentKernel == CSM_KERNEL_EVSM) {
    return 0.5 * (log(max(m, 1e-30)) / max(csmU.moments.z, 1e-3) + 1.0);
  }
  return 0.5 * (m + 1.0);  // MSM: the centred depth 2 z - 1
}

// World height (m, above the sphere's centre) of the surface held at box texel t of cascade c
// (the texel's centre), or kNothing outside the box or where nothing was drawn (the far plane).
float boxHeight(vec2 t, int c) {
  const float res = csmU.resolution;
  if (any(lessThan(t, vec2(0.0))) || any(greaterThanEqual(t, vec2(res)))) return kNothing;
  const vec2 centre = floor(t) + 0.5;
  float far;
  const float d = storedDepth(centre, c, far);
  return d < far ? inThumb.y + dot(inRelief, vec3(centre, d)) : kNothing;
}

// How high the surface at box texel t stands above the ground around it (m), or -1 where nothing
// was drawn; `ground` receives that ground's height. The ground: the lowest mean of a pair of
// opposite taps (4 directions, 2 radii), or the surface itself.
float aboveGround(vec2 t, int c, out float ground) {
  const float h = boxHeight(t, c);
  ground = h;
  if (h == kNothing) return -1.0;
  const vec2 dirs[4] =
      vec2[4](vec2(1.0, 0.0), vec2(0.0, 1.0), vec2(0.7071, 0.7071), vec2(0.7071, -0.7071));
  const float texelM = max(csmU.cascades[c].texelSizeM, 1e-6);
  for (int ring = 0; ring < 2; ++ring) {
    const float r = (ring == 0 ? kGroundRadiusM : kWideGroundRadiusM) / texelM;
    for (int k = 0; k < 4; ++k) {
      const float a = boxHeight(t + r * dirs[k], c), b = boxHeight(t - r * dirs[k], c);
      if (a != kNothing && b != kNothing) ground = min(ground, 0.5 * (a + b));
    }
  }
  return h - ground;
}

void main() {
  if (inThumb.x < 0.0) {
    outColor = inColor;
    return;
  }
  const int c = int(inThumb.x);
  gMomentKernel = inColor.a > 1.5 ? int(round(inColor.a - 2.0)) : -1;
  const float res = csmU.resolution;
  const vec2 t = inUv * res;
  const float texelsPerPixel = res / max(inThumb.w, 1.0);
  // The highest caster over the pixel's footprint (2x2 taps, each against its own ground), so
  // that casters smaller than a pixel still show in the far cascades.
  float above = -1.0, ground = kNothing;
  for (int k = 0; k < 4; ++k) {
    const vec2 o = (vec2(k & 1, k >> 1) - 0.5) * (0.5 * texelsPerPixel);
    float g;
    const float a = aboveGround(t + o, c, g);
    if (a > above) above = a;
    if (g != kNothing) ground = max(ground, g);
  }
  if (ground == kNothing) {  // nothing drawn here: white
    outColor = vec4(inColor.rgb, 1.0);
    return;
  }
  const float caster = smoothstep(kGroundAboveM, kDarkAboveM, above);
  // The ground's tone: its height across the sphere (lower darker).
  const float s = clamp(0.5 + 0.5 * ground / max(inThumb.z, 1e-3), 0.0, 1.0);
  const float tone = mix(mix(0.6, 0.92, s), 0.05, caster);
  outColor = vec4(tone * inColor.rgb, 1.0);
}
