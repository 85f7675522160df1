// Procedural world generation (see world.hpp). Every random choice comes from a hash of the seed
// and integer coordinates (no std:: distributions, whose output differs between libraries), so
// one seed gives the same world on every build and machine.
#include "sample_world/world.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <future>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>

#include "mesh_ops.hpp"

namespace world {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::uint64_t mix64(std::uint64_t x) noexcept {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

std::uint64_t hash3(std::uint64_t seed, std::int64_t a, std::int64_t b, std::uint64_t salt) {
  return mix64(seed ^ mix64(static_cast<std::uint64_t>(a) * 0x632be59bd9b4e019ull ^
                            mix64(static_cast<std::uint64_t>(b) ^ (salt << 40))));
}

double unit(std::uint64_t h) noexcept {
  return static_cast<double>(h >> 11) * 0x1.0p-53;
}

/// A small deterministic generator (splitmix64 stream).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  double next() noexcept {
    state_ = mix64(state_);
    return unit(state_);
  }
  double range(double lo, double hi) noexcept { return lo + (hi - lo) * next(); }
  std::uint32_t below(std::uint32_t n) noexcept {
    return static_cast<std::uint32_t>(next() * n) % std::max(n, 1u);
  }

 private:
  std::uint64_t state_;
};

double smooth(double t) noexcept {
  return t * t * (3.0 - 2.0 * t);
}

double valueNoise(std::uint64_t seed, double x, double z, std::uint64_t salt) noexcept {
  const double fx = std::floor(x), fz = std::floor(z);
  const auto ix = static_cast<std::int64_t>(fx), iz = static_cast<std::int64_t>(fz);
  const double tx = smooth(x - fx), tz = smooth(z - fz);
  const double a = unit(hash3(seed, ix, iz, salt)), b = unit(hash3(seed, ix + 1, iz, salt));
  const double c = unit(hash3(seed, ix, iz + 1, salt)), d = unit(hash3(seed, ix + 1, iz + 1, salt));
  return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * tz;
}

double fbm(std::uint64_t seed, double x, double z, int octaves, std::uint64_t salt) noexcept {
  double sum = 0.0, amp = 0.5, norm = 0.0;
  for (int o = 0; o < octaves; ++o) {
    sum += amp * valueNoise(seed, x, z, salt + static_cast<std::uint64_t>(o));
    norm += amp;
    amp *= 0.5;
    x = x * 2.03 + 17.1;
    z = z * 2.03 - 9.7;
  }
  return sum / norm;
}

// ---- Mesh prototypes (built in object space, finished by OpenMesh) --------------------------

struct Shape {
  std::vector<glm::vec3> p;
  std::vector<std::uint32_t> i;

  std::uint32_t vertex(const glm::vec3& v) {
    p.push_back(v);
    return static_cast<std::uint32_t>(p.size() - 1);
  }
  void tri(std::uint32_t a, std::uint32_t b, std::uint32_t c) { i.insert(i.end(), {a, b, c}); }
  // A flat quad of its own 4 vertices (a, b, c, d counter-clockwise seen from outside).
  void quad(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c, const glm::vec3& d) {
    const std::uint32_t base = static_cast<std::uint32_t>(p.size());
    p.insert(p.end(), {a, b, c, d});
    tri(base, base + 1, base + 2);
    tri(base, base + 2, base + 3);
  }
  // An axis-aligned box with flat faces.
  void box(const glm::vec3& lo, const glm::vec3& hi) {
    const glm::vec3 c[8] = {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z},
                            {lo.x, hi.y, lo.z}, {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z},
                            {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}};
    quad(c[4], c[5], c[6], c[7]);  // +z
    quad(c[1], c[0], c[3], c[2]);  // -z
    quad(c[5], c[1], c[2], c[6]);  // +x
    quad(c[0], c[4], c[7], c[3]);  // -x
    quad(c[7], c[6], c[2], c[3]);  // +y
    quad(c[0], c[1], c[5], c[4]);  // -y
  }
  // A closed frustum of a cone along +y (radius r0 at y0, r1 at y1; r1 = 0 gives a cone). The
  // caps are fans around a centre vertex (`hubs`) or, with the same outline and two triangles
  // fewer each, fans from the ring's first vertex.
  void cone(float y0, float y1, float r0, float r1, int sides, float twist = 0.0f,
            bool hubs = true) {
    const std::uint32_t bottom = hubs ? vertex({0.0f, y0, 0.0f}) : 0u;
    std::vector<std::uint32_t> ring0, ring1;
    for (int s = 0; s < sides; ++s) {
      const double a = 2.0 * kPi * s / sides + twist;
      ring0.push_back(
          vertex({r0 * static_cast<float>(std::cos(a)), y0, r0 * static_cast<float>(std::sin(a))}));
    }
    if (r1 > 0.0f) {
      for (int s = 0; s < sides; ++s) {
        const double a = 2.0 * kPi * s / sides + twist;
        ring1.push_back(vertex(
            {r1 * static_cast<float>(std::cos(a)), y1, r1 * static_cast<float>(std::sin(a))}));
      }
    }
    const bool apex = !(r1 > 0.0f);
    const std::uint32_t top = hubs || apex ? vertex({0.0f, y1, 0.0f}) : 0u;
    for (int s = 0; s < sides; ++s) {
      const int n = (s + 1) % sides;
      if (hubs) {
        tri(bottom, ring0[s], ring0[n]);
      } else if (s >= 1 && n >= 2) {
        tri(ring0[0], ring0[s], ring0[n]);
      }
      if (!apex) {
        tri(ring0[n], ring0[s], ring1[s]);
        tri(ring0[n], ring1[s], ring1[n]);
        if (hubs) {
          tri(top, ring1[n], ring1[s]);
        } else if (s >= 1 && n >= 2) {
          tri(ring1[0], ring1[n], ring1[s]);
        }
      } else {
        tri(ring0[n], ring0[s], top);
      }
    }
  }
  // A unit icosphere (subdivided once), each vertex pushed out by `jitter(v)`, centred at c.
  template <class F>
  void blob(const glm::vec3& c, const glm::vec3& radius, F jitter) {
    const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
    std::vector<glm::vec3> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    std::vector<std::uint32_t> f = {0, 11, 5, 0, 5,  1,  0,  1,  7,  0,  7, 10, 0, 10, 11,
                                    1, 5,  9, 5, 11, 4,  11, 10, 2,  10, 7, 6,  7, 1,  8,
                                    3, 9,  4, 3, 4,  2,  3,  2,  6,  3,  6, 8,  3, 8,  9,
                                    4, 9,  5, 2, 4,  11, 6,  2,  10, 8,  6, 7,  9, 8,  1};
    for (auto& x : v) x = glm::normalize(x);
    std::vector<std::uint32_t> g;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> mids;
    auto mid = [&](std::uint32_t a, std::uint32_t b) {
      const std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      for (const auto& m : mids) {
        if (m.first == key) return m.second;
      }
      v.push_back(glm::normalize(v[a] + v[b]));
      mids.emplace_back(key, static_cast<std::uint32_t>(v.size() - 1));
      return static_cast<std::uint32_t>(v.size() - 1);
    };
    for (std::size_t k = 0; k < f.size(); k += 3) {
      const std::uint32_t a = f[k], b = f[k + 1], cc = f[k + 2];
      const std::uint32_t ab = mid(a, b), bc = mid(b, cc), ca = mid(cc, a);
      g.insert(g.end(), {a, ab, ca, b, bc, ab, cc, ca, bc, ab, bc, ca});
    }
    const std::uint32_t base = static_cast<std::uint32_t>(p.size());
    for (const auto& x : v) p.push_back(c + x * radius * jitter(x));
    for (std::uint32_t idx : g) i.push_back(base + idx);
  }
};

