// Error-bounded caster LODs (issue 14): every LOD of the world within the bound it was built
// for, measured both ways; no connected piece larger than the bound lost; the shadow outline of
// each tree, projected along several light directions, within the bound of the full mesh's
// (PNG strips under the build tree for looking at); the per-cascade choice on the forest path.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numeric>
#include <string>
#include <vector>

#include "csm/cascades.hpp"
#include "csm/vulkan/shadow_renderer.hpp"
#include "engine/image_io.hpp"
#include "sample_world/paths.hpp"
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

// A UV sphere of `rings` x `segments` (closed), centred at c.
void addSphere(world::MeshData& m, const glm::vec3& c, float r, int rings, int segments) {
  const auto base = static_cast<std::uint32_t>(m.positions.size());
  m.positions.push_back(c + glm::vec3(0, r, 0));
  for (int i = 1; i < rings; ++i) {
    const double th = 3.14159265358979 * i / rings;
    for (int j = 0; j < segments; ++j) {
      const double ph = 2.0 * 3.14159265358979 * j / segments;
      m.positions.push_back(c + r * glm::vec3(float(std::sin(th) * std::cos(ph)),
                                              float(std::cos(th)),
                                              float(std::sin(th) * std::sin(ph))));
    }
  }
  m.positions.push_back(c - glm::vec3(0, r, 0));
  const auto south = static_cast<std::uint32_t>(m.positions.size() - 1);
  auto at = [&](int i, int j) {
    return base + 1 + static_cast<std::uint32_t>((i - 1) * segments + (j % segments));
  };
  for (int j = 0; j < segments; ++j) {
    m.indices.insert(m.indices.end(), {base, at(1, j + 1), at(1, j)});
    m.indices.insert(m.indices.end(), {south, at(rings - 1, j), at(rings - 1, j + 1)});
    for (int i = 1; i + 1 < rings; ++i) {
      m.indices.insert(m.indices.end(), {at(i, j), at(i, j + 1), at(i + 1, j + 1)});
      m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j + 1), at(i + 1, j)});
    }
  }
  m.normals.assign(m.positions.size(), glm::vec3(0, 1, 0));
}

// Connected pieces (triangles sharing a vertex position), as bounding boxes.
struct Piece {
  glm::vec3 lo{1e30f}, hi{-1e30f};
  [[nodiscard]] float diagonal() const { return glm::length(hi - lo); }
};
std::vector<Piece> pieces(const world::MeshData& m) {
  // Union-find over vertices; vertices at the same position are one.
  std::vector<std::uint32_t> parent(m.positions.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  auto unite = [&](std::uint32_t a, std::uint32_t b) { parent[find(a)] = find(b); };
  std::vector<std::uint32_t> order(m.positions.size());
  std::iota(order.begin(), order.end(), 0u);
  auto less = [&](std::uint32_t a, std::uint32_t b) {
    const glm::vec3 &p = m.positions[a], &q = m.positions[b];
    return std::tie(p.x, p.y, p.z) < std::tie(q.x, q.y, q.z);
  };
  std::sort(order.begin(), order.end(), less);
  for (std::size_t k = 1; k < order.size(); ++k) {
    if (m.positions[order[k]] == m.positions[order[k - 1]]) unite(order[k], order[k - 1]);
  }
  for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    unite(m.indices[t], m.indices[t + 1]);
    unite(m.indices[t], m.indices[t + 2]);
  }
  std::vector<std::int64_t> pieceOf(m.positions.size(), -1);
  std::vector<Piece> out;
  for (std::uint32_t idx : m.indices) {
    const std::uint32_t r = find(idx);
    if (pieceOf[r] < 0) {
      pieceOf[r] = static_cast<std::int64_t>(out.size());
      out.emplace_back();
    }
    Piece& p = out[static_cast<std::size_t>(pieceOf[r])];
    p.lo = glm::min(p.lo, m.positions[idx]);
    p.hi = glm::max(p.hi, m.positions[idx]);
  }
  return out;
}

