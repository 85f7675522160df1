// The procedural world: determinism from the seed, OpenMesh normals, Decimater and cut-cone
// LODs, object flags, mesh files (good and bad), settings validation.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>
#include <string>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>

#include "csm/names.hpp"
#include "sample_world/paths.hpp"
#include "sample_world/settings.hpp"
#include "sample_world/world.hpp"

namespace {

namespace fs = std::filesystem;

const world::World& defaultWorld() {
  static const world::World w = [] {
    world::WorldError e;
    auto r = world::generateWorld(world::WorldDesc{}, &e);
    if (!r) throw std::runtime_error(e.message);
    return std::move(*r);
  }();
  return w;
}

fs::path tempDir() {
  const fs::path d = fs::temp_directory_path() / "csm_sample_world_test";
  fs::create_directories(d);
  return d;
}

std::string writeFile(const std::string& name, const std::string& bytes) {
  const fs::path p = tempDir() / name;
  std::ofstream(p, std::ios::binary) << bytes;
  return p.string();
}

const char* kCubeOff =
    "OFF\n8 6 0\n-1 -1 -1\n1 -1 -1\n1 1 -1\n-1 1 -1\n-1 -1 1\n1 -1 1\n1 1 1\n-1 1 1\n"
    "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 2 3 7 6\n4 1 2 6 5\n4 0 4 7 3\n";

TEST(World, SameSeedGivesIdenticalMeshes) {
  const world::World& a = defaultWorld();
  world::WorldError e;
  const auto b = world::generateWorld(world::WorldDesc{}, &e);
  ASSERT_TRUE(b) << e.message;
  ASSERT_EQ(a.meshes.size(), b->meshes.size());
  for (std::size_t m = 0; m < a.meshes.size(); ++m) {
    for (std::uint32_t l = 0; l < world::kLodCount; ++l) {
      EXPECT_EQ(world::meshHash(a.meshes[m].lods[l]), world::meshHash(b->meshes[m].lods[l]))
          << a.meshes[m].name << " lod " << l;
    }
  }
  EXPECT_EQ(world::worldHash(a), world::worldHash(*b));
}

TEST(World, SameSeedGivesTheRecordedWorldInEveryBuild) {
  // Recorded from the default world (seed 1) of a Release build (GCC 12, Debian 12); a Debug or
  // sanitizer build, or any later build, must generate the same meshes bit for bit. If a
  // deliberate change to the world's generation moves it, record the new value here.
  char hash[32];
  std::snprintf(hash, sizeof hash, "%016llx",
                static_cast<unsigned long long>(world::worldHash(defaultWorld())));
  EXPECT_STREQ(hash, "39ddf3bb5762f45d");
}

TEST(World, OtherSeedGivesOtherWorld) {
  world::WorldDesc d;
  d.seed = 2;
  d.treeCount = 2000;
  world::WorldError e;
  const auto b = world::generateWorld(d, &e);
  ASSERT_TRUE(b) << e.message;
  EXPECT_NE(world::meshHash(defaultWorld().meshes[0].lods[0]),
            world::meshHash(b->meshes[0].lods[0]));
}

TEST(World, HasTheRequiredContent) {
  const world::World& w = defaultWorld();
  const glm::dvec3 size = w.boundsWs.maxWs - w.boundsWs.minWs;
  EXPECT_GE(size.x, 4096.0);
  EXPECT_GE(size.z, 4096.0);
  auto count = [&](world::Kind k) { return w.kindCounts[static_cast<std::size_t>(k)]; };
  EXPECT_GE(count(world::Kind::kTree), 20000u);
  EXPECT_GT(count(world::Kind::kRock), 0u);
  EXPECT_GT(count(world::Kind::kBuilding), 0u);
  EXPECT_EQ(count(world::Kind::kTower), 1u);
  EXPECT_GT(count(world::Kind::kPole), 0u);
  EXPECT_GT(count(world::Kind::kFence), 0u);
  EXPECT_GT(count(world::Kind::kCable), 0u);
  EXPECT_EQ(count(world::Kind::kTerrain), w.chunksPerSide * w.chunksPerSide);
  for (const world::Object& ob : w.objects) {
    // Cables cast but are not darkened; everything else casts and receives.
    EXPECT_EQ(ob.receives, ob.kind != world::Kind::kCable);
    EXPECT_TRUE(ob.casts);
  }
  // The tower is tall.
  for (const world::Object& ob : w.objects) {
    if (ob.kind == world::Kind::kTower) {
      EXPECT_GT(ob.boundsWs.maxWs.y - ob.boundsWs.minWs.y, 150.0);
    }
  }
}

TEST(World, NormalsAreUnitAndLodsSimplify) {
  const world::World& w = defaultWorld();
  std::uint64_t tris[world::kLodCount] = {};
  for (const world::CasterCluster& c : w.clusters) {
    for (std::uint32_t l = 0; l < world::kLodCount; ++l) {
      const world::MeshData& m =
          c.asset >= 0 ? w.meshes[static_cast<std::size_t>(c.asset)].lods[l] : c.lods[l];
      tris[l] += m.triangleCount();
    }
  }
  // Error-bounded LODs (kLodErrorLadderM): fewer triangles at each step, not a fixed fraction.
  EXPECT_LT(tris[1], tris[0]);
  EXPECT_LT(tris[2], tris[1]);
  // Terrain casters are never simplified: a simplified heightfield rises above the real one in
  // every hollow and shadows the ground it stands for.
  for (const world::Object& ob : w.objects) {
    if (ob.kind != world::Kind::kTerrain) continue;
    const world::MeshAsset& a = w.meshes[ob.mesh];
    for (std::uint32_t l = 1; l < world::kLodCount; ++l) {
      ASSERT_EQ(world::meshHash(a.lods[l]), world::meshHash(a.lods[0])) << a.name << " lod " << l;
    }
  }
  for (const world::MeshAsset& a : w.meshes) {
    for (const world::MeshData& m : a.lods) {
      ASSERT_EQ(m.positions.size(), m.normals.size());
      ASSERT_GT(m.indices.size(), 0u) << a.name;
      for (const glm::vec3& n : m.normals) ASSERT_NEAR(glm::length(n), 1.0f, 1e-3f) << a.name;
    }
  }
}

// The simplification error: 0 for the same mesh, the offset for a displaced triangle, the bump
// height for a flat square against one with a raised centre (both directions).
TEST(World, SimplificationErrorIsTheHausdorffDistance) {
  world::MeshData tri;
  tri.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  tri.indices = {0, 1, 2};
  EXPECT_EQ(world::simplificationErrorM(tri, tri), 0.0);
  world::MeshData lifted = tri;
  for (glm::vec3& p : lifted.positions) p.z += 0.25f;
  EXPECT_NEAR(world::simplificationErrorM(tri, lifted), 0.25, 1e-6);
  world::MeshData flat;
  flat.positions = {{-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}};
  flat.indices = {0, 1, 2, 0, 2, 3};
  world::MeshData bump;
  bump.positions = flat.positions;
  bump.positions.push_back({0, 0.5f, 0});
  bump.indices = {0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4};
  EXPECT_NEAR(world::simplificationErrorM(bump, flat), 0.5, 1e-6);
  EXPECT_NEAR(world::simplificationErrorM(flat, bump), 0.5, 1e-6);
}

namespace {

// The closest point of triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5), in
// double: an implementation independent of the module's, for the brute force below.
double distanceToTriangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                          const glm::dvec3& c) {
  const glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return glm::length(p - a);
  const glm::dvec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return glm::length(p - b);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return glm::length(p - (a + ab * (d1 / (d1 - d3))));
  const glm::dvec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return glm::length(p - c);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return glm::length(p - (a + ac * (d2 / (d2 - d6))));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    return glm::length(p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))));
  }
  const double denom = 1.0 / (va + vb + vc);
  return glm::length(p - (a + ab * (vb * denom) + ac * (vc * denom)));
}