// One of Shape::cone's frusta, kept so that a prototype can be rebuilt with fewer sides.
struct ConeSpec {
  float y0, y1, r0, r1;
  int sides;
  float twist = 0.0f;
};

// The fewest sides (3 .. spec.sides) whose polygon, with its radius set to straddle the original
// polygon's mid circle (vertices outside by as much as edge midpoints are inside), is predicted
// within `budgetM` of the original: mid radius x tan^2(pi / 2n) plus the original's own
// half-deviation. The caller measures the result: the prediction only picks the candidate.
struct ConeCut {
  int sides;
  float radiusScale;
};
ConeCut cutCone(const ConeSpec& spec, double budgetM) {
  const double r = std::max(spec.r0, spec.r1);
  const double c0 = std::cos(kPi / spec.sides);
  const double mid = r * (1.0 + c0) / 2.0;
  for (int n = 3; n < spec.sides; ++n) {
    const double t = std::tan(kPi / (2.0 * n));
    if (mid * t * t + r * (1.0 - c0) / 2.0 <= budgetM) {
      return {n, static_cast<float>(2.0 * mid / (1.0 + std::cos(kPi / n)) / r)};
    }
  }
  return {spec.sides, 1.0f};
}

// Adds `cones` to `shape`: as specified (budgetM 0), or each cut to the fewest sides cutCone
// predicts within budgetM, caps as ring fans.
void addCones(Shape& shape, const std::vector<ConeSpec>& cones, double budgetM) {
  for (const ConeSpec& c : cones) {
    if (!(budgetM > 0.0)) {
      shape.cone(c.y0, c.y1, c.r0, c.r1, c.sides, c.twist);
      continue;
    }
    const ConeCut cut = cutCone(c, budgetM);
    shape.cone(c.y0, c.y1, c.r0 * cut.radiusScale, c.r1 * cut.radiusScale, cut.sides, c.twist,
               false);
  }
}

// Records each LOD's geometric error against LOD 0 (0 where the LOD is LOD 0's mesh), sampled
// as densely as decimateToError measured it; `measuredM[l]` >= 0: the error decimateToError
// measured for lods[l] as it is (the same number, not measured twice: seconds on a large mesh).
void measureLodErrors(MeshAsset& asset, const std::array<double, kLodCount>& measuredM) {
  asset.lodErrorM[0] = 0.0f;
  for (std::uint32_t l = 1; l < kLodCount; ++l) {
    const bool same = asset.lods[l].indices == asset.lods[0].indices &&
                      asset.lods[l].positions == asset.lods[0].positions;
    const double spacing = lodSampleSpacingM(asset.lodBoundM[l]);
    const double errorM = measuredM[l] >= 0.0
                              ? measuredM[l]
                              : simplificationErrorM(asset.lods[0], asset.lods[l], spacing);
    asset.lodErrorM[l] = same ? 0.0f : std::max(asset.lodErrorM[l - 1], static_cast<float>(errorM));
  }
}

// The largest scales trees and rocks are placed with (their placement below draws 0.7 + 0.6 u
// and 0.5 + 3.5 u^3): an asset's LOD bound in its own metres is the world rung over it.
constexpr double kTreeMaxScale = 1.3;
constexpr double kRockMaxScale = 4.0;

// A prototype rebuilt with its round parts cut to fewer sides within a budget in its own metres
// (0: the prototype itself).
using ShapeBuilder = std::function<Shape(double budgetM)>;

// The procedural candidate for a LOD within `boundM` of `lod0`: the prototype's round parts cut
// to fewer sides, predicted within a fraction of the bound, the fraction lowered while the
// measured error or the shadow outlines exceed the bound. Nothing when no cut fits or helps.
std::optional<MeshData> cutWithin(const ShapeBuilder& build, const MeshData& lod0, double boundM) {
  for (double fraction : {1.0, 0.8, 0.6, 0.4}) {
    const Shape shape = build(fraction * boundM);
    MeshData cut = finishMesh(shape.p, shape.i);
    if (cut.indices.empty() || cut.triangleCount() >= lod0.triangleCount()) return std::nullopt;
    if (simplificationErrorM(lod0, cut, lodSampleSpacingM(boundM)) <= boundM &&
        shadowOutlinesWithin(lod0, cut, boundM)) {
      return cut;
    }
  }
  return std::nullopt;
}

