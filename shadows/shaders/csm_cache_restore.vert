// Cached cascades, CacheRestore::kShaderCopy: one triangle over the whole layer; the scissor
// keeps the rectangle being restored (csm_cache_restore.frag writes its depth).
#version 450

void main() {
  // (-1, -1), (3, -1), (-1, 3): covers clip space [-1, 1]^2.
  const vec2 p = vec2(float((gl_VertexIndex & 1) * 4 - 1), float((gl_VertexIndex & 2) * 2 - 1));
  gl_Position = vec4(p, 0.0, 1.0);
}
