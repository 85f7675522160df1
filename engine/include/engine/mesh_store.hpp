// Meshes packed into one shared device-local vertex buffer and one index buffer, so every mesh
// is drawn with the same two bindings and a (firstIndex, vertexOffset, indexCount) triple.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <glm/vec3.hpp>
#include <span>
#include <string_view>
#include <vector>

#include "engine/memory.hpp"

namespace engine {

class Context;

/// One vertex: object-space position and normal (positions of objects far from the origin are
/// handled by per-draw camera-relative transforms, never stored in world space here).
struct Vertex {
  glm::vec3 position;
  glm::vec3 normal;
};
static_assert(sizeof(Vertex) == 24, "Vertex is tightly packed: 2 x vec3");

/// Where a mesh lives in the shared buffers; pass straight to vkCmdDrawIndexed.
struct MeshRange {
  uint32_t firstIndex = 0;
  uint32_t indexCount = 0;
  int32_t vertexOffset = 0;
  uint32_t vertexCount = 0;
};

/// Shared vertex and index buffers with bump allocation. Meshes are uploaded once (blocking
/// staging copy) and live as long as the store.
class MeshStore {
 public:
  /// Creates buffers for up to `maxVertices` vertices and `maxIndices` 32-bit indices.
  MeshStore(Context& ctx, uint32_t maxVertices, uint32_t maxIndices, std::string_view name);

  /// Appends a mesh; indices are relative to the mesh's own first vertex. Throws
  /// std::length_error when the store is full and std::invalid_argument when an index is out of
  /// range of `vertices`.
  MeshRange upload(std::span<const Vertex> vertices, std::span<const uint32_t> indices);

  /// Binds the vertex buffer to binding 0 and the index buffer (UINT32).
  void bind(VkCommandBuffer cmd) const;

  VkBuffer vertexBuffer() const { return vertices_.handle(); }
  VkBuffer indexBuffer() const { return indices_.handle(); }
  uint32_t vertexCount() const { return vertexCount_; }
  uint32_t indexCount() const { return indexCount_; }

  /// The vertex input of Vertex: binding 0, location 0 = position, location 1 = normal.
  static VkVertexInputBindingDescription bindingDescription();
  static std::span<const VkVertexInputAttributeDescription> attributeDescriptions();

 private:
  Context* ctx_;
  Buffer vertices_;
  Buffer indices_;
  uint32_t maxVertices_, maxIndices_;
  uint32_t vertexCount_ = 0, indexCount_ = 0;
};

/// A unit cube centred at the origin (side 1), 24 vertices with face normals, 36 indices.
void makeCube(std::vector<Vertex>& vertices, std::vector<uint32_t>& indices);

/// A UV sphere of unit radius centred at the origin: (rings + 1) x (segments + 1) vertices on the
/// sphere with outward normals (poles and the seam repeated), 6 x rings x segments indices.
void makeSphere(std::vector<Vertex>& vertices, std::vector<uint32_t>& indices, int segments,
                int rings);

}  // namespace engine
