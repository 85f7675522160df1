// A test scene on the GPU (see gpu_scene.hpp).
#include "glue/gpu_scene.hpp"

namespace glue {

GpuScene uploadScene(engine::Context& ctx, const Scene& scene, const std::string& name) {
  GpuScene out;
  uint64_t vertices = 0, indices = 0;
  for (const MeshData& m : scene.meshes()) {
    vertices += m.vertices.size();
    indices += m.indices.size();
  }
  out.store = std::make_unique<engine::MeshStore>(ctx, uint32_t(vertices + 16),
                                                  uint32_t(indices + 16), name);
  for (const MeshData& m : scene.meshes()) {
    const engine::MeshRange r = out.store->upload(m.vertices, m.indices);
    out.ranges.push_back(r);
    csm::vk::MeshDraw d;
    d.vertexBuffer = out.store->vertexBuffer();
    d.indexBuffer = out.store->indexBuffer();
    d.firstIndex = r.firstIndex;
    d.indexCount = r.indexCount;
    d.vertexOffset = r.vertexOffset;
    out.meshDraws.push_back(d);
  }
  for (const Instance& in : scene.instances()) {
    out.casters.push_back({in.mesh, in.translationWs, in.linearWs});
    out.casters.back().thin = in.thin;
    out.casters.back().thinWidthM = in.thinWidthM;
    out.casters.back().closed = in.closed;
    out.litDraws.push_back({out.ranges[in.mesh], in.translationWs, in.linearWs, in.color});
  }
  return out;
}

}  // namespace glue
