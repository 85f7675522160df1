#version 460
// A single flat triangle placed in clip space by push constants (engine tests and smoke app).
// Vertex i of the base triangle: (0, -0.5), (0.5, 0.5), (-0.5, 0.5) in NDC (Vulkan: y down).

layout(push_constant) uniform Push {
  vec4 color;    // written unchanged by engine_tri.frag
  vec2 offset;   // NDC offset of the triangle
  float scale;   // scale of the base triangle
  float depth;   // NDC depth in [0, 1]
} pc;

const vec2 kBase[3] = vec2[](vec2(0.0, -0.5), vec2(0.5, 0.5), vec2(-0.5, 0.5));

void main() {
  gl_Position = vec4(pc.offset + pc.scale * kBase[gl_VertexIndex], pc.depth, 1.0);
}
