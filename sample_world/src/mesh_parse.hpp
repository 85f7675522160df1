// Bounded readers for the mesh files --mesh accepts (OBJ, PLY ascii/binary, OFF), written so
// that no input can crash them or make them allocate more than the file's size justifies:
// every count is checked against the bytes left before anything is reserved, lines are bounded,
// every index is checked against the vertex count, every number must parse completely. Pure
// C++ (no OpenMesh, no Vulkan): the fuzz harnesses link it alone.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace world {

/// What a mesh file holds: positions (as written, not yet validated for range) and triangles
/// (polygons fan-triangulated; every index < positions.size()).
struct ParsedMesh {
  std::vector<double> xyz;  // 3 per vertex
  std::vector<std::uint32_t> triangles;
  [[nodiscard]] std::size_t vertexCount() const noexcept { return xyz.size() / 3; }
};

/// Limits of the readers (a refused file names the limit).
inline constexpr std::size_t kMaxMeshFileBytes = 256u << 20;
inline constexpr std::size_t kMaxMeshLineBytes = 64u << 10;
inline constexpr std::size_t kMaxMeshVertices = 4'000'000;
inline constexpr std::size_t kMaxMeshTriangles = 8'000'000;
inline constexpr std::size_t kMaxFaceVertices = 1024;
inline constexpr std::size_t kMaxPlyHeaderLines = 1000;

/// Parses `data` as `format` ("obj", "ply" or "off"). On failure returns nothing and sets
/// `error` to what is wrong (line or element, the value, what is allowed).
[[nodiscard]] std::optional<ParsedMesh> parseMeshBytes(std::string_view data,
                                                       std::string_view format, std::string* error);

}  // namespace world
