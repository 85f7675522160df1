#include "engine/mesh_store.hpp"

#include <array>
#include <cmath>
#include <cstddef>
#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>
#include <stdexcept>
#include <string>

#include "engine/context.hpp"

namespace engine {

MeshStore::MeshStore(Context& ctx, uint32_t maxVertices, uint32_t maxIndices, std::string_view name)
    : ctx_(&ctx),
      vertices_(ctx, VkDeviceSize(maxVertices) * sizeof(Vertex),
                VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                    VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                MemoryUsage::DeviceLocal, std::string(name) + ".vertices"),
      indices_(ctx, VkDeviceSize(maxIndices) * sizeof(uint32_t),
               VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                   VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
               MemoryUsage::DeviceLocal, std::string(name) + ".indices"),
      maxVertices_(maxVertices),
      maxIndices_(maxIndices) {}

MeshRange MeshStore::upload(std::span<const Vertex> vertices, std::span<const uint32_t> indices) {
  if (vertices.size() > maxVertices_ - vertexCount_ || indices.size() > maxIndices_ - indexCount_)
    throw std::length_error(
        "MeshStore full: mesh of " + std::to_string(vertices.size()) + " vertices / " +
        std::to_string(indices.size()) + " indices does not fit (" + std::to_string(vertexCount_) +
        "/" + std::to_string(maxVertices_) + " vertices, " + std::to_string(indexCount_) + "/" +
        std::to_string(maxIndices_) + " indices used)");
  for (uint32_t index : indices)
    if (index >= vertices.size())
      throw std::invalid_argument("MeshStore::upload: index " + std::to_string(index) +
                                  " is out of range [0, " + std::to_string(vertices.size()) + ")");
  MeshRange range;
  range.firstIndex = indexCount_;
  range.indexCount = static_cast<uint32_t>(indices.size());
  range.vertexOffset = static_cast<int32_t>(vertexCount_);
  range.vertexCount = static_cast<uint32_t>(vertices.size());
  uploadBuffer(*ctx_, vertices_, VkDeviceSize(vertexCount_) * sizeof(Vertex),
               std::as_bytes(vertices));
  uploadBuffer(*ctx_, indices_, VkDeviceSize(indexCount_) * sizeof(uint32_t),
               std::as_bytes(indices));
  vertexCount_ += range.vertexCount;
  indexCount_ += range.indexCount;
  return range;
}

void MeshStore::bind(VkCommandBuffer cmd) const {
  const VkBuffer buffer = vertices_.handle();
  const VkDeviceSize offset = 0;
  vkCmdBindVertexBuffers(cmd, 0, 1, &buffer, &offset);
  vkCmdBindIndexBuffer(cmd, indices_.handle(), 0, VK_INDEX_TYPE_UINT32);
}

VkVertexInputBindingDescription MeshStore::bindingDescription() {
  return {0, sizeof(Vertex), VK_VERTEX_INPUT_RATE_VERTEX};
}

std::span<const VkVertexInputAttributeDescription> MeshStore::attributeDescriptions() {
  static constexpr std::array<VkVertexInputAttributeDescription, 2> kAttributes{{
      {0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(Vertex, position)},
      {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(Vertex, normal)},
  }};
  return kAttributes;
}

void makeCube(std::vector<Vertex>& vertices, std::vector<uint32_t>& indices) {
  vertices.clear();
  indices.clear();
  // For each face: its normal n and two in-plane axes u, v with u x v = n (counter-clockwise).
  const glm::vec3 normals[6] = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
  for (const glm::vec3& n : normals) {
    const glm::vec3 u = std::abs(n.y) > 0.5f ? glm::vec3(0, 0, n.y) : glm::vec3(-n.z, 0, n.x);
    const glm::vec3 v = glm::cross(n, u);
    const uint32_t base = static_cast<uint32_t>(vertices.size());
    const float s[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (const auto& c : s) vertices.push_back({0.5f * (n + c[0] * u + c[1] * v), n});
    for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) indices.push_back(base + i);
  }
}

void makeSphere(std::vector<Vertex>& vertices, std::vector<uint32_t>& indices, int segments,
                int rings) {
  vertices.clear();
  indices.clear();
  for (int r = 0; r <= rings; ++r) {
    const double phi = glm::pi<double>() * r / rings;
    for (int s = 0; s <= segments; ++s) {
      const double theta = 2.0 * glm::pi<double>() * s / segments;
      const glm::vec3 n(std::sin(phi) * std::cos(theta), std::cos(phi),
                        std::sin(phi) * std::sin(theta));
      vertices.push_back({n, n});
    }
  }
  const uint32_t row = static_cast<uint32_t>(segments + 1);
  for (uint32_t r = 0; r < static_cast<uint32_t>(rings); ++r) {
    for (uint32_t s = 0; s < static_cast<uint32_t>(segments); ++s) {
      const uint32_t a = r * row + s, b = a + row;
      indices.insert(indices.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
  }
}

}  // namespace engine