// Pieces of `full` larger than `boundM` that no piece of `lod` matches (every box face within
// boundM of the full piece's).
int lostPieces(const world::MeshData& full, const world::MeshData& lod, float boundM) {
  const std::vector<Piece> lodPieces = pieces(lod);
  int lost = 0;
  for (const Piece& p : pieces(full)) {
    if (p.diagonal() <= boundM) continue;
    const bool kept = std::any_of(lodPieces.begin(), lodPieces.end(), [&](const Piece& q) {
      const glm::vec3 d = glm::max(glm::abs(q.lo - p.lo), glm::abs(q.hi - p.hi));
      return std::max({d.x, d.y, d.z}) <= boundM * 1.0001f;
    });
    if (!kept) ++lost;
  }
  return lost;
}

// The mesh's shadow outline along `lightDir`: a coverage mask over the light-space square
// [lo, lo + n * pixel)^2 (orthographic, every triangle, no culling, as the depth pass draws).
struct Mask {
  int n = 0;
  std::vector<std::uint8_t> on;
};
Mask shadowMask(const world::MeshData& m, const glm::vec3& lightDir, const glm::vec2& lo,
                float pixel, int n) {
  const glm::vec3 w = glm::normalize(lightDir);
  const glm::vec3 u = glm::normalize(std::abs(w.y) > 0.99f ? glm::cross(glm::vec3(1, 0, 0), w)
                                                           : glm::cross(glm::vec3(0, 1, 0), w));
  const glm::vec3 v = glm::cross(w, u);
  Mask mask{n, std::vector<std::uint8_t>(static_cast<std::size_t>(n) * n, 0)};
  for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    glm::vec2 p[3];
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 x = m.positions[m.indices[t + k]];
      p[k] = (glm::vec2(glm::dot(x, u), glm::dot(x, v)) - lo) / pixel;
    }
    const float area =
        (p[1].x - p[0].x) * (p[2].y - p[0].y) - (p[1].y - p[0].y) * (p[2].x - p[0].x);
    if (std::abs(area) < 1e-12f) continue;  // edge-on: the depth pass draws nothing either
    const glm::vec2 bmin = glm::min(p[0], glm::min(p[1], p[2]));
    const glm::vec2 bmax = glm::max(p[0], glm::max(p[1], p[2]));
    // Conservative: a pixel is covered when the triangle overlaps its square (no separating
    // edge normal), so a sliver thinner than a pixel still draws a continuous line and the check
    // compares geometry, not sampling luck.
    for (int y = std::max(0, int(std::floor(bmin.y))); y <= std::min(n - 1, int(bmax.y)); ++y) {
      for (int x = std::max(0, int(std::floor(bmin.x))); x <= std::min(n - 1, int(bmax.x)); ++x) {
        bool separated = false;
        for (int k = 0; k < 3 && !separated; ++k) {
          const glm::vec2 a = p[k], b = p[(k + 1) % 3], c = p[(k + 2) % 3];
          const glm::vec2 nrm(-(b.y - a.y), b.x - a.x);
          const float side = glm::dot(nrm, c - a);
          float best = -1e30f;  // the square corner farthest toward the triangle's side
          for (const glm::vec2& q : {glm::vec2(x, y), glm::vec2(x + 1, y), glm::vec2(x, y + 1),
                                     glm::vec2(x + 1, y + 1)}) {
            best = std::max(best, glm::dot(nrm, q - a) * (side >= 0.0f ? 1.0f : -1.0f));
          }
          separated = best < 0.0f;
        }
        if (!separated) mask.on[static_cast<std::size_t>(y) * n + x] = 1;
      }
    }
  }
  return mask;
}

// Pixels of `a` farther than `radius` pixels from every pixel of `b`.
int outside(const Mask& a, const Mask& b, int radius) {
  int count = 0;
  for (int y = 0; y < a.n; ++y) {
    for (int x = 0; x < a.n; ++x) {
      if (!a.on[static_cast<std::size_t>(y) * a.n + x]) continue;
      bool near = false;
      for (int dy = -radius; dy <= radius && !near; ++dy) {
        for (int dx = -radius; dx <= radius && !near; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (dx * dx + dy * dy > radius * radius || xx < 0 || yy < 0 || xx >= b.n || yy >= b.n) {
            continue;
          }
          near = b.on[static_cast<std::size_t>(yy) * b.n + xx] != 0;
        }
      }
      if (!near) ++count;
    }
  }
  return count;
}

int area(const Mask& m) {
  return static_cast<int>(std::count(m.on.begin(), m.on.end(), std::uint8_t{1}));
}