// simplificationErrorM's samples of `from` (vertices; per triangle the centroid, edge
// midpoints, centroid-corner midpoints and the barycentric grid at `spacing`), every one
// measured against every triangle of `to`.
double bruteOneSided(const world::MeshData& from, const world::MeshData& to, double spacing) {
  auto distance = [&](const glm::dvec3& p) {
    double best = std::numeric_limits<double>::max();
    for (std::size_t t = 0; t + 2 < to.indices.size(); t += 3) {
      best = std::min(
          best, distanceToTriangle(p, to.positions[to.indices[t]], to.positions[to.indices[t + 1]],
                                   to.positions[to.indices[t + 2]]));
    }
    return best;
  };
  double worst = 0.0;
  for (const glm::vec3& p : from.positions) worst = std::max(worst, distance(p));
  for (std::size_t t = 0; t + 2 < from.indices.size(); t += 3) {
    const glm::dvec3 a = from.positions[from.indices[t]], b = from.positions[from.indices[t + 1]],
                     c = from.positions[from.indices[t + 2]];
    const glm::dvec3 g = (a + b + c) / 3.0;
    for (const glm::dvec3& p : {g, (a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5, (g + a) * 0.5,
                                (g + b) * 0.5, (g + c) * 0.5}) {
      worst = std::max(worst, distance(p));
    }
    const double longest = std::max({glm::length(b - a), glm::length(c - b), glm::length(a - c)});
    const int steps = static_cast<int>(std::min(16.0, std::ceil(longest / spacing)));
    for (int i = 0; i <= steps; ++i) {
      for (int j = 0; i + j <= steps; ++j) {
        worst = std::max(
            worst, distance(a + (b - a) * (double(i) / steps) + (c - a) * (double(j) / steps)));
      }
    }
  }
  return worst;
}

// A height field of n x n quads over [0, size]^2.
world::MeshData heightField(int n, double size, const std::function<double(double, double)>& h) {
  world::MeshData m;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      const double x = size * i / n, z = size * j / n;
      m.positions.push_back(glm::vec3(glm::dvec3(x, h(x, z), z)));
    }
  }
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const auto v = static_cast<std::uint32_t>(j * (n + 1) + i);
      const auto w = static_cast<std::uint32_t>(n + 1);
      m.indices.insert(m.indices.end(), {v, v + w, v + 1, v + 1, v + w, v + w + 1});
    }
  }
  return m;
}

}  // namespace