// Fills LODs 1.. of an asset placed at most `maxScale` times its size (0: full detail at every
// LOD), each within its rung of kLodErrorLadderM in world metres: the fewer triangles of the
// Decimater's simplification and, for a procedural prototype (`build`), the prototype with its
// cones cut to fewer sides. The Decimater takes no side off the conifer's 12-sided 3.2 m crown
// within LOD 1's 0.154 m (a collapse moves a ring vertex a whole side's width); rebuilt with 10
// sides and a radius straddling the 12-sided one it measures 0.152 m, and the conifer's LOD 1
// has 48 triangles instead of the Decimater's 74.
void buildLods(MeshAsset& asset, double maxScale, const ShapeBuilder& build = {},
               const Progress& progress = {}) {
  std::array<double, kLodCount> measuredM{};  // decimateToError's measured error, -1: none
  for (std::uint32_t l = 1; l < kLodCount; ++l) {
    asset.lodBoundM[l] = maxScale > 0.0 ? static_cast<float>(kLodErrorLadderM[l] / maxScale) : 0.0f;
  }
  if (maxScale > 0.0) {
    // Each LOD is decimated from LOD 0 on its own, so the levels run on their own threads (the
    // same meshes as one after the other, in about the time of the slowest). Progress lines
    // from the threads are serialised.
    std::mutex progressMutex;
    auto decimate = [&](std::uint32_t l) {
      Progress lodProgress;
      if (progress) {
        lodProgress = [&, l](const std::string& step) {
          const std::lock_guard<std::mutex> lock(progressMutex);
          progress(asset.name + ": LOD " + std::to_string(l) + " of " +
                   std::to_string(kLodCount - 1) + ", " + step);
        };
      }
      asset.lods[l] =
          decimateToError(asset.lods[0], asset.lodBoundM[l], &measuredM[l], lodProgress);
      if (lodProgress) {
        char done[96];
        std::snprintf(done, sizeof done, "done: %u triangles, %.3g m",
                      asset.lods[l].triangleCount(), measuredM[l]);
        lodProgress(done);
      }
    };
    // Small meshes take microseconds: threads only where a level is worth one.
    constexpr std::uint32_t kThreadedTriangles = 20000;
    if (asset.lods[0].triangleCount() >= kThreadedTriangles) {
      // Futures: a level that throws (out of memory) rethrows here, after every level ended.
      std::vector<std::future<void>> levels;
      for (std::uint32_t l = 2; l < kLodCount; ++l) {
        levels.push_back(std::async(std::launch::async, decimate, l));
      }
      decimate(1);
      for (auto& level : levels) level.get();
    } else {
      for (std::uint32_t l = 1; l < kLodCount; ++l) decimate(l);
    }
  }
  for (std::uint32_t l = 1; l < kLodCount; ++l) {
    if (maxScale <= 0.0) {
      asset.lods[l] = asset.lods[0];
      measuredM[l] = -1.0;
    }
    if (maxScale > 0.0 && build) {
      std::optional<MeshData> cut = cutWithin(build, asset.lods[0], asset.lodBoundM[l]);
      if (cut && cut->triangleCount() < asset.lods[l].triangleCount()) {
        asset.lods[l] = std::move(*cut);
        measuredM[l] = -1.0;
      }
    }
    if (asset.lods[l].triangleCount() > asset.lods[l - 1].triangleCount()) {
      asset.lods[l] = asset.lods[l - 1];
      measuredM[l] = -1.0;
    }
  }
  measureLodErrors(asset, measuredM);
}

// `maxScale`: the largest uniform scale the asset is placed with (0: no simplified LODs).
MeshAsset makeAsset(std::string name, const Shape& shape, double maxScale) {
  MeshAsset asset;
  asset.name = std::move(name);
  asset.lods[0] = finishMesh(shape.p, shape.i);
  buildLods(asset, maxScale);
  return asset;
}

// A procedural prototype: LOD 0 is build(0); its LODs also try build(budget) (see buildLods).
MeshAsset makeAsset(std::string name, const ShapeBuilder& build, double maxScale) {
  MeshAsset asset;
  asset.name = std::move(name);
  const Shape shape = build(0.0);
  asset.lods[0] = finishMesh(shape.p, shape.i);
  buildLods(asset, maxScale, build);
  return asset;
}

glm::mat3 yawScale(double yaw, double scale) {
  const float c = static_cast<float>(std::cos(yaw) * scale);
  const float s = static_cast<float>(std::sin(yaw) * scale);
  const float k = static_cast<float>(scale);
  // Columns: rotation about +y, uniform scale.
  return glm::mat3(glm::vec3(c, 0.0f, -s), glm::vec3(0.0f, k, 0.0f), glm::vec3(s, 0.0f, c));
}

csm::AabbWs placedBounds(const MeshData& mesh, const glm::dvec3& t, const glm::mat3& linear) {
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (const glm::vec3& p : mesh.positions) {
    const glm::dvec3 q = t + glm::dvec3(linear * p);
    lo = glm::min(lo, q);
    hi = glm::max(hi, q);
  }
  return {lo, hi};
}

void appendTransformed(MeshData& dst, const MeshData& src, const glm::vec3& offset,
                       const glm::mat3& linear) {
  const auto base = static_cast<std::uint32_t>(dst.positions.size());
  const glm::mat3 normalMatrix = glm::transpose(glm::inverse(linear));
  for (std::size_t k = 0; k < src.positions.size(); ++k) {
    dst.positions.push_back(offset + linear * src.positions[k]);
    dst.normals.push_back(glm::normalize(normalMatrix * src.normals[k]));
  }
  for (std::uint32_t idx : src.indices) dst.indices.push_back(base + idx);
}

}  // namespace

const char* kindName(Kind kind) noexcept {
  switch (kind) {
    case Kind::kTerrain:
      return "terrain";
    case Kind::kTree:
      return "tree";
    case Kind::kRock:
      return "rock";
    case Kind::kBuilding:
      return "building";
    case Kind::kTower:
      return "tower";
    case Kind::kPole:
      return "pole";
    case Kind::kFence:
      return "fence";
    case Kind::kCable:
      return "cable";
    case Kind::kUser:
      return "user mesh";
  }
  return "?";
}

