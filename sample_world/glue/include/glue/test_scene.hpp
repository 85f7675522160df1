// The one test scene of the GPU tests and tools/measure (target csm_test_scene): a static,
// deterministic scene of meshes in object space (CPU copies, so the GPU draws and the ray
// tracers use the very same triangles) placed by double-precision translations, and the receiver
// points the shimmer metrics follow; AnalyticShapes, a plane with spheres and boxes whose rays
// are answered exactly, as such a scene. Pure CPU: no Vulkan (glue/gpu_scene.hpp uploads it).
#pragma once

#include <csm/core.hpp>
#include <engine/mesh_store.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace glue {

/// One mesh in object space.
struct MeshData {
  std::string name;
  std::vector<engine::Vertex> vertices;
  std::vector<uint32_t> indices;
};

/// What an instance is, for receiver sampling and reports.
enum class InstanceKind : uint8_t { kGround, kBuilding, kPole, kSphere };

/// One mesh placed in the world: posWs = translationWs + linearWs * posMs.
struct Instance {
  uint32_t mesh = 0;
  glm::dvec3 translationWs{0.0};
  glm::mat3 linearWs{1.0f};
  glm::vec4 color{0.8f, 0.8f, 0.8f, 1.0f};
  InstanceKind kind = InstanceKind::kGround;
  /// Drawn as a thin caster (csm::vk::CasterInstance::thin: widened in the depth pass).
  bool thin = false;
  /// The mesh is closed and wound outward (csm::vk::CasterInstance::closed: its faces turned
  /// away from the light are culled in the depth pass).
  bool closed = false;
  /// A thin caster's true width where it is narrowest, metres; 0 = not known
  /// (csm::vk::CasterInstance::thinWidthM).
  float thinWidthM = 0.0f;
};

/// A fixed receiver point on a surface (on a triangle of the scene, exactly).
struct Receiver {
  glm::dvec3 posWs{0.0};
  glm::vec3 normalWs{0.0f, 1.0f, 0.0f};
  InstanceKind kind = InstanceKind::kGround;
};

/// How makeTestScene builds the scene.
struct TestSceneDesc {
  /// World position of the scene's local origin (0, 1e6 or 1e7 m away in the tests).
  glm::dvec3 originWs{0.0};
  /// Rolling heightfield terrain (true) or a flat plane (false: only analytic shapes).
  bool terrain = true;
  /// Side of the ground square (m) and cells per side of the terrain grid.
  double groundSideM = 200.0;
  uint32_t terrainCells = 80;
};

/// Meshes, instances and bounds of a static scene.
class Scene {
 public:
  /// A plane or terrain with box buildings, thin poles and floating spheres, laid out ahead of a
  /// camera that looks from local (0, h, +z) toward -z. Deterministic.
  static Scene makeTestScene(const TestSceneDesc& desc);

  Scene() = default;
  /// An empty scene whose local origin (the ray tracers' anchor) is `originWs`: a scene built
  /// by hand 1e7 m from the world origin keeps its rays precise.
  explicit Scene(const glm::dvec3& originWs) : originWs_(originWs) {}

  /// Appends a mesh and returns its index.
  uint32_t addMesh(MeshData mesh);
  /// Appends an instance (its bounds are computed from the mesh's transformed vertices).
  void addInstance(const Instance& instance);
  /// Appends an instance with the given world bounds (exact bounds of an analytic shape).
  void addInstance(const Instance& instance, const csm::AabbWs& boundsWs);

  const std::vector<MeshData>& meshes() const { return meshes_; }
  const std::vector<Instance>& instances() const { return instances_; }
  /// World bounds of instance i and of the whole scene.
  const csm::AabbWs& instanceBounds(size_t i) const { return bounds_[i]; }
  const std::vector<csm::AabbWs>& instanceBounds() const { return bounds_; }
  const csm::AabbWs& boundsWs() const { return sceneBounds_; }
  /// The local origin (ray tracing and receivers are anchored here).
  const glm::dvec3& originWs() const { return originWs_; }
  /// Total triangle count over all instances.
  uint64_t triangleCount() const;

  /// World-space triangle t of instance i (vertex k), in double.
  glm::dvec3 vertexWs(size_t instance, uint32_t index) const;

  /// `count` receivers spread over ground triangles (fraction 1 - wallFraction) and building
  /// walls (vertical faces, fraction wallFraction) whose position lies inside the local box
  /// [regionMin, regionMax] (relative to originWs). Deterministic for a given seed.
  std::vector<Receiver> sampleReceivers(uint32_t count, double wallFraction,
                                        const glm::dvec3& regionMinLocal,
                                        const glm::dvec3& regionMaxLocal, uint32_t seed) const;

  /// A CasterSet with one box per instance (same order as instances()), built.
  csm::CasterSet casterSet() const;

 private:
  glm::dvec3 originWs_{0.0};
  std::vector<MeshData> meshes_;
  std::vector<Instance> instances_;
  std::vector<csm::AabbWs> bounds_;
  csm::AabbWs sceneBounds_{glm::dvec3(0.0), glm::dvec3(0.0)};
};

/// Unit cube (side 1, centred) and UV sphere (radius 1).
MeshData makeCubeMesh();
MeshData makeSphereMesh(int segments, int rings);
/// Ground in the scene's local metres: a square of side `sideM` centred at local (cx, 0, cz),
/// `cells` x `cells` quads, on terrainHeight() (terrain) or at y = 0 (flat).
MeshData makeGroundMesh(bool terrain, double sideM, uint32_t cells, double cxLocal, double czLocal);

/// Height of the test terrain at local (x, z) (0 for the flat ground).
double terrainHeight(double xLocal, double zLocal) noexcept;

struct SphereWs {
  glm::dvec3 centerWs;
  double radiusM;
};

/// The analytic scene: a flat square ground at y = 0 with spheres and boxes (axis-aligned) above
/// it, whose camera and shadow rays are answered exactly in double.
struct AnalyticShapes {
  glm::dvec3 planeCenterWs{0.0, 0.0, -25.0};
  double planeHalfM = 40.0;
  std::vector<SphereWs> spheres;
  std::vector<csm::AabbWs> boxes;

  /// Nearest surface along o + t d (t > 0): t (+inf: none) and whether it is the ground.
  struct RayHit {
    double t = 0.0;
    bool plane = false;
  };
  [[nodiscard]] RayHit intersect(const glm::dvec3& o, const glm::dvec3& d) const;
  /// Whether the ray from `posWs` along `toLight` hits a sphere or a box.
  [[nodiscard]] bool occluded(const glm::dvec3& posWs, const glm::dvec3& toLight) const;

  /// As a Scene: meshes ground (one quad), sphere (`sphereSegments` x `sphereRings`) and cube;
  /// instances the ground, the spheres, the boxes in that order, each with its exact bounds.
  [[nodiscard]] Scene scene(int sphereSegments = 96, int sphereRings = 48) const;
};

}  // namespace glue