// The error meter skips a triangle whose centroid's distance plus its reach cannot raise the
// largest distance found: the result must be what measuring every sample gives. A fine bumpy
// field against a coarse flat one and the reverse, and a coarse triangle whose centroid lies on
// the other surface while an edge midpoint is farther from it than anything before (the skip
// without the reach would miss it).
TEST(World, SimplificationErrorEqualsEverySampleMeasured) {
  const world::MeshData fine = heightField(
      36, 4.0, [](double x, double z) { return 0.08 * std::sin(7.0 * x) * std::cos(5.0 * z); });
  const world::MeshData coarse =
      heightField(3, 4.0, [](double x, double z) { return 0.05 * std::sin(2.0 * x + z); });
  for (double spacing : {0.0125, 0.05, 0.4}) {
    const double fineToCoarse = bruteOneSided(fine, coarse, spacing);
    const double coarseToFine = bruteOneSided(coarse, fine, spacing);
    EXPECT_NEAR(world::simplificationErrorM(fine, coarse, spacing),
                std::max(fineToCoarse, coarseToFine), 1e-5)
        << spacing;
    EXPECT_NEAR(world::simplificationErrorM(coarse, fine, spacing),
                std::max(fineToCoarse, coarseToFine), 1e-5)
        << spacing;
  }
  // `to`: a small patch under each corner and the centroid of a 1 m triangle, and patches
  // 0.15 m under a small triangle's corners. The small triangle's corners set the maximum at
  // 0.15 m before the large triangle is measured. Its centroid lies on `to` (0 m) but its edge
  // midpoints are over 0.25 m from every patch: a skip that left out the centroid's reach
  // (0.75 m) would stop at 0.15 m.
  world::MeshData from;
  from.positions = {{5, 0, 5}, {5.01f, 0, 5}, {5, 0, 5.01f}, {0, 0, 0}, {1, 0, 0}, {0, 0, 1}};
  from.indices = {0, 1, 2, 3, 4, 5};
  world::MeshData to;
  auto patch = [&](glm::vec3 c) {
    const auto v = static_cast<std::uint32_t>(to.positions.size());
    to.positions.insert(to.positions.end(),
                        {c + glm::vec3(-0.02f, 0, -0.02f), c + glm::vec3(0.04f, 0, -0.02f),
                         c + glm::vec3(-0.02f, 0, 0.04f)});
    to.indices.insert(to.indices.end(), {v, v + 1, v + 2});
  };
  for (const glm::vec3 c : {glm::vec3(0, 0, 0), glm::vec3(1, 0, 0), glm::vec3(0, 0, 1),
                            glm::vec3(1.0f / 3, 0, 1.0f / 3), glm::vec3(5, -0.15f, 5),
                            glm::vec3(5.01f, -0.15f, 5), glm::vec3(5, -0.15f, 5.01f)}) {
    patch(c);
  }
  const double fromTo = bruteOneSided(from, to, 0.0125);
  EXPECT_GT(fromTo, 0.25);
  EXPECT_NEAR(world::simplificationErrorM(from, to, 0.0125),
              std::max(fromTo, bruteOneSided(to, from, 0.0125)), 1e-5);
}