double terrainHeight(std::uint64_t seed, double uM, double vM) noexcept {
  // Rolling hills (fBm over ~1 km), a few sharper ridges, a valley running north-south, and a
  // plateau at the centre for the town.
  const double hills = fbm(seed, uM / 1100.0, vM / 1100.0, 5, 11) * 170.0;
  const double ridge = 1.0 - std::abs(2.0 * fbm(seed, uM / 600.0, vM / 600.0, 4, 31) - 1.0);
  const double valleyX = 2048.0 + 500.0 * std::sin(vM / 700.0);
  const double valley = std::exp(-std::pow((uM - valleyX) / 260.0, 2.0));
  double h = 30.0 + hills + 60.0 * ridge * ridge - 70.0 * valley;
  const double du = uM - 2048.0, dv = vM - 2048.0;
  const double town = std::clamp((std::sqrt(du * du + dv * dv) - 380.0) / 250.0, 0.0, 1.0);
  const double townH = 30.0 + fbm(seed, 2048.0 / 1100.0, 2048.0 / 1100.0, 5, 11) * 170.0;
  h = townH + (h - townH) * smooth(town);
  return h;
}

double World::heightAt(double xWs, double zWs) const noexcept {
  const double u = std::clamp(xWs - desc.originWs.x, 0.0, desc.sizeM);
  const double v = std::clamp(zWs - desc.originWs.z, 0.0, desc.sizeM);
  return desc.originWs.y + terrainHeight(desc.seed, u, v);
}

glm::dvec3 World::centerWs() const noexcept {
  const double x = desc.originWs.x + 0.5 * desc.sizeM, z = desc.originWs.z + 0.5 * desc.sizeM;
  return {x, heightAt(x, z), z};
}

namespace {
std::string shortNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

/// generateWorld's state, shared by its sections (one member function each, called in order:
/// the order fixes every mesh index and so the world's hash).
class WorldBuilder {
 public:
  WorldBuilder(const WorldDesc& d, World& world)
      : desc(d),
        w(world),
        n(world.chunksPerSide),
        seed(d.seed),
        o(d.originWs),
        centre(d.originWs + glm::dvec3(0.5 * d.sizeM, 0.0, 0.5 * d.sizeM)) {}

  void terrain();
  void prototypes();
  void town();
  void thinCasters();
  void forests();
  void placeUserMesh(std::optional<MeshData>& userMesh, const Progress& progress);
  void statisticsAndClusters();

 private:
  double ground(double u, double v) const { return terrainHeight(seed, u, v); }
  double heightWs(double x, double z) const { return w.heightAt(x, z); }
  std::uint32_t addAsset(MeshAsset a) {
    w.meshes.push_back(std::move(a));
    return static_cast<std::uint32_t>(w.meshes.size() - 1);
  }
  std::uint32_t chunkOf(const glm::dvec3& p) const {
    const auto cx = static_cast<std::uint32_t>(
        std::clamp(std::floor((p.x - o.x) / desc.chunkM), 0.0, double(n - 1)));
    const auto cz = static_cast<std::uint32_t>(
        std::clamp(std::floor((p.z - o.z) / desc.chunkM), 0.0, double(n - 1)));
    return cz * n + cx;
  }
  void place(std::uint32_t mesh, Kind kind, const glm::dvec3& t, const glm::mat3& linear,
             const glm::vec3& color, bool casts = true, bool receives = true) {
    Object ob;
    ob.mesh = mesh;
    ob.kind = kind;
    ob.translationWs = t;
    ob.linear = linear;
    ob.color = color;
    ob.casts = casts;
    ob.receives = receives;
    ob.boundsWs = placedBounds(w.meshes[mesh].lods[0], t, linear);
    ob.chunk = chunkOf(t);
    w.objects.push_back(ob);
  }
  bool inTown(double x, double z, double r) const {
    const double dx = x - centre.x, dz = z - centre.z;
    return dx * dx + dz * dz < r * r;
  }

  const WorldDesc& desc;
  World& w;
  const std::uint32_t n;                    // chunks per side
  const std::uint64_t seed;                 // desc.seed
  const glm::dvec3 o;                       // the world's origin (its south-west corner)
  const glm::dvec3 centre;                  // the town's centre, the middle of the world
  std::vector<std::uint32_t> trees, rocks;  // prototype meshes
};

/// Why `desc` cannot be generated (the field, the value and the allowed range), or nothing.
std::optional<std::string> checkDesc(const WorldDesc& desc) {
  if (!(desc.sizeM >= 4096.0 && desc.sizeM <= 65536.0)) {
    return std::string("world.size = " + shortNumber(desc.sizeM) + ": allowed [4096, 65536] m");
  }
  const double chunksD = desc.sizeM / desc.chunkM;
  if (!(desc.chunkM >= 64.0) || std::abs(chunksD - std::round(chunksD)) > 1e-9) {
    return std::string("world.chunk = " + shortNumber(desc.chunkM) +
                       ": must be >= 64 m and divide world.size");
  }
  const double cellsD = desc.chunkM / desc.clusterM;
  if (!(desc.clusterM >= 16.0) || !(desc.clusterM <= desc.chunkM) ||
      std::abs(cellsD - std::round(cellsD)) > 1e-9) {
    return std::string("world.clusterM = " + shortNumber(desc.clusterM) +
                       ": must be >= 16 m, at most world.chunk (" + shortNumber(desc.chunkM) +
                       " m) and divide it");
  }
  if (desc.chunkCells < 4 || desc.chunkCells > 256) {
    return std::string("world.chunkCells = " + std::to_string(desc.chunkCells) +
                       ": allowed [4, 256]");
  }
  if (desc.treeCount > 500000 || desc.rockCount > 100000 || desc.buildingCount > 5000) {
    return std::string("world.trees/rocks/buildings: allowed at most 500000 / 100000 / 5000");
  }
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(desc.originWs[a]) || std::abs(desc.originWs[a]) > 1e8) {
      return std::string("world.origin: every coordinate must be finite and within 1e8 m");
    }
  }
  return std::nullopt;
}