fs::path outDir() {
  const fs::path d = fs::current_path() / "lod_shadows";
  fs::create_directories(d);
  return d;
}

}  // namespace

// decimateToError on a finely tessellated sphere: the measured error stays within each bound,
// larger bounds give fewer triangles, and the sphere neither vanishes nor shrinks past the bound.
TEST(Lod, DecimateToErrorKeepsTheBound) {
  world::MeshData sphere;
  addSphere(sphere, {0, 0, 0}, 1.0f, 24, 48);
  std::uint32_t previous = sphere.triangleCount();
  for (double bound : {0.005, 0.02, 0.05, 0.2}) {
    double measured = -1.0;
    const world::MeshData lod = world::decimateToError(sphere, bound, &measured);
    EXPECT_LE(measured, bound);
    EXPECT_NEAR(world::simplificationErrorM(sphere, lod, world::lodSampleSpacingM(bound)), measured,
                1e-6);
    EXPECT_TRUE(world::shadowOutlinesWithin(sphere, lod, bound));
    EXPECT_LE(lod.triangleCount(), previous) << bound;
    previous = lod.triangleCount();
    const std::vector<Piece> p = pieces(lod);
    ASSERT_EQ(p.size(), 1u);
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(p[0].hi[k], 1.0f - float(bound) - 1e-4f) << bound;
      EXPECT_LE(p[0].lo[k], -1.0f + float(bound) + 1e-4f) << bound;
    }
    std::printf("sphere 1 m, bound %.3f m: %u -> %u triangles, measured %.4f m\n", bound,
                sphere.triangleCount(), lod.triangleCount(), measured);
  }
  EXPECT_LT(previous, sphere.triangleCount() / 4);  // the coarsest bound simplifies a lot
  // No bound (0, negative, NaN): the mesh itself, error 0.
  for (double bad : {0.0, -1.0, std::nan("")}) {
    double measured = -1.0;
    EXPECT_EQ(world::decimateToError(sphere, bad, &measured).triangleCount(),
              sphere.triangleCount());
    EXPECT_EQ(measured, 0.0);
  }
}

// A large bumpy mesh (about 100k triangles, bumps of many sizes, as a scanned or sculpted --mesh
// is): each LOD decimateToError makes for the world's bounds (5 m mesh) records the error it
// measured, lies within its bound re-measured both ways and along the 48 shadow outlines, is
// still closed and outward (the Decimater's own collapse test keeps it manifold), and
// simplifies.
TEST(Lod, LargeBumpyMeshKeepsEveryBound) {
  world::MeshData sphere;
  addSphere(sphere, {0, 0, 0}, 2.5f, 160, 320);
  for (glm::vec3& p : sphere.positions) {
    const glm::vec3 d = glm::normalize(p);
    float r = 2.5f;
    for (int k = 0; k < 6; ++k) {
      const float f = 1.5f * float(1 << k);
      r += 0.12f / float(1 << k) * std::sin(f * d.x + 2.1f * k) * std::cos(f * d.z - 1.3f * k) *
           std::sin(f * d.y + 0.7f * k);
    }
    p = d * r;
  }
  ASSERT_TRUE(world::isClosedOutward(sphere));
  for (double bound : {world::kLodErrorLadderM[1] / 4.0, world::kLodErrorLadderM[2] / 4.0}) {
    double measured = -1.0;
    const world::MeshData lod = world::decimateToError(sphere, bound, &measured);
    EXPECT_GT(measured, 0.0) << bound;
    EXPECT_LE(measured, bound) << bound;
    EXPECT_NEAR(world::simplificationErrorM(sphere, lod, world::lodSampleSpacingM(bound)), measured,
                1e-6)
        << bound;
    EXPECT_LE(world::simplificationErrorM(sphere, lod, world::lodSampleSpacingM(bound) / 2.0),
              bound * 1.05)
        << bound;
    EXPECT_TRUE(world::shadowOutlinesWithin(sphere, lod, bound)) << bound;
    EXPECT_TRUE(world::isClosedOutward(lod)) << bound;
    EXPECT_LT(lod.triangleCount(), sphere.triangleCount() / 10) << bound;
    std::printf("bumpy sphere 5 m, bound %.3f m: %u -> %u triangles, measured %.4f m\n", bound,
                sphere.triangleCount(), lod.triangleCount(), measured);
  }
}

