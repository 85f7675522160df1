// The procedural open world: terrain chunks, forests, rocks, buildings, a tower and thin casters
// (poles, fences, power lines), deterministic from a seed. Pure CPU: meshes are built and
// simplified with OpenMesh (normals from OpenMesh, caster LODs from its Decimater and from the
// trees' cones rebuilt with fewer sides); nothing here touches Vulkan.
#pragma once

#include <glm/glm.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "csm/types.hpp"

namespace world {

/// Levels of detail every mesh has: 0 full, 1 and 2 simplified within the error bounds of
/// kLodErrorLadderM, by OpenMesh's Decimater or, for the trees' cones, by rebuilding them with
/// fewer sides (whichever has fewer triangles; both measured against LOD 0).
inline constexpr std::uint32_t kLodCount = 3;

/// An indexed triangle mesh in its own object space (positions and unit normals).
struct MeshData {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;
  std::vector<std::uint32_t> indices;  ///< three per triangle

  [[nodiscard]] std::uint32_t triangleCount() const noexcept {
    return static_cast<std::uint32_t>(indices.size() / 3);
  }
};

/// World-space error bound of each LOD, metres (LOD 0 is the mesh itself): the rungs an asset's
/// simplified LODs are built within, divided by the largest scale it is placed with. With the
/// default 4 x 2048^2 over 400 m the last cascade's texel is about 0.5 m on the forest path, so
/// at RendererOptions::lodMaxErrorTexels 0.5 it admits LOD 1 (0.2 m, margin for a ladder rung
/// below), and LOD 2 (0.8 m) serves cascades of 1.6 m texels (the fly-through's 1500 m) or a
/// budget of 2 texels. Finer rungs buy almost nothing on these meshes: a tree's 12-sided cones
/// cannot lose a side within a few centimetres (the 3.2 m crown loses two within 0.152 m).
inline constexpr std::array<double, kLodCount> kLodErrorLadderM = {0.0, 0.2, 0.8};

/// A mesh with its levels of detail (lods[0] full; lods[1], lods[2] simplified).
struct MeshAsset {
  std::string name;
  std::array<MeshData, kLodCount> lods;
  /// lodErrorM[l]: simplificationErrorM(lods[0], lods[l]) in the asset's metres (0 for LOD 0).
  std::array<float, kLodCount> lodErrorM{};
  /// lodBoundM[l]: the error LOD l was built within, asset metres (0: not simplified).
  std::array<float, kLodCount> lodBoundM{};
  /// Every LOD closed and wound outward (isClosedOutward); false for terrain chunks (open
  /// heightfields, not checked).
  bool closed = false;
};

/// What kind of thing an object is (colour, report statistics).
enum class Kind : std::uint8_t {
  kTerrain,
  kTree,
  kRock,
  kBuilding,
  kTower,
  kPole,
  kFence,
  kCable,
  kUser
};
[[nodiscard]] const char* kindName(Kind kind) noexcept;
inline constexpr std::uint32_t kKindCount = 9;

/// One object placed in the world: model = translate(translationWs) * linear.
struct Object {
  std::uint32_t mesh = 0;  ///< index into World::meshes
  glm::dvec3 translationWs{0.0};
  glm::mat3 linear{1.0f};  ///< rotation times a uniform scale (normals transform with it)
  glm::vec3 color{0.7f};
  Kind kind = Kind::kTree;
  /// Drawn into the shadow maps.
  bool casts = true;
  /// Darkened by shadows in the lit pass (false: always lit, e.g. cables, a glowing marker).
  bool receives = true;
  /// World-space bounds of the placed mesh (LOD 0).
  csm::AabbWs boundsWs{};
  /// Index of the terrain chunk the object stands in.
  std::uint32_t chunk = 0;
};

/// A batch of casting objects of one chunk merged into one mesh per LOD (the shadow pass draws
/// one caster per cluster instead of one per tree: a draw costs far more than its triangles on a
/// CPU rasteriser). Vertices are relative to `originWs`.
struct CasterCluster {
  std::string name;
  glm::dvec3 originWs{0.0};
  /// When >= 0 the cluster draws that mesh asset (a terrain chunk) and `lods` is empty.
  std::int32_t asset = -1;
  std::array<MeshData, kLodCount> lods;
  /// lodErrorM[l]: bound on how far LOD l lies from LOD 0 in world metres (the largest of its
  /// objects' asset errors scaled by their transforms; for a terrain chunk its asset's).
  std::array<float, kLodCount> lodErrorM{};
  csm::AabbWs boundsWs{};
  std::uint32_t objectCount = 0;
  /// A cluster of a chunk's thin casters (its cables, its fence segments, or its poles: one
  /// cluster each, since they differ in width): flagged csm::vk::CasterInstance::thin (widened
  /// in the depth pass) when AppSettings::thinCasters.
  bool thin = false;
  /// A thin cluster's narrowest true width, metres (csm::vk::CasterInstance::thinWidthM):
  /// cables 0.03, fence rails 0.06, poles 0.28 (their tops); 0 for other clusters.
  float thinWidthM = 0.0f;
  /// Every object of the cluster is closed and wound outward at every LOD, none mirrored: its
  /// faces turned away from the light can be culled in the depth pass
  /// (csm::vk::CasterInstance::closed). False for terrain chunks.
  bool closed = false;
};

/// How to generate a world.
struct WorldDesc {
  std::uint64_t seed = 1;
  /// Side of the square terrain, metres (>= 4096).
  double sizeM = 4096.0;
  /// Side of a terrain chunk, metres (a divisor of sizeM).
  double chunkM = 256.0;
  /// Terrain grid cells per chunk side (16: 16 m cells; OpenMesh's Decimater makes the chunk
  /// LODs at about 25 us per collapse, so finer grids cost seconds of start-up).
  std::uint32_t chunkCells = 16;
  /// Side of a caster cluster's cell, metres (a divisor of chunkM, >= 16): trees, rocks,
  /// buildings and thin casters are merged into one mesh per cell and group. Smaller cells let
  /// the near cascades (tens of metres across) cull more of the forest, for more draws and more
  /// CPU culling per frame.
  double clusterM = 64.0;
  std::uint32_t treeCount = 30000;
  std::uint32_t rockCount = 1500;
  std::uint32_t buildingCount = 120;
  /// Where the world's south-west corner at height 0 lies: the same world anywhere (10^7 m).
  glm::dvec3 originWs{-2048.0, 0.0, -2048.0};
  /// Optional user mesh (OBJ, PLY, OFF) placed near the centre, scaled to `userMeshSizeM`.
  std::string userMeshPath;
  double userMeshSizeM = 30.0;
};

/// The generated world.
struct World {
  WorldDesc desc;
  std::vector<MeshAsset> meshes;
  std::vector<Object> objects;
  std::vector<CasterCluster> clusters;
  /// Bounds of everything (receivers and casters).
  csm::AabbWs boundsWs{};
  std::uint32_t chunksPerSide = 0;
  /// Objects per kind.
  std::array<std::uint32_t, kKindCount> kindCounts{};

