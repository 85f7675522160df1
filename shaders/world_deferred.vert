#version 450
// Sample world deferred lighting pass: one triangle covering the view (vertices 0, 1, 2).

void main() {
  const vec2 p = vec2(float((gl_VertexIndex << 1) & 2), float(gl_VertexIndex & 2));
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