// ---- Terrain chunks: one mesh asset each (LODs keep their boundary: no cracks) --------------
void WorldBuilder::terrain() {
  w.meshes.resize(static_cast<std::size_t>(n) * n);
  auto buildChunk = [&](std::uint32_t c) {
    const std::uint32_t cx = c % n, cz = c / n;
    const std::uint32_t cells = desc.chunkCells;
    const double step = desc.chunkM / cells;
    Shape s;
    for (std::uint32_t j = 0; j <= cells; ++j) {
      for (std::uint32_t i = 0; i <= cells; ++i) {
        const double u = cx * desc.chunkM + i * step, v = cz * desc.chunkM + j * step;
        s.vertex({static_cast<float>(i * step), static_cast<float>(ground(u, v)),
                  static_cast<float>(j * step)});
      }
    }
    for (std::uint32_t j = 0; j < cells; ++j) {
      for (std::uint32_t i = 0; i < cells; ++i) {
        const std::uint32_t a = j * (cells + 1) + i, b = a + 1, d = a + cells + 1, e = d + 1;
        s.tri(a, d, e);
        s.tri(a, e, b);
      }
    }
    // Terrain keeps full detail at every LOD. It is its own receiver, and a simplified
    // heightfield lies above the real one over every concave stretch, where it shadows the
    // ground it stands for: with Decimater LODs in cascades 1+, csm_tradeoff measured 30%
    // of receiver pixels misclassified against the ray-traced truth (0.46% without). It is
    // a small share of the shadow pass's triangles (512 per chunk).
    w.meshes[c] =
        makeAsset("terrain chunk " + std::to_string(cx) + "," + std::to_string(cz), s, 0.0);
  };
  // Chunks are independent: build them on every core (results do not depend on the order).
  const unsigned threads = std::max(1u, std::min(4u, std::thread::hardware_concurrency()));
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      for (std::uint32_t c = t; c < n * n; c += threads) buildChunk(c);
    });
  }
  for (auto& th : pool) th.join();
  for (std::uint32_t c = 0; c < n * n; ++c) {
    Object t;
    t.mesh = c;
    t.kind = Kind::kTerrain;
    t.translationWs = o + glm::dvec3((c % n) * desc.chunkM, 0.0, (c / n) * desc.chunkM);
    t.color = {0.42f, 0.55f, 0.28f};
    t.boundsWs = placedBounds(w.meshes[c].lods[0], t.translationWs, t.linear);
    t.chunk = c;
    w.objects.push_back(t);
  }
}

// ---- Prototypes ------------------------------------------------------------------------------
void WorldBuilder::prototypes() {
  // Trees are cones (and a lumpy crown): rebuilt with fewer sides for their LODs.
  auto conesAlone = [](const std::vector<ConeSpec>& cones) -> ShapeBuilder {
    return [&cones](double budgetM) {
      Shape s;
      addCones(s, cones, budgetM);
      return s;
    };
  };
  const std::vector<ConeSpec> coniferCones = {{-0.5f, 3.0f, 0.35f, 0.25f, 8},  // trunk
                                              {2.5f, 8.0f, 3.2f, 0.0f, 12},
                                              {6.0f, 11.5f, 2.4f, 0.0f, 12, 0.2f},
                                              {9.5f, 14.0f, 1.5f, 0.0f, 10, 0.4f}};
  trees.push_back(addAsset(makeAsset(  // trunk + three stacked cones, ~14 m
      "conifer", conesAlone(coniferCones), kTreeMaxScale)));
  const std::vector<ConeSpec> broadTrunk = {{-0.5f, 4.5f, 0.45f, 0.3f, 8}};
  trees.push_back(addAsset(makeAsset(  // trunk + lumpy crown, ~11 m
      "broadleaf",
      [&](double budgetM) {
        Shape s;
        addCones(s, broadTrunk, budgetM);
        s.blob({0.0f, 7.5f, 0.0f}, {4.0f, 3.6f, 4.0f}, [&](const glm::vec3& v) {
          return static_cast<float>(0.85 +
                                    0.3 * valueNoise(seed, v.x * 2.0 + 5, v.z * 2.0 + v.y, 77));
        });
        return s;
      },
      kTreeMaxScale)));
  const std::vector<ConeSpec> pineCones = {{-0.5f, 12.0f, 0.4f, 0.2f, 8},
                                           {8.0f, 22.0f, 2.2f, 0.0f, 10}};
  trees.push_back(addAsset(makeAsset(  // tall thin pine, ~22 m
      "pine", conesAlone(pineCones), kTreeMaxScale)));
  for (int k = 0; k < 4; ++k) {
    Shape rock;
    rock.blob({0.0f, 0.3f, 0.0f}, {1.0f, 0.7f, 1.1f}, [&](const glm::vec3& v) {
      return static_cast<float>(
          0.7 + 0.6 * valueNoise(seed, v.x * 2.5 + 10 * k, v.z * 2.5 + v.y * 1.7, 91));
    });
    rocks.push_back(addAsset(makeAsset("rock " + std::to_string(k), rock, kRockMaxScale)));
  }
  const std::uint32_t unitBox = [&] {
    Shape b;
    b.box({-0.5f, 0.0f, -0.5f}, {0.5f, 1.0f, 0.5f});
    return addAsset(makeAsset("box", b, 0.0));
  }();
  (void)unitBox;
}