  /// Terrain height (world y) at world (x, z); clamps to the terrain's edge.
  [[nodiscard]] double heightAt(double xWs, double zWs) const noexcept;
  /// Centre of the world at ground level.
  [[nodiscard]] glm::dvec3 centerWs() const noexcept;
};

/// A load or generation error (the message names the file and the reason).
struct WorldError {
  std::string message;
};

/// Told each step of long work as it starts ("forests", "user mesh: LOD 2 of 3, 2000000
/// triangles to within 0.31 m, try 1"), for progress on a console.
using Progress = std::function<void(const std::string& step)>;

/// Generates the world (or refuses an invalid description / unreadable user mesh). `progress`
/// (optional) is told each section and, for a user mesh, each LOD and decimation try.
[[nodiscard]] std::optional<World> generateWorld(const WorldDesc& desc, WorldError* error,
                                                 const Progress& progress = {});

/// Loads a mesh file through OpenMesh IO (OBJ, PLY, OFF), triangulated, normals from OpenMesh,
/// centred on its base and scaled so that its largest side is `sizeM`. Returns nothing and fills
/// `error` for a missing, empty, truncated or unparsable file, or one without triangles.
[[nodiscard]] std::optional<MeshData> loadMeshFile(const std::string& path, double sizeM,
                                                   WorldError* error);

/// Simplifies `mesh` with OpenMesh's Decimater as far as it goes while the result stays within
/// `maxErrorM` of it: collapses ordered by quadric error, each legal only while the removed
/// vertices stay within the bound of the new surface (ModHausdorffT), no normal turning over 60
/// degrees, no triangle thinner than 1:10, boundary locked. The result's simplificationErrorM
/// (sampled at lodSampleSpacingM) is at most `maxErrorM` and its shadowOutlinesWithin the bound
/// (the tolerance shrinks until both hold; the mesh itself when nothing fits); the error is
/// written to `errorM`. `progress` (optional) is told each try.
[[nodiscard]] MeshData decimateToError(const MeshData& mesh, double maxErrorM,
                                       double* errorM = nullptr, const Progress& progress = {});

/// Geometric error of a simplified mesh, metres in the mesh's space: the larger of the largest
/// distance from `original`'s sample points to `simplified`'s surface and the reverse (a sampled
/// symmetric Hausdorff distance). Samples: vertices, per triangle its centroid, edge midpoints
/// and the points halfway between centroid and corners, and with `sampleSpacingM` > 0 a grid at
/// most that far apart (64 steps per edge at most), so the true distance exceeds the result by
/// at most about the spacing. Bounds how far the simplified silhouette (a shadow's outline)
/// moves, for every light direction.
[[nodiscard]] double simplificationErrorM(const MeshData& original, const MeshData& simplified,
                                          double sampleSpacingM = 0.0);

/// Whether the shadow outlines of `simplified` and `original` (orthographic projections along
/// 48 directions spread over a hemisphere, rasterised at a quarter of the bound, 500 pixels
/// across at most)
/// cover each other within `boundM` plus a pixel: catches what the Hausdorff distance misses,
/// e.g. a thin cylinder flattened into a sheet that casts nothing seen edge-on.
[[nodiscard]] bool shadowOutlinesWithin(const MeshData& original, const MeshData& simplified,
                                        double boundM);

/// True when the mesh is closed and outward: welded by position, every directed edge has exactly
/// one reverse and no duplicate, and its signed volume is positive (counter-clockwise outside).
/// Such a mesh may have its back faces culled.
[[nodiscard]] bool isClosedOutward(const MeshData& mesh);

/// The sample spacing decimateToError measures a LOD built within `maxErrorM` with.
[[nodiscard]] inline double lodSampleSpacingM(double maxErrorM) noexcept {
  return maxErrorM / 4.0;
}

/// 64-bit FNV-1a hash of a mesh's positions, normals and indices (bit patterns).
[[nodiscard]] std::uint64_t meshHash(const MeshData& mesh) noexcept;
/// Hash of a whole world: every mesh LOD, cluster LOD and object placement.
[[nodiscard]] std::uint64_t worldHash(const World& world) noexcept;

/// The world's terrain height field (noise in world-relative coordinates, so it does not depend
/// on originWs): height in metres at (u, v) metres from the world's south-west corner.
[[nodiscard]] double terrainHeight(std::uint64_t seed, double uM, double vM) noexcept;

}  // namespace world
