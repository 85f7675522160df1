// Caster clusters: casting objects merged per WorldDesc::clusterM cell and group, nothing lost,
// a bad cell size refused by name.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>
#include <tuple>

#include "sample_world/world.hpp"

namespace {

world::World smallWorld(double clusterM) {
  world::WorldDesc d;
  d.treeCount = 3000;
  d.rockCount = 200;
  d.buildingCount = 20;
  d.clusterM = clusterM;
  world::WorldError e;
  std::optional<world::World> w = world::generateWorld(d, &e);
  if (!w) throw std::runtime_error(e.message);
  return std::move(*w);
}

int groupOf(world::Kind k) {
  switch (k) {
    case world::Kind::kTree:
    case world::Kind::kRock:
      return 0;
    case world::Kind::kBuilding:
    case world::Kind::kTower:
    case world::Kind::kUser:
      return 1;
    case world::Kind::kCable:
      return 2;
    case world::Kind::kFence:
      return 3;
    default:
      return 4;
  }
}

// Every casting object lies in the cell of the one cluster of its group there: as many merged
// clusters as occupied (cell, group) pairs, each cluster's origin on the cell grid and its LOD 0
// holding exactly the triangles of its cell's objects.
void expectClusteredPerCell(const world::World& w) {
  const double cell = w.desc.clusterM;
  std::map<std::tuple<long, long, int>, std::uint64_t> triangles;  // (cx, cz, group) -> LOD 0
  std::uint32_t terrain = 0;
  for (const world::Object& ob : w.objects) {
    if (!ob.casts) continue;
    if (ob.kind == world::Kind::kTerrain) {
      ++terrain;
      continue;
    }
    const auto cx = long(std::floor((ob.translationWs.x - w.desc.originWs.x) / cell));
    const auto cz = long(std::floor((ob.translationWs.z - w.desc.originWs.z) / cell));
    triangles[{cx, cz, groupOf(ob.kind)}] += w.meshes[ob.mesh].lods[0].triangleCount();
  }
  std::set<std::tuple<long, long, int>> seen;
  std::uint32_t merged = 0;
  for (const world::CasterCluster& c : w.clusters) {
    if (c.asset >= 0) continue;
    ++merged;
    const double fx = (c.originWs.x - w.desc.originWs.x) / cell;
    const double fz = (c.originWs.z - w.desc.originWs.z) / cell;
    EXPECT_EQ(fx, std::round(fx)) << c.name;
    EXPECT_EQ(fz, std::round(fz)) << c.name;
    // The group from the cluster's name (vegetation, buildings, thin cables, fences, poles).
    const int g = c.name.rfind("vegetation", 0) == 0    ? 0
                  : c.name.rfind("buildings", 0) == 0   ? 1
                  : c.name.rfind("thin cables", 0) == 0 ? 2
                  : c.name.rfind("thin fences", 0) == 0 ? 3
                                                        : 4;
    EXPECT_EQ(c.thin, g >= 2) << c.name;
    EXPECT_EQ(c.thinWidthM > 0.0f, g >= 2) << c.name;
    const std::tuple<long, long, int> key{long(std::lround(fx)), long(std::lround(fz)), g};
    EXPECT_TRUE(seen.insert(key).second) << "two clusters for " << c.name;
    auto it = triangles.find(key);
    ASSERT_NE(it, triangles.end()) << c.name << " has no objects in its cell";
    EXPECT_EQ(c.lods[0].triangleCount(), it->second) << c.name;
  }
  EXPECT_EQ(merged, triangles.size());
  EXPECT_EQ(w.clusters.size(), merged + terrain);
}

}  // namespace

TEST(Clusters, CastersAreMergedPerCellAndGroup) {
  const world::World w64 = smallWorld(64.0);
  expectClusteredPerCell(w64);
  const world::World w256 = smallWorld(256.0);
  expectClusteredPerCell(w256);
  // Finer cells: more clusters, the same objects and triangles.
  EXPECT_GT(w64.clusters.size(), 2 * w256.clusters.size());
  auto total = [](const world::World& w) {
    std::uint64_t t = 0;
    for (const world::CasterCluster& c : w.clusters) t += c.lods[0].triangleCount();
    return t;
  };
  EXPECT_EQ(total(w64), total(w256));
  std::printf("clusters: %zu at 64 m cells, %zu at 256 m\n", w64.clusters.size(),
              w256.clusters.size());
}

TEST(Clusters, BadCellSizeIsRefusedByName) {
  for (double bad : {0.0, -64.0, 8.0, 48.0, 512.0, std::nan("")}) {
    world::WorldDesc d;
    d.clusterM = bad;
    world::WorldError e;
    EXPECT_FALSE(world::generateWorld(d, &e).has_value()) << bad;
    EXPECT_NE(e.message.find("world.clusterM"), std::string::npos) << e.message;
    EXPECT_NE(e.message.find("divide"), std::string::npos) << e.message;
  }
}