// isClosedOutward: a cube wound outward is closed, also with every face's corners its own
// vertices (welded by position); wound inward, with a face missing, a face doubled, a degenerate
// triangle or a third face on an edge it is not.
TEST(World, ClosedOutwardNeedsEveryEdgeSharedOnceEachWay) {
  world::MeshData cube;
  cube.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                    {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  cube.indices = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                  3, 7, 6, 3, 6, 2, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6, 5};
  EXPECT_TRUE(world::isClosedOutward(cube));
  world::MeshData split;  // every corner of every triangle its own vertex
  for (std::uint32_t i : cube.indices) {
    split.indices.push_back(static_cast<std::uint32_t>(split.positions.size()));
    split.positions.push_back(cube.positions[i]);
  }
  EXPECT_TRUE(world::isClosedOutward(split));
  world::MeshData inward = cube;
  for (std::size_t t = 0; t < inward.indices.size(); t += 3) {
    std::swap(inward.indices[t + 1], inward.indices[t + 2]);
  }
  EXPECT_FALSE(world::isClosedOutward(inward));
  world::MeshData open = cube;
  open.indices.resize(open.indices.size() - 3);
  EXPECT_FALSE(world::isClosedOutward(open));
  world::MeshData doubled = cube;
  doubled.indices.insert(doubled.indices.end(), {0, 2, 1});
  EXPECT_FALSE(world::isClosedOutward(doubled));
  world::MeshData degenerate = cube;
  degenerate.indices.insert(degenerate.indices.end(), {0, 0, 1});
  EXPECT_FALSE(world::isClosedOutward(degenerate));
  world::MeshData fin = cube;  // a third face on edge 0-1 (and its reverse elsewhere)
  fin.positions.push_back({0.5f, -1.0f, 0.0f});
  fin.indices.insert(fin.indices.end(), {0, 1, 8, 1, 0, 8});
  EXPECT_FALSE(world::isClosedOutward(fin));
  EXPECT_FALSE(world::isClosedOutward(world::MeshData{}));
}

// Every LOD's error is recorded: 0 for terrain (never simplified), positive and growing with the
// LOD for the simplified trees (buildings keep full detail: 0); clusters carry the largest of their
// objects' scaled errors.
TEST(World, LodErrorsAreRecorded) {
  const world::World& w = defaultWorld();
  bool sawTree = false;
  for (const world::MeshAsset& a : w.meshes) {
    EXPECT_EQ(a.lodErrorM[0], 0.0f) << a.name;
    EXPECT_LE(a.lodErrorM[1], a.lodErrorM[2]) << a.name;
    EXPECT_TRUE(std::isfinite(a.lodErrorM[2])) << a.name;
    if (a.name.rfind("terrain", 0) == 0) {
      EXPECT_EQ(a.lodErrorM[2], 0.0f) << a.name;
    }
    if (a.name == "conifer") {
      sawTree = true;
      EXPECT_GT(a.lodErrorM[2], 0.01f);
      std::printf("conifer LOD errors %.3f / %.3f m\n", a.lodErrorM[1], a.lodErrorM[2]);
    }
  }
  EXPECT_TRUE(sawTree);
  for (const world::CasterCluster& c : w.clusters) {
    if (c.asset >= 0) {
      EXPECT_EQ(c.lodErrorM[2], 0.0f) << c.name;
    } else {
      // Buildings are not simplified (error 0); vegetation is.
      if (c.name.rfind("vegetation", 0) == 0) {
        EXPECT_GT(c.lodErrorM[2], 0.0f) << c.name;
      }
      EXPECT_LE(c.lodErrorM[1], c.lodErrorM[2]) << c.name;
      EXPECT_TRUE(std::isfinite(c.lodErrorM[2])) << c.name;
    }
  }
}

// The trees' LODs: their cones rebuilt with fewer sides (or the Decimater's result, whichever
// has fewer triangles) stay within each LOD's bound, measured here at half the build's sample
// spacing (the build's guarantee: the bound plus that spacing), cast the same shadow outlines
// within it, stay closed and outward (so their back faces may still be culled), and have the
// triangle counts of the cut (the Decimater alone gave the conifer 74 / 74, the pine 30 / 26).
TEST(World, TreeLodsAreCutWithinTheirBound) {
  const std::map<std::string, std::array<std::uint32_t, world::kLodCount>> expected = {
      {"conifer", {100, 48, 24}}, {"broadleaf", {112, 92, 56}}, {"pine", {52, 22, 14}}};
  std::size_t seen = 0;
  for (const world::MeshAsset& a : defaultWorld().meshes) {
    const auto it = expected.find(a.name);
    if (it == expected.end()) continue;
    ++seen;
    for (std::uint32_t l = 0; l < world::kLodCount; ++l) {
      const world::MeshData& lod = a.lods[l];
      EXPECT_EQ(lod.triangleCount(), it->second[l]) << a.name << " lod " << l;
      EXPECT_TRUE(world::isClosedOutward(lod)) << a.name << " lod " << l;
      if (l == 0) continue;
      const double bound = a.lodBoundM[l];
      ASSERT_GT(bound, 0.0) << a.name;
      const double spacing = world::lodSampleSpacingM(bound);
      const double e = world::simplificationErrorM(a.lods[0], lod, spacing / 2.0);
      EXPECT_LE(e, bound + spacing) << a.name << " lod " << l;
      EXPECT_LE(a.lodErrorM[l], bound) << a.name << " lod " << l;
      EXPECT_TRUE(world::shadowOutlinesWithin(a.lods[0], lod, bound)) << a.name << " lod " << l;
      std::printf("%s lod %u: %u triangles, error %.3f m (recorded %.3f, bound %.3f)\n",
                  a.name.c_str(), l, lod.triangleCount(), e, a.lodErrorM[l], bound);
    }
  }
  EXPECT_EQ(seen, expected.size());
}

