// The sample world as the world-based stability tests build it: its terrain, paths, town, power
// line and fences as the fly-through places them, with fewer trees, rocks and buildings
// (start-up time).
#pragma once

#include <sample_world/world.hpp>

#include <optional>

namespace csm_stability {

/// The sample world with 3000 trees, 400 rocks and 40 buildings; nothing (and `err` says why)
/// when it cannot be generated.
inline std::optional<world::World> smallSampleWorld(world::WorldError* err) {
  world::WorldDesc wd;
  wd.treeCount = 3000;
  wd.rockCount = 400;
  wd.buildingCount = 40;
  return world::generateWorld(wd, err);
}

}  // namespace csm_stability
