// The sample world as a measurement Scene (see world_scene.hpp). Moved from csm_tradeoff.
#include "csm_measure/world_scene.hpp"

#include <string>

namespace csm_measure {

WorldScene sceneFromWorld(const world::World& w, bool flagThin) {
  WorldScene out;
  Scene& scene = out.scene;
  auto convert = [](const world::MeshData& m, const std::string& name) {
    MeshData out;
    out.name = name;
    out.vertices.reserve(m.positions.size());
    for (size_t i = 0; i < m.positions.size(); ++i) {
      out.vertices.push_back(
          {m.positions[i], i < m.normals.size() ? m.normals[i] : glm::vec3(0, 1, 0)});
    }
    out.indices = m.indices;
    return out;
  };
  // Mesh indices of an asset's LODs, added on first use.
  std::vector<std::vector<uint32_t>> assetMeshes(w.meshes.size());
  auto addLods = [&](const std::array<world::MeshData, world::kLodCount>& lods,
                     const std::string& name) {
    std::vector<uint32_t> meshes;
    for (uint32_t l = 0; l < world::kLodCount; ++l) {
      meshes.push_back(scene.addMesh(convert(lods[l], name + " lod" + std::to_string(l))));
    }
    return meshes;
  };
  for (const world::CasterCluster& c : w.clusters) {
    std::vector<uint32_t> lodMeshes;
    glm::mat3 linear(1.0f);
    glm::dvec3 translation = c.originWs;
    if (c.asset >= 0) {
      const world::MeshAsset& asset = w.meshes[size_t(c.asset)];
      if (assetMeshes[size_t(c.asset)].empty()) {
        assetMeshes[size_t(c.asset)] = addLods(asset.lods, asset.name);
      }
      lodMeshes = assetMeshes[size_t(c.asset)];
      // Terrain chunk assets are placed by the object that uses them.
      for (const world::Object& o : w.objects) {
        if (o.mesh == uint32_t(c.asset)) {
          translation = o.translationWs;
          linear = o.linear;
          break;
        }
      }
    } else {
      if (c.lods[0].indices.empty()) continue;
      lodMeshes = addLods(c.lods, c.name);
    }
    scene.addInstance({lodMeshes[0],
                       translation,
                       linear,
                       {0.6f, 0.65f, 0.5f, 1.0f},
                       c.asset >= 0 ? InstanceKind::kGround : InstanceKind::kBuilding,
                       flagThin && c.thin,
                       c.closed,
                       flagThin && c.thin ? c.thinWidthM : 0.0f});
    out.lodMeshes.push_back(std::move(lodMeshes));
    out.lodErrorM.emplace_back(c.lodErrorM.begin(), c.lodErrorM.end());
  }
  return out;
}

}  // namespace csm_measure
