#version 450
// Overlay geometry in pixels: solid shapes and lines (map, panels) and shadow-map thumbnails.

layout(location = 0) in vec2 inPixel;   // pixel position, origin top-left
layout(location = 1) in vec2 inUv;      // thumbnail uv
layout(location = 2) in vec4 inColor;   // solid colour (rgba)
layout(location = 3) in vec4 inThumb;   // x: cascade (< 0: solid colour), y, z, w: overlay_2d.frag
layout(location = 4) in vec3 inRelief;  // thumbnails: overlay_2d.frag

layout(push_constant) uniform OverlayPush {
  vec2 invExtent;  // 1 / target size in pixels
} pc;

layout(location = 0) out vec2 outUv;
layout(location = 1) out vec4 outColor;
layout(location = 2) flat out vec4 outThumb;
layout(location = 3) flat out vec3 outRelief;

void main() {
  outUv = inUv;
  outColor = inColor;
  outThumb = inThumb;
  outRelief = inRelief;
  gl_Position = vec4(inPixel * pc.invExtent * 2.0 - 1.0, 0.0, 1.0);
}
