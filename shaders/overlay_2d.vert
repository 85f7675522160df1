#version 450
// Overlay geometry in pixels: solid shapes and lines (map, panels) and shadow-map thumbnails.

layout(location = 0) in vec2 inPixel;   // pixel position, origin top-left
layout(location = 1) in vec2 inUv;      // thumbnail uv
layout(location = 2) in vec4 inColor;   // solid colour (rgba)
layout(location = 3) in vec4 inDepth;   // x: layer (< 0: solid colour), y, z: depth remap range

layout(push_constant) uniform OverlayPush {
  vec2 invExtent;  // 1 / target size in pixels
} pc;

layout(location = 0) out vec2 outUv;
layout(location = 1) out vec4 outColor;
layout(location = 2) flat out vec4 outDepth;

void main() {
  outUv = inUv;
  outColor = inColor;
  outDepth = inDepth;
  gl_Position = vec4(inPixel * pc.invExtent * 2.0 - 1.0, 0.0, 1.0);
}
