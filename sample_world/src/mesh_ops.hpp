// Internal helpers of the sample world's mesh code (OpenMesh kept out of the public headers).
#pragma once

#include <cstdint>
#include <vector>

#include "sample_world/world.hpp"

namespace world {

/// Builds a mesh from positions and triangles through OpenMesh: OpenMesh's vertex normals
/// (area-weighted face normals), degenerate triangles dropped.
[[nodiscard]] MeshData finishMesh(const std::vector<glm::vec3>& positions,
                                  const std::vector<std::uint32_t>& indices);

/// FNV-1a over raw bytes, continuing from `h`.
[[nodiscard]] std::uint64_t hashBytes(std::uint64_t h, const void* data, std::size_t size) noexcept;

}  // namespace world
