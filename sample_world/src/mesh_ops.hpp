// Internal helpers of the sample world's mesh code (OpenMesh kept out of the public headers).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sample_world/world.hpp"

namespace world {

/// Builds a mesh from positions and triangles through OpenMesh: OpenMesh's vertex normals
/// (area-weighted face normals), degenerate triangles dropped.
[[nodiscard]] MeshData finishMesh(const std::vector<glm::vec3>& positions,
                                  const std::vector<std::uint32_t>& indices);

struct ParsedMesh;

/// Largest absolute coordinate a mesh file may hold, and the smallest largest extent.
inline constexpr double kMaxMeshCoordinate = 1e9;
inline constexpr double kMinMeshExtent = 1e-6;

/// Validates a parsed mesh (coordinates within +-kMaxMeshCoordinate, extent >= kMinMeshExtent),
/// scales it to `sizeM` (largest extent, base centred at the origin), checks every transformed
/// vertex and builds it through OpenMesh. Nothing on failure, with `error` set.
[[nodiscard]] std::optional<MeshData> meshFromParsed(const ParsedMesh& parsed, double sizeM,
                                                     std::string* error);

/// FNV-1a over raw bytes, continuing from `h`.
[[nodiscard]] std::uint64_t hashBytes(std::uint64_t h, const void* data, std::size_t size) noexcept;

}  // namespace world