// ---- The town: buildings on a grid around a tall tower ----------------------------------------
void WorldBuilder::town() {
  {
    Shape tower;  // 160 m tapering lattice-like tower: stacked boxes with balconies
    float y = 0.0f, side = 12.0f;
    for (int k = 0; k < 8; ++k) {
      const float hseg = 18.0f;
      tower.box({-side / 2, y, -side / 2}, {side / 2, y + hseg, side / 2});
      tower.box({-side / 2 - 1.5f, y + hseg - 1.0f, -side / 2 - 1.5f},
                {side / 2 + 1.5f, y + hseg, side / 2 + 1.5f});
      y += hseg;
      side *= 0.88f;
    }
    tower.box({-0.4f, y, -0.4f}, {0.4f, y + 16.0f, 0.4f});  // antenna: a thin caster
    const std::uint32_t towerMesh = addAsset(makeAsset("tower", tower, 0.0));
    const glm::dvec3 at(centre.x + 20.0, 0.0, centre.z - 30.0);
    place(towerMesh, Kind::kTower, {at.x, heightWs(at.x, at.z) - 0.5, at.z}, yawScale(0.3, 1.0),
          {0.75f, 0.72f, 0.68f});
  }
  {
    Rng r(mix64(seed ^ 0x70f0));
    std::vector<std::uint32_t> houseMeshes;
    for (int k = 0; k < 6; ++k) {  // a few building shapes, flat roofs and pitched roofs
      Shape b;
      const float wx = static_cast<float>(r.range(8.0, 22.0));
      const float wz = static_cast<float>(r.range(8.0, 18.0));
      const float hgt = static_cast<float>(k < 3 ? r.range(18.0, 40.0) : r.range(6.0, 10.0));
      b.box({-wx / 2, -1.0f, -wz / 2}, {wx / 2, hgt, wz / 2});
      if (k >= 3) {  // pitched roof
        const float rh = 0.4f * wz;
        b.quad({-wx / 2, hgt, wz / 2}, {wx / 2, hgt, wz / 2}, {wx / 2, hgt + rh, 0.0f},
               {-wx / 2, hgt + rh, 0.0f});
        b.quad({wx / 2, hgt, -wz / 2}, {-wx / 2, hgt, -wz / 2}, {-wx / 2, hgt + rh, 0.0f},
               {wx / 2, hgt + rh, 0.0f});
        const std::uint32_t a0 = b.vertex({-wx / 2, hgt, -wz / 2});
        const std::uint32_t a1 = b.vertex({-wx / 2, hgt, wz / 2});
        const std::uint32_t a2 = b.vertex({-wx / 2, hgt + rh, 0.0f});
        b.tri(a0, a1, a2);
        const std::uint32_t b0 = b.vertex({wx / 2, hgt, wz / 2});
        const std::uint32_t b1 = b.vertex({wx / 2, hgt, -wz / 2});
        const std::uint32_t b2 = b.vertex({wx / 2, hgt + rh, 0.0f});
        b.tri(b0, b1, b2);
      }
      houseMeshes.push_back(addAsset(makeAsset("building " + std::to_string(k), b, 0.0)));
    }
    std::uint32_t placed = 0;
    for (int gz = -7; gz <= 7 && placed < desc.buildingCount; ++gz) {
      for (int gx = -7; gx <= 7 && placed < desc.buildingCount; ++gx) {
        if (std::abs(gx) <= 1 && std::abs(gz) <= 1) continue;  // the tower's square
        const std::uint64_t h = hash3(seed, gx, gz, 0x40);
        if (unit(h) < 0.3) continue;
        const double x = centre.x + gx * 42.0 + (unit(mix64(h)) - 0.5) * 8.0;
        const double z = centre.z + gz * 42.0 + (unit(mix64(h + 1)) - 0.5) * 8.0;
        const std::uint32_t mesh = houseMeshes[(std::abs(gx) + std::abs(gz) > 5 ? 3 : 0) +
                                               static_cast<std::uint32_t>(h >> 60) % 3];
        const double yaw = (h >> 58 & 1) ? 0.0 : kPi / 2;
        const float shade = static_cast<float>(0.6 + 0.3 * unit(mix64(h + 2)));
        place(mesh, Kind::kBuilding, {x, heightWs(x, z), z}, yawScale(yaw, 1.0),
              {shade, shade * 0.9f, shade * 0.8f});
        ++placed;
      }
    }
  }
}

// ---- Thin casters: a power line east of the town, fences around fields -----------------------
void WorldBuilder::thinCasters() {
  Shape pole;
  pole.cone(-1.0f, 12.0f, 0.18f, 0.14f, 8);
  pole.box({-1.6f, 11.0f, -0.1f}, {1.6f, 11.3f, 0.1f});  // cross arm
  const std::uint32_t poleMesh = addAsset(makeAsset("pole", pole, 1.0));
  Shape cable;  // a unit-length cable along +x, 3 cm thick
  cable.box({0.0f, -0.015f, -0.015f}, {1.0f, 0.015f, 0.015f});
  const std::uint32_t cableMesh = addAsset(makeAsset("cable", cable, 0.0));
  const double spacing = 45.0;
  glm::dvec3 prev{};
  for (int k = 0; k < 36; ++k) {
    const double x = centre.x + 330.0 + k * spacing;
    const double z = centre.z + 60.0 + 40.0 * std::sin(k * 0.15);
    const glm::dvec3 base{x, heightWs(x, z), z};
    place(poleMesh, Kind::kPole, base, yawScale(0.0, 1.0), {0.35f, 0.27f, 0.2f});
    if (k > 0) {
      for (int c = -1; c <= 1; ++c) {
        const glm::dvec3 a = prev + glm::dvec3(0.0, 11.35, 1.4 * c);
        const glm::dvec3 b = base + glm::dvec3(0.0, 11.35, 1.4 * c);
        const glm::dvec3 d = b - a;
        const double len = glm::length(d);
        // Rotation taking +x to d, scaled along x only is non-uniform: build the cable at its
        // length instead (x axis -> d, y and z kept unit).
        const glm::vec3 ax = glm::vec3(d / len);
        const glm::vec3 az = glm::normalize(glm::cross(ax, glm::vec3(0, 1, 0)));
        const glm::vec3 ay = glm::cross(az, ax);
        const glm::mat3 lin(ax * static_cast<float>(len), ay, az);
        // Cables: cast, but are never darkened themselves (receives = false).
        Object ob;
        ob.mesh = cableMesh;
        ob.kind = Kind::kCable;
        ob.translationWs = a;
        ob.linear = lin;
        ob.color = {0.1f, 0.1f, 0.1f};
        ob.receives = false;
        ob.boundsWs = placedBounds(w.meshes[cableMesh].lods[0], a, lin);
        ob.chunk = chunkOf(a);
        w.objects.push_back(ob);
      }
    }
    prev = base;
  }
  Shape post;
  post.box({-0.06f, -0.5f, -0.06f}, {0.06f, 1.4f, 0.06f});
  post.box({-0.03f, 0.5f, 0.0f}, {0.03f, 0.6f, 3.0f});  // rails toward the next post
  post.box({-0.03f, 1.1f, 0.0f}, {0.03f, 1.2f, 3.0f});
  const std::uint32_t postMesh = addAsset(makeAsset("fence segment", post, 0.0));
  for (int field = 0; field < 6; ++field) {
    const double fx = centre.x - 520.0 + 110.0 * (field % 3);
    const double fz = centre.z + 200.0 + 120.0 * (field / 3);
    for (int side = 0; side < 4; ++side) {
      for (int k = 0; k < 27; ++k) {
        const double t = k * 3.0;
        glm::dvec3 p;
        double yaw = 0.0;
        if (side == 0) p = {fx, 0, fz + t}, yaw = 0.0;
        if (side == 1) p = {fx + t, 0, fz + 81.0}, yaw = kPi / 2;
        if (side == 2) p = {fx + 81.0, 0, fz + 81.0 - t}, yaw = kPi;
        if (side == 3) p = {fx + 81.0 - t, 0, fz}, yaw = -kPi / 2;
        p.y = heightWs(p.x, p.z);
        place(postMesh, Kind::kFence, p, yawScale(yaw, 1.0), {0.55f, 0.45f, 0.3f});
      }
    }
  }
}