// A small piece beside a big one: above the bound it stays (matched within the bound), at any
// bound it is never moved by more than the bound.
TEST(Lod, SmallPiecesLargerThanTheBoundSurvive) {
  world::MeshData m;
  addSphere(m, {0, 0, 0}, 2.0f, 16, 32);
  addSphere(m, {3.0f, 0, 0}, 0.08f, 8, 16);  // 0.28 m across
  for (double bound : {0.02, 0.1, 0.3}) {
    double measured = 0.0;
    const world::MeshData lod = world::decimateToError(m, bound, &measured);
    EXPECT_LE(measured, bound);
    EXPECT_EQ(lostPieces(m, lod, float(bound)), 0) << bound;
  }
  // The check itself fails when the small sphere is dropped.
  world::MeshData big;
  addSphere(big, {0, 0, 0}, 2.0f, 16, 32);
  EXPECT_EQ(lostPieces(m, big, 0.1f), 1);
  EXPECT_GT(world::simplificationErrorM(m, big), 0.9);
}

// Every simplified LOD of the world: measured error (sampled symmetric Hausdorff distance to
// LOD 0) recorded, within the bound it was built for, and no piece larger than the bound lost;
// clusters within the world-space ladder.
TEST(Lod, WorldLodsWithinTheirBounds) {
  const world::World& w = defaultWorld();
  int simplified = 0;
  for (const world::MeshAsset& a : w.meshes) {
    for (std::uint32_t l = 1; l < world::kLodCount; ++l) {
      const float bound = a.lodBoundM[l];
      if (bound == 0.0f) {
        EXPECT_EQ(a.lodErrorM[l], 0.0f) << a.name;
        continue;
      }
      // Re-measured as densely as the world measured it (0 recorded for an unchanged mesh).
      const double measured =
          world::simplificationErrorM(a.lods[0], a.lods[l], world::lodSampleSpacingM(bound));
      EXPECT_LE(measured, double(a.lodErrorM[l]) + 1e-4) << a.name << " lod " << l;
      EXPECT_LE(a.lodErrorM[l], bound) << a.name << " lod " << l;
      EXPECT_EQ(lostPieces(a.lods[0], a.lods[l], bound), 0) << a.name << " lod " << l;
      EXPECT_LE(a.lods[l].triangleCount(), a.lods[l - 1].triangleCount()) << a.name;
      if (a.lods[l].triangleCount() < a.lods[0].triangleCount()) ++simplified;
      if (a.name.rfind("terrain", 0) != 0 && a.name.rfind("building", 0) != 0) {
        std::printf("%-10s lod %u: %4u -> %4u triangles, error %.4f m (bound %.4f m)\n",
                    a.name.c_str(), l, a.lods[0].triangleCount(), a.lods[l].triangleCount(),
                    double(a.lodErrorM[l]), double(bound));
      }
    }
  }
  EXPECT_GT(simplified, 0);
  for (const world::CasterCluster& c : w.clusters) {
    for (std::uint32_t l = 1; l < world::kLodCount; ++l) {
      EXPECT_LE(double(c.lodErrorM[l]), world::kLodErrorLadderM[l] * (1.0 + 1e-5)) << c.name;
    }
  }
}

