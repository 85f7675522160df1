#version 460
// Writes the push-constant colour unchanged, so tests can check exact texel values.

layout(push_constant) uniform Push {
  vec4 color;
  vec2 offset;
  float scale;
  float depth;
} pc;

layout(location = 0) out vec4 outColor;

void main() { outColor = pc.color; }