TEST(World, SameFlightAnywhere) {
  // The "far" path is the forest pass with the world 10^7 m away: the same relative poses.
  const world::World& w = defaultWorld();
  world::WorldDesc d;
  d.originWs = world::pathWorldOrigin("far", d.sizeM);
  d.treeCount = 0;
  world::WorldError e;
  const auto far = world::generateWorld(d, &e);
  ASSERT_TRUE(far) << e.message;
  const auto p0 = world::FlightPath::make("forest", w, 60.0);
  const auto p1 = world::FlightPath::make("far", *far, 60.0);
  ASSERT_TRUE(p0 && p1);
  for (double t : {0.0, 0.5, 1.0}) {
    const glm::dvec3 a = p0->at(t).positionWs - w.desc.originWs;
    const glm::dvec3 b = p1->at(t).positionWs - far->desc.originWs;
    EXPECT_NEAR(glm::length(a - b), 0.0, 1e-6);
  }
  EXPECT_GT(p1->at(0.5).positionWs.x, 9.0e6);
}

TEST(World, DayPathMovesTheSunAcrossTheSkyAtItsDayLength) {
  const world::World& w = defaultWorld();
  world::PathClock clock;
  clock.dayLengthS = 1200.0;
  const auto day = world::FlightPath::make("day", w, 60.0, clock);
  const auto forest = world::FlightPath::make("forest", w, 60.0, clock);
  ASSERT_TRUE(day && forest);
  EXPECT_TRUE(day->movesSun());
  EXPECT_FALSE(day->cuts());
  EXPECT_FALSE(forest->sunAt(10.0).has_value()) << "only the day path moves the sun";
  // The camera flies the forest pass.
  for (double t : {0.0, 0.4, 1.0}) {
    EXPECT_EQ(day->at(t, 3.0).positionWs, forest->at(t).positionWs);
  }
  // Mid-morning at the start, then east to west through noon: azimuth rises by 180° over the day
  // length, elevation peaks at noon, never below 2° (the settings' range starts at 1°).
  const world::SunPose s0 = *day->sunAt(0.0);
  EXPECT_NEAR(s0.azimuthDeg, 135.0, 1e-9);
  EXPECT_GT(s0.elevationDeg, 30.0);
  double lastAz = s0.azimuthDeg, noonEl = 0.0;
  for (double sec = 1.0; sec < 900.0; sec += 1.0) {  // 900 s: sunset
    const world::SunPose s = *day->sunAt(sec);
    // A second of a 1200 s day turns the sun 0.15° in azimuth.
    EXPECT_NEAR(s.azimuthDeg - lastAz, 180.0 / 1200.0, 1e-9) << sec;
    lastAz = s.azimuthDeg;
    EXPECT_GE(s.elevationDeg, 2.0);
    EXPECT_LE(s.elevationDeg, 90.0);
    noonEl = std::max(noonEl, s.elevationDeg);
  }
  EXPECT_NEAR(noonEl, 65.0, 1e-3);
  // A shorter day turns it faster, in proportion.
  clock.dayLengthS = 600.0;
  const auto fast = world::FlightPath::make("day", w, 60.0, clock);
  EXPECT_NEAR(fast->sunAt(10.0)->azimuthDeg - fast->sunAt(0.0)->azimuthDeg, 3.0, 1e-9);
}