// The shadow outline of each simplified asset, projected along five light directions (straight
// down, the sweep's sun, a low sun, grazing, along x): every pixel one outline covers lies within
// the LOD's bound (plus one pixel of rasterisation) of the other outline, both ways, so no branch
// is lost and nothing shrinks or grows past the bound. (A part thinner than twice the bound may
// thin within it: the pole's LOD 2 trunk is narrower.) A PNG strip per asset and light shows
// LOD 0, 1, 2 (grey: both; red: only LOD 0, lost; blue: only the LOD, grown).
TEST(Lod, ShadowOutlinesWithinTheBound) {
  const std::vector<glm::vec3> lights = {{0.0f, -1.0f, 0.0f},
                                         {0.45f, -0.8f, -0.35f},
                                         {0.8f, -0.35f, 0.4f},
                                         {0.2f, -0.05f, 1.0f},
                                         {1.0f, 0.0f, 0.0f}};
  const fs::path dir = outDir();
  int checked = 0;
  for (const world::MeshAsset& a : defaultWorld().meshes) {
    if (a.lodBoundM[world::kLodCount - 1] == 0.0f) continue;
    for (std::size_t li = 0; li < lights.size(); ++li) {
      const glm::vec3 w = glm::normalize(lights[li]);
      const glm::vec3 u = glm::normalize(std::abs(w.y) > 0.99f ? glm::cross(glm::vec3(1, 0, 0), w)
                                                               : glm::cross(glm::vec3(0, 1, 0), w));
      const glm::vec3 v = glm::cross(w, u);
      glm::vec2 lo(1e30f), hi(-1e30f);
      for (const glm::vec3& p : a.lods[0].positions) {
        const glm::vec2 q(glm::dot(p, u), glm::dot(p, v));
        lo = glm::min(lo, q);
        hi = glm::max(hi, q);
      }
      for (std::uint32_t l = 1; l < world::kLodCount; ++l) {
        const float bound = a.lodBoundM[l];
        const float pixel = bound / 3.0f;
        const int n = static_cast<int>(std::ceil(std::max(hi.x - lo.x, hi.y - lo.y) / pixel)) + 8;
        ASSERT_LE(n, 4096) << a.name;
        const glm::vec2 origin = lo - 4.0f * pixel;
        const Mask full = shadowMask(a.lods[0], w, origin, pixel, n);
        const Mask lod = shadowMask(a.lods[l], w, origin, pixel, n);
        const int lost = outside(full, lod, 4), grown = outside(lod, full, 4);
        EXPECT_EQ(lost, 0) << a.name << " lod " << l << " light " << li;
        EXPECT_EQ(grown, 0) << a.name << " lod " << l << " light " << li;
        EXPECT_GT(area(lod), area(full) / 2) << a.name << " lod " << l << " light " << li;
        ++checked;
      }
      if (li != 1 || (a.name.rfind("rock", 0) == 0 && a.name != "rock 0")) continue;
      // The strip: 256 pixels per metre-scaled panel, LOD 0 | 1 | 2 side by side.
      const int n = 256;
      const float pixel = std::max(hi.x - lo.x, hi.y - lo.y) * 1.05f / n;
      const glm::vec2 origin = 0.5f * (lo + hi) - 0.5f * pixel * float(n);
      const Mask full = shadowMask(a.lods[0], w, origin, pixel, n);
      engine::CpuImage img;
      img.width = n * world::kLodCount;
      img.height = n;
      img.rgba.assign(std::size_t(img.width) * n * 4, 255);
      for (std::uint32_t l = 0; l < world::kLodCount; ++l) {
        const Mask m = shadowMask(a.lods[l], w, origin, pixel, n);
        for (int y = 0; y < n; ++y) {
          for (int x = 0; x < n; ++x) {
            const std::size_t s = std::size_t(y) * n + x;
            const std::size_t d = (std::size_t(n - 1 - y) * img.width + l * n + x) * 4;
            const bool f = full.on[s] != 0, o = m.on[s] != 0;
            const std::array<std::uint8_t, 3> c = f && o ? std::array<std::uint8_t, 3>{90, 90, 90}
                                                  : f    ? std::array<std::uint8_t, 3>{230, 30, 30}
                                                  : o    ? std::array<std::uint8_t, 3>{30, 60, 230}
                                                      : std::array<std::uint8_t, 3>{255, 255, 255};
            img.rgba[d] = c[0];
            img.rgba[d + 1] = c[1];
            img.rgba[d + 2] = c[2];
          }
        }
      }
      std::string name = a.name;
      std::replace(name.begin(), name.end(), ' ', '_');
      EXPECT_TRUE(engine::writePng((dir / (name + "_sun.png")).string(), img));
    }
  }
  EXPECT_GT(checked, 20);
  // The check fails for a tree that lost a part: the conifer without its top cone.
  for (const world::MeshAsset& a : defaultWorld().meshes) {
    if (a.name != "conifer") continue;
    world::MeshData cut = a.lods[0];
    float top = -1e30f;
    for (const glm::vec3& p : cut.positions) top = std::max(top, p.y);
    std::vector<std::uint32_t> kept;
    for (std::size_t t = 0; t + 2 < cut.indices.size(); t += 3) {
      const float y =
          std::max({cut.positions[cut.indices[t]].y, cut.positions[cut.indices[t + 1]].y,
                    cut.positions[cut.indices[t + 2]].y});
      if (y < top - 4.0f)
        kept.insert(kept.end(), cut.indices.begin() + long(t), cut.indices.begin() + long(t) + 3);
    }
    cut.indices = kept;
    const float pixel = 0.05f;
    const Mask full = shadowMask(a.lods[0], lights[1], glm::vec2(-20.0f), pixel, 800);
    const Mask lod = shadowMask(cut, lights[1], glm::vec2(-20.0f), pixel, 800);
    EXPECT_GT(outside(full, lod, 4), 100);
    EXPECT_FALSE(world::shadowOutlinesWithin(a.lods[0], cut, 0.2));
  }
  std::printf("outlines checked: %d (PNG strips in %s)\n", checked, dir.string().c_str());
}

