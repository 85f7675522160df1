// Cached cascades, CacheRestore::kShaderCopy: the sampled layer gets the static layer's depth
// back in the scissored rectangle, texel for texel. The value read is written unchanged
// (D32_SFLOAT stores the float as is), so the restore is bit-identical to a copy.
#version 450

// One layer of the static depth image (a 2D view), read by texel index: no filtering.
layout(set = 0, binding = 0) uniform sampler2D csmStaticDepth;

void main() {
  gl_FragDepth = texelFetch(csmStaticDepth, ivec2(gl_FragCoord.xy), 0).r;
}