TEST(World, CutPathJumpsToANewPlaceEveryCutAndDriftsBetween) {
  const world::World& w = defaultWorld();
  world::PathClock clock;
  clock.cutEveryS = 2.0;
  const auto cut = world::FlightPath::make("cut", w, 60.0, clock);
  ASSERT_TRUE(cut);
  EXPECT_TRUE(cut->cuts());
  EXPECT_FALSE(cut->sunAt(1.0).has_value());
  int cuts = 0;
  glm::dvec3 last = cut->at(0.0, 0.0).positionWs;
  for (int frame = 1; frame < 60 * 14; ++frame) {
    const double sec = frame / 60.0;
    const glm::dvec3 p = cut->at(0.0, sec).positionWs;
    const double step = glm::length(p - last);
    if (cut->shotAt(sec) != cut->shotAt((frame - 1) / 60.0)) {
      ++cuts;
      // A cut: hundreds of metres away, nothing in common with the frame before.
      EXPECT_GT(step, 300.0) << "cut at " << sec << " s";
    } else {
      // Between cuts: a slow drift (6 m/s), over the ground.
      EXPECT_LT(step, 0.5) << sec;
    }
    const glm::dvec3 rel = p - w.desc.originWs;
    EXPECT_GT(rel.x, 0.0);
    EXPECT_LT(rel.x, w.desc.sizeM);
    EXPECT_GT(rel.z, 0.0);
    EXPECT_LT(rel.z, w.desc.sizeM);
    EXPECT_GT(p.y, w.heightAt(p.x, p.z));
    last = p;
  }
  EXPECT_EQ(cuts, 6) << "14 s at a cut every 2 s";
  EXPECT_EQ(cut->shotAt(1.99), 0);
  EXPECT_EQ(cut->shotAt(2.0), 1);
  // Along t alone (the tools that fly by t), every place is visited once.
  int shotsByT = 0;
  glm::dvec3 prevT = cut->at(0.0).positionWs;
  for (int i = 1; i <= 600; ++i) {
    const glm::dvec3 p = cut->at(i / 600.0).positionWs;
    if (glm::length(p - prevT) > 100.0) ++shotsByT;
    prevT = p;
  }
  EXPECT_EQ(shotsByT, 5) << "six places, five cuts over t in [0, 1]";
  // A clock outside the settings' ranges makes no path (no division by zero, no endless shots).
  for (const world::PathClock bad : {world::PathClock{1200.0, 0.0}, world::PathClock{0.0, 1.0},
                                     world::PathClock{1200.0, std::nan("")}}) {
    EXPECT_FALSE(world::FlightPath::make("cut", w, 60.0, bad).has_value());
    EXPECT_FALSE(world::FlightPath::make("day", w, 60.0, bad).has_value());
  }
}