// ---- Forests: jittered grid, kept where a low-frequency density field is high -----------------
void WorldBuilder::forests() {
  const double cell = std::max(
      6.0, std::sqrt(desc.sizeM * desc.sizeM * 0.35 / std::max(1.0, double(desc.treeCount))));
  const auto cellsPerSide = static_cast<std::int64_t>(desc.sizeM / cell);
  // Candidates sorted by a hash so that the first treeCount kept are spread over the world.
  std::uint32_t placed = 0;
  for (std::int64_t j = 0; j < cellsPerSide && placed < desc.treeCount; ++j) {
    for (std::int64_t i = 0; i < cellsPerSide && placed < desc.treeCount; ++i) {
      const std::uint64_t h = hash3(seed, i, j, 0x7ee);
      const double u = (i + 0.1 + 0.8 * unit(mix64(h))) * cell;
      const double v = (j + 0.1 + 0.8 * unit(mix64(h + 1))) * cell;
      const double density = fbm(seed, u / 500.0, v / 500.0, 3, 51);
      if (density < 0.47 || unit(mix64(h + 2)) > (density - 0.4) * 4.0) continue;
      const double x = o.x + u, z = o.z + v;
      if (inTown(x, z, 420.0)) continue;
      const std::uint32_t kind = static_cast<std::uint32_t>(mix64(h + 3) >> 61) % 3;
      const double scale = 0.7 + 0.6 * unit(mix64(h + 4));
      const float g = static_cast<float>(0.8 + 0.4 * unit(mix64(h + 5)));
      const glm::vec3 color =
          kind == 1 ? glm::vec3(0.30f, 0.50f, 0.18f) * g : glm::vec3(0.16f, 0.36f, 0.17f) * g;
      place(trees[kind], Kind::kTree, {x, heightWs(x, z) - 0.3, z},
            yawScale(unit(mix64(h + 6)) * 2.0 * kPi, scale), color);
      ++placed;
    }
  }
  Rng r(mix64(seed ^ 0x50c));
  for (std::uint32_t k = 0; k < desc.rockCount; ++k) {
    const double x = o.x + r.range(20.0, desc.sizeM - 20.0);
    const double z = o.z + r.range(20.0, desc.sizeM - 20.0);
    const double scale = 0.5 + 3.5 * std::pow(r.next(), 3.0);
    const std::uint32_t mesh = rocks[r.below(4)];
    const float g = static_cast<float>(r.range(0.4, 0.6));
    place(mesh, Kind::kRock, {x, heightWs(x, z) - 0.2 * scale, z},
          yawScale(r.range(0.0, 2.0 * kPi), scale), {g, g * 0.97f, g * 0.92f});
  }
}

// ---- The user's mesh --------------------------------------------------------------------------
void WorldBuilder::placeUserMesh(std::optional<MeshData>& userMesh, const Progress& progress) {
  if (!userMesh) return;
  MeshAsset a;
  a.name = "user mesh";
  a.lods[0] = std::move(*userMesh);
  buildLods(a, 1.0, {}, progress);
  const std::uint32_t m = addAsset(std::move(a));
  const double x = centre.x - 60.0, z = centre.z - 80.0;
  place(m, Kind::kUser, {x, heightWs(x, z), z}, yawScale(0.0, 1.0), {0.85f, 0.55f, 0.3f});
}

