// The sample world (sample_world/) as a measurement Scene, for the tools and tests that measure on
// it (csm_tradeoff, the soft-shadow test).
#pragma once

#include <sample_world/world.hpp>

#include <cstdint>
#include <vector>

#include "csm_measure/scene.hpp"

namespace csm_measure {

/// The sample world's caster clusters (terrain chunks and merged objects) as a measurement scene:
/// instances of the full-detail meshes (LOD 0), the same triangles for the rasteriser's receivers
/// and the ray tracer. The simplified LODs are extra meshes no instance uses: `lodMeshes[i][l]` is
/// the mesh of instance i at LOD l, for Harness::setCasterLods.
struct WorldScene {
  Scene scene;
  std::vector<std::vector<uint32_t>> lodMeshes;
  /// lodErrorM[i][l]: the world's recorded geometric error of instance i's LOD l, metres.
  std::vector<std::vector<float>> lodErrorM;
};

/// `flagThin`: the world's thin clusters (cables, fence segments, poles: CasterCluster::thin) are
/// flagged Instance::thin, as the fly-through flags them by default (off here unless asked, so
/// that the tools' measurements stay comparable with earlier runs).
WorldScene sceneFromWorld(const world::World& w, bool flagThin = false);

}  // namespace csm_measure