TEST(MeshFile, LoadsObjPlyOff) {
  world::WorldError e;
  const auto off = world::loadMeshFile(writeFile("cube.off", kCubeOff), 10.0, &e);
  ASSERT_TRUE(off) << e.message;
  EXPECT_EQ(off->triangleCount(), 12u);
  const auto obj = world::loadMeshFile(
      writeFile("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\n"), 10.0, &e);
  ASSERT_TRUE(obj) << e.message;
  EXPECT_EQ(obj->triangleCount(), 2u);
  const auto ply = world::loadMeshFile(
      writeFile("tri.ply",
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
      10.0, &e);
  ASSERT_TRUE(ply) << e.message;
  EXPECT_EQ(ply->triangleCount(), 1u);
  for (const glm::vec3& n : off->normals) EXPECT_NEAR(glm::length(n), 1.0f, 1e-4f);
}

// The variants real files use: OBJ v/vt/vn tokens, negative indices, quads, comments and ignored
// statements; binary PLY of both byte orders with extra properties and elements; OFF with
// comments, colours and counts on the header line.
TEST(MeshFile, ReadsTheVariantsRealFilesUse) {
  world::WorldError e;
  const auto obj = world::loadMeshFile(
      writeFile("variants.obj",
                "# comment\r\nmtllib a.mtl\r\no thing\r\nv 0 0 0\r\nv 1 0 0 1.0\r\n"
                "v 1 1 0\r\nv 0 1 0 0.5 0.5 0.5\r\nvt 0 0\r\nvn 0 0 1\r\ng g\r\ns off\r\n"
                "usemtl m\r\nf 1/1/1 2/1/1 3//1 4\r\nf -4 -3 -1\r\nl 1 2\r\n"),
      10.0, &e);
  ASSERT_TRUE(obj) << e.message;
  EXPECT_EQ(obj->triangleCount(), 3u);  // the quad fan-triangulated, plus one triangle

  auto binaryPly = [](bool little) {
    std::string h = std::string("ply\nformat ") +
                    (little ? "binary_little_endian" : "binary_big_endian") +
                    " 1.0\ncomment c\nelement vertex 3\nproperty float x\nproperty uchar red\n"
                    "property float y\nproperty double z\nelement face 1\n"
                    "property list uchar int vertex_indices\nproperty int flags\n"
                    "element extra 2\nproperty list ushort short values\nend_header\n";
    auto put = [&](const void* p, std::size_t n) {
      std::string b(static_cast<const char*>(p), n);
      if (!little) std::reverse(b.begin(), b.end());
      h += b;
    };
    const float xy[3][2] = {{0, 0}, {2, 0}, {0, 2}};
    for (const auto& v : xy) {
      const unsigned char red = 7;
      const double z = 0.5;
      put(&v[0], 4);
      put(&red, 1);
      put(&v[1], 4);
      put(&z, 8);
    }
    const unsigned char three = 3;
    put(&three, 1);
    for (std::int32_t i : {0, 1, 2}) put(&i, 4);
    const std::int32_t flags = 9;
    put(&flags, 4);
    for (int k = 0; k < 2; ++k) {
      const std::uint16_t n = 2;
      const std::int16_t a = 1, b = -1;
      put(&n, 2);
      put(&a, 2);
      put(&b, 2);
    }
    return h;
  };
  for (const bool little : {true, false}) {
    const auto ply =
        world::loadMeshFile(writeFile(little ? "le.ply" : "be.ply", binaryPly(little)), 10.0, &e);
    ASSERT_TRUE(ply) << e.message;
    EXPECT_EQ(ply->triangleCount(), 1u);
    // Scaled to 10 m: the 2 m triangle's corners land 10 m apart.
    float maxX = 0.0f;
    for (const glm::vec3& p : ply->positions) maxX = std::max(maxX, p.x);
    EXPECT_NEAR(maxX, 5.0f, 1e-5f);
  }

  const auto off = world::loadMeshFile(
      writeFile("variants.off",
                "COFF 4 2 0\n# comment\n0 0 0 255 0 0 255\n1 0 0 255 0 0 255\n"
                "1 1 0 0 0 0 255\n0 1 0 0 0 0 255  # trailing\n\n4 0 1 2 3 1 2 3\n3 0 2 3\n"),
      10.0, &e);
  ASSERT_TRUE(off) << e.message;
  EXPECT_EQ(off->triangleCount(), 3u);
}

TEST(MeshFile, BadFilesAreRefusedWithTheirReason) {
  struct Case {
    std::string path, reason;
  };
  const std::string cube = kCubeOff;
  std::string garbage(4096, '\0');
  for (std::size_t i = 0; i < garbage.size(); ++i)
    garbage[i] = static_cast<char>((i * 7919u + 13u) % 251u);
  const std::vector<Case> cases = {
      {(tempDir() / "missing.obj").string(), "not found"},
      {writeFile("empty.obj", ""), "empty"},
      {writeFile("truncated.off", cube.substr(0, cube.size() / 2)), "truncated"},
      {writeFile("garbage.ply", garbage), "not a valid PLY"},
      {writeFile("garbage.obj", garbage), "unknown OBJ statement"},
      {writeFile("mesh.stl", "solid x\n"), "unsupported extension"},
  };
  for (const Case& c : cases) {
    world::WorldError e;
    EXPECT_FALSE(world::loadMeshFile(c.path, 10.0, &e)) << c.path;
    EXPECT_NE(e.message.find(c.path), std::string::npos) << e.message;
    EXPECT_NE(e.message.find(c.reason), std::string::npos) << e.message;
  }
}

TEST(Settings, InvalidValuesListWhatIsAllowed) {
  world::AppSettings s;
  EXPECT_FALSE(world::setSetting(s, "shadow.cascades", "3"));
  EXPECT_EQ(s.shadow.cascadeCount, 3u);
  auto err = world::setSetting(s, "shadow.kernel", "box9");
  ASSERT_TRUE(err);
  EXPECT_NE(err->find("tent3"), std::string::npos) << *err;
  err = world::setSetting(s, "shadow.cascades", "9");
  ASSERT_TRUE(err);
  EXPECT_NE(err->find("[1, 8]"), std::string::npos) << *err;
  err = world::setSetting(s, "no.such.key", "1");
  ASSERT_TRUE(err);
  EXPECT_NE(err->find("shadow.resolution"), std::string::npos) << *err;
  ASSERT_FALSE(world::setSetting(s, "shadow.resolution", "1000"));
  err = world::validateSettings(s);
  ASSERT_TRUE(err);
  EXPECT_NE(err->find("power of two"), std::string::npos) << *err;
  EXPECT_FALSE(world::setSetting(s, "lod.cascades", "0,1,2"));
  EXPECT_EQ(s.cascadeLod[5], 2u);
  EXPECT_TRUE(world::setSetting(s, "lod.cascades", "0,3"));
  // LODs by texel error: half a texel by default, the schedule all 0.
  const world::AppSettings defaults;
  EXPECT_EQ(defaults.lodMaxErrorTexels, 0.5f);
  EXPECT_EQ(defaults.cascadeLod[3], 0u);
  EXPECT_FALSE(world::setSetting(s, "lod.maxErrorTexels", "1.5"));
  EXPECT_EQ(s.lodMaxErrorTexels, 1.5f);
  err = world::setSetting(s, "lod.maxErrorTexels", "-1");
  ASSERT_TRUE(err);
  EXPECT_NE(err->find("lod.maxErrorTexels"), std::string::npos) << *err;
  // The day and cut paths' clock.
  EXPECT_FALSE(world::setSetting(s, "day.lengthS", "3600"));
  EXPECT_EQ(s.clock.dayLengthS, 3600.0);
  EXPECT_FALSE(world::setSetting(s, "cut.everyS", "3"));
  EXPECT_EQ(s.clock.cutEveryS, 3.0);
  for (const auto& [key, value] : {std::pair<const char*, const char*>{"day.lengthS", "5"},
                                   {"day.lengthS", "nan"},
                                   {"cut.everyS", "0"},
                                   {"cut.everyS", "1e9"}}) {
    err = world::setSetting(s, key, value);
    ASSERT_TRUE(err) << key << " = " << value;
    EXPECT_NE(err->find(key), std::string::npos) << *err;
    EXPECT_NE(err->find(value), std::string::npos) << *err;
    EXPECT_NE(err->find("seconds"), std::string::npos) << *err;
  }
  EXPECT_EQ(s.clock.dayLengthS, 3600.0);
  EXPECT_EQ(s.clock.cutEveryS, 3.0);
}

// --set preset=NAME: the module's tier on top of the fly-through's own settings (its shadow
// distance, lambda and light steps kept); other settings go on top of it, in a config wherever
// the preset stands; every name round-trips through report.json's settings; bad names are
// refused with every allowed name.
TEST(Settings, PresetsApplyFirstAndRoundTrip) {
  const world::AppSettings defaults;
  for (csm::Preset p : csm::kAllPresets) {
    SCOPED_TRACE(csm::presetName(p));
    world::AppSettings s;
    ASSERT_FALSE(world::setSetting(s, "preset", csm::presetName(p)));
    const csm::PresetConfig c = csm::presetConfig(p, defaults.shadow);
    EXPECT_EQ(s.shadow.cascadeCount, c.settings.cascadeCount);
    EXPECT_EQ(s.shadow.resolution, c.settings.resolution);
    EXPECT_EQ(s.shadow.kernel, c.settings.kernel);
    EXPECT_EQ(s.shadow.shadowDistanceM, defaults.shadow.shadowDistanceM);
    EXPECT_EQ(s.shadow.splitLambda, defaults.shadow.splitLambda);
    EXPECT_EQ(s.shadow.lightStepDeg, defaults.shadow.lightStepDeg);
    EXPECT_FALSE(world::validateSettings(s));
    // report.json's settings, read back as a config, give the same settings.
    const nlohmann::json j = world::settingsJson(s);
    EXPECT_EQ(j["preset"], csm::presetName(p));
    world::AppSettings back;
    ASSERT_FALSE(world::applyConfigText(back, j.dump(), "report"));
    EXPECT_EQ(world::settingsJson(back), j);
  }
  // A config's other keys go on top of its preset, before or after it in the file.
  for (const char* text : {R"({"shadow.cascades": 3, "preset": "ultra"})",
                           R"({"preset": "ultra", "shadow.cascades": 3})"}) {
    world::AppSettings s;
    ASSERT_FALSE(world::applyConfigText(s, text, "config"));
    EXPECT_EQ(s.shadow.cascadeCount, 3u) << text;
    EXPECT_EQ(s.shadow.resolution, 4096u) << text;
    EXPECT_EQ(s.shadow.kernel, csm::PcfKernel::kPcss) << text;
  }
  // The panel's menu: the tier the settings hold now, whether applied by name or not.
  world::AppSettings m;
  EXPECT_EQ(world::matchingPreset(m), csm::Preset::kHigh) << "the defaults are high";
  ASSERT_FALSE(world::setSetting(m, "preset", "low"));
  EXPECT_EQ(world::matchingPreset(m), csm::Preset::kLow);
  ASSERT_FALSE(world::setSetting(m, "shadow.cascades", "3"));
  EXPECT_FALSE(world::matchingPreset(m).has_value()) << "a tier changed by hand is custom";
  ASSERT_FALSE(world::setSetting(m, "shadow.cascades", "4"));
  ASSERT_FALSE(world::setSetting(m, "shadow.resolution", "4096"));
  ASSERT_FALSE(world::setSetting(m, "shadow.kernel", "pcss"));
  EXPECT_EQ(world::matchingPreset(m), csm::Preset::kUltra) << "ultra's choices set one by one";

  world::AppSettings s;
  auto err = world::setSetting(s, "preset", "epic");
  ASSERT_TRUE(err);
  EXPECT_EQ(*err, "preset = 'epic' is invalid: allowed one of low, medium, high, ultra");
  err = world::applyConfigText(s, R"({"preset": 2})", "config");
  ASSERT_TRUE(err);
  EXPECT_NE(err->find("low, medium, high, ultra"), std::string::npos) << *err;
  EXPECT_FALSE(s.preset.has_value());  // nothing applied
}

}  // namespace