// ---- Statistics, bounds and caster clusters ---------------------------------------------------
void WorldBuilder::statisticsAndClusters() {
  w.boundsWs.minWs = glm::dvec3(std::numeric_limits<double>::max());
  w.boundsWs.maxWs = -w.boundsWs.minWs;
  for (const Object& ob : w.objects) {
    ++w.kindCounts[static_cast<std::size_t>(ob.kind)];
    w.boundsWs.minWs = glm::min(w.boundsWs.minWs, ob.boundsWs.minWs);
    w.boundsWs.maxWs = glm::max(w.boundsWs.maxWs, ob.boundsWs.maxWs);
  }

  // Which assets are closed (every LOD), for back-face culling in the lit and depth passes.
  std::vector<bool> terrainAsset(w.meshes.size(), false);
  for (const Object& ob : w.objects) {
    if (ob.kind == Kind::kTerrain) terrainAsset[ob.mesh] = true;
  }
  for (std::size_t a = 0; a < w.meshes.size(); ++a) {
    MeshAsset& asset = w.meshes[a];
    asset.closed =
        !terrainAsset[a] && std::all_of(asset.lods.begin(), asset.lods.end(),
                                        [](const MeshData& m) { return isClosedOutward(m); });
  }

  // The terrain chunks, then one cluster per cell (clusterM) and group of casting objects.
  // 0 vegetation + rocks, 1 buildings + tower + user mesh, then the thin casters by width (the
  // depth pass widens a thin caster by its narrowest width, csm::thinCasterWidenTexels): 2
  // cables, 3 fence segments, 4 poles.
  const int kGroups = 5;
  auto groupOf = [](Kind k) {
    switch (k) {
      case Kind::kTree:
      case Kind::kRock:
        return 0;
      case Kind::kBuilding:
      case Kind::kTower:
      case Kind::kUser:
        return 1;
      case Kind::kCable:
        return 2;
      case Kind::kFence:
        return 3;
      default:
        return 4;
    }
  };
  static const char* kGroupNames[] = {"vegetation", "buildings", "thin cables", "thin fences",
                                      "thin poles"};
  // Narrowest true width per thin group, metres: 3 cm cables, 6 cm rails (12 cm posts), poles
  // 0.28 m at the top (0.36 m at the foot; the cross arm 0.2 x 0.3 m, seen at 0.2 m or more).
  static const float kGroupWidthM[] = {0.0f, 0.0f, 0.03f, 0.06f, 0.28f};
  const auto cells = static_cast<std::uint32_t>(std::lround(desc.sizeM / desc.clusterM));
  auto cellOf = [&](const glm::dvec3& p) {
    const auto cx = static_cast<std::uint32_t>(
        std::clamp(std::floor((p.x - o.x) / desc.clusterM), 0.0, double(cells - 1)));
    const auto cz = static_cast<std::uint32_t>(
        std::clamp(std::floor((p.z - o.z) / desc.clusterM), 0.0, double(cells - 1)));
    return cz * cells + cx;
  };
  std::vector<std::vector<std::uint32_t>> members(static_cast<std::size_t>(cells) * cells *
                                                  kGroups);
  for (std::uint32_t k = 0; k < w.objects.size(); ++k) {
    const Object& ob = w.objects[k];
    if (!ob.casts) continue;
    if (ob.kind == Kind::kTerrain) {
      CasterCluster c;
      c.name = w.meshes[ob.mesh].name;
      c.originWs = ob.translationWs;
      c.asset = static_cast<std::int32_t>(ob.mesh);
      c.lodErrorM = w.meshes[ob.mesh].lodErrorM;  // terrain chunks are placed unscaled
      c.boundsWs = ob.boundsWs;
      c.objectCount = 1;
      w.clusters.push_back(std::move(c));
      continue;
    }
    members[cellOf(ob.translationWs) * kGroups + groupOf(ob.kind)].push_back(k);
  }
  for (std::size_t m = 0; m < members.size(); ++m) {
    if (members[m].empty()) continue;
    const auto cell = static_cast<std::uint32_t>(m / kGroups);
    CasterCluster c;
    c.name = std::string(kGroupNames[m % kGroups]) + " " + std::to_string(cell % cells) + "," +
             std::to_string(cell / cells);
    c.originWs =
        o + glm::dvec3((cell % cells) * desc.clusterM, 0.0, (cell / cells) * desc.clusterM);
    c.boundsWs = {glm::dvec3(std::numeric_limits<double>::max()),
                  glm::dvec3(-std::numeric_limits<double>::max())};
    c.thin = m % kGroups >= 2;
    c.thinWidthM = kGroupWidthM[m % kGroups];
    c.closed = true;
    for (std::uint32_t k : members[m]) {
      const Object& ob = w.objects[k];
      // appendTransformed keeps the index order, so a mirroring transform turns a part inside out.
      c.closed = c.closed && w.meshes[ob.mesh].closed && glm::determinant(ob.linear) > 0.0f;
      const glm::vec3 offset(ob.translationWs - c.originWs);
      // Distances grow at most by the transform's largest column length (its largest stretch
      // for the sample world's rotation-times-scale transforms).
      const float stretch = std::max(
          {glm::length(ob.linear[0]), glm::length(ob.linear[1]), glm::length(ob.linear[2])});
      for (std::uint32_t l = 0; l < kLodCount; ++l) {
        appendTransformed(c.lods[l], w.meshes[ob.mesh].lods[l], offset, ob.linear);
        c.lodErrorM[l] = std::max(c.lodErrorM[l], w.meshes[ob.mesh].lodErrorM[l] * stretch);
      }
      c.boundsWs.minWs = glm::min(c.boundsWs.minWs, ob.boundsWs.minWs);
      c.boundsWs.maxWs = glm::max(c.boundsWs.maxWs, ob.boundsWs.maxWs);
      ++c.objectCount;
    }
    w.clusters.push_back(std::move(c));
  }
}

}  // namespace

std::optional<World> generateWorld(const WorldDesc& desc, WorldError* error,
                                   const Progress& progress) {
  auto step = [&](const char* name) {
    if (progress) progress(name);
  };
  auto fail = [&](const std::string& m) -> std::optional<World> {
    if (error) error->message = m;
    return std::nullopt;
  };
  if (auto e = checkDesc(desc)) return fail(*e);

  // The user's mesh first: a bad file is refused before seconds of generation.
  std::optional<MeshData> userMesh;
  if (!desc.userMeshPath.empty()) {
    step("reading the user mesh");
    userMesh = loadMeshFile(desc.userMeshPath, desc.userMeshSizeM, error);
    if (!userMesh) return std::nullopt;
  }

  World w;
  w.desc = desc;
  w.chunksPerSide = static_cast<std::uint32_t>(std::lround(desc.sizeM / desc.chunkM));
  WorldBuilder b(desc, w);
  step("terrain");
  b.terrain();
  step("prototypes and their LODs");
  b.prototypes();
  step("town");
  b.town();
  step("thin casters");
  b.thinCasters();
  step("forests");
  b.forests();
  b.placeUserMesh(userMesh, progress);
  step("statistics and caster clusters");
  b.statisticsAndClusters();
  return w;
}

std::uint64_t worldHash(const World& world) noexcept {
  std::uint64_t h = 14695981039346656037ull;
  auto mix = [&](std::uint64_t v) { h = hashBytes(h, &v, sizeof(v)); };
  for (const MeshAsset& a : world.meshes) {
    for (const MeshData& m : a.lods) mix(meshHash(m));
  }
  for (const CasterCluster& c : world.clusters) {
    for (const MeshData& m : c.lods) mix(meshHash(m));
    h = hashBytes(h, &c.originWs, sizeof(c.originWs));
  }
  for (const Object& ob : world.objects) {
    h = hashBytes(h, &ob.translationWs, sizeof(ob.translationWs));
    h = hashBytes(h, &ob.linear, sizeof(ob.linear));
    h = hashBytes(h, &ob.color, sizeof(ob.color));
    mix(ob.mesh);
    mix((ob.casts ? 1u : 0u) | (ob.receives ? 2u : 0u));
  }
  return h;
}

}  // namespace world