// The per-cascade choice on the world's clusters at the texels of the default cascades on the
// forest path: each cluster draws the coarsest LOD whose recorded error is within
// lodMaxErrorTexels of the cascade's texel, and the ladder is built so that at the default
// budget the last cascade admits LOD 1 of every vegetation cluster in every pose, and at a
// budget of 2 texels LOD 2 there and LOD 1 in cascade 2.
class LodChoice : public testing::TestWithParam<float> {};

TEST_P(LodChoice, CascadesChooseTheCoarsestLodWithinTheirTexelBudget) {
  const world::World& w = defaultWorld();
  const auto path = world::FlightPath::make("forest", w, 60.0);
  ASSERT_TRUE(path);
  const float e = GetParam();
  const csm::ShadowSettings settings;
  const csm::DirectionalLight light{glm::normalize(glm::dvec3(0.45, -0.8, -0.35))};
  std::array<int, 4> vegetationLodSum{};
  int vegetationCount = 0;
  for (int p = 0; p < 5; ++p) {
    const world::CameraPose pose = path->at((p + 0.5) / 5.0);
    csm::Camera cam;
    cam.positionWs = pose.positionWs;
    cam.orientationWs = glm::angleAxis(pose.yawRad, glm::dvec3(0, 1, 0)) *
                        glm::angleAxis(pose.pitchRad, glm::dvec3(1, 0, 0));
    cam.fovYRad = glm::radians(pose.fovDeg);
    cam.aspect = 16.0 / 9.0;
    cam.nearM = 0.1;
    cam.farM = 5000.0;
    const auto frame = csm::computeCascades(settings, cam, light);
    ASSERT_TRUE(frame.ok());
    ASSERT_EQ(frame.value().cascadeCount, 4u);
    for (std::uint32_t c = 0; c < 4; ++c) {
      const double texel = glm::min(frame.value().cascades[c].texelSizeLs.x,
                                    frame.value().cascades[c].texelSizeLs.y);
      if (p == 0) std::printf("forest pose 0, cascade %u: texel %.4f m\n", c, texel);
      for (const world::CasterCluster& cl : w.clusters) {
        csm::vk::CasterInstance in;
        for (std::uint32_t l = 1; l < world::kLodCount; ++l) {
          in.lodMeshes[l - 1] = l;
          in.lodErrorM[l - 1] = cl.lodErrorM[l];
        }
        std::uint32_t expected = 0;
        for (std::uint32_t l = 0; l < world::kLodCount; ++l) {
          if (double(cl.lodErrorM[l]) <= double(e) * texel) expected = l;
        }
        const std::uint32_t got = csm::vk::casterLod(in, 0, texel, e);
        ASSERT_EQ(got, expected) << cl.name << " cascade " << c;
        if (cl.name.rfind("vegetation", 0) == 0) {
          vegetationLodSum[c] += int(got);
          if (c == 0) ++vegetationCount;
        }
      }
    }
  }
  ASSERT_GT(vegetationCount, 0);
  // vegetationCount counts clusters over all poses.
  if (e == csm::vk::RendererOptions{}.lodMaxErrorTexels) {
    EXPECT_GE(vegetationLodSum[3], vegetationCount);  // LOD 1 or 2 in every pose
  } else {
    EXPECT_GE(vegetationLodSum[2], vegetationCount);      // LOD 1 or 2 in every pose
    EXPECT_EQ(vegetationLodSum[3], vegetationCount * 2);  // the coarsest in every pose
  }
}

INSTANTIATE_TEST_SUITE_P(Budgets, LodChoice,
                         testing::Values(csm::vk::RendererOptions{}.lodMaxErrorTexels, 2.0f));
