// The test scene (see test_scene.hpp).
#include "glue/test_scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace glue {
namespace {

// splitmix64: a small deterministic generator (identical on every standard library).
struct Rng {
  uint64_t state;
  uint64_t next() noexcept {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform in [0, 1).
  double uniform() noexcept { return double(next() >> 11) * (1.0 / 9007199254740992.0); }
  double range(double lo, double hi) noexcept { return lo + (hi - lo) * uniform(); }
};

glm::mat3 scaleMatrix(const glm::dvec3& s) {
  return glm::mat3(glm::vec3(float(s.x), 0, 0), glm::vec3(0, float(s.y), 0),
                   glm::vec3(0, 0, float(s.z)));
}

}  // namespace

double terrainHeight(double x, double z) noexcept {
  return 0.9 * std::sin(0.061 * x + 0.3) * std::cos(0.047 * z) +
         0.45 * std::sin(0.17 * x + 1.1) * std::sin(0.13 * z + 0.4) +
         0.12 * std::cos(0.41 * x - 0.37 * z);
}

MeshData makeCubeMesh() {
  MeshData m;
  m.name = "cube";
  engine::makeCube(m.vertices, m.indices);
  return m;
}

MeshData makeSphereMesh(int segments, int rings) {
  MeshData m;
  m.name = "sphere";
  engine::makeSphere(m.vertices, m.indices, segments, rings);
  return m;
}

MeshData makeGroundMesh(bool terrain, double sideM, uint32_t cells, double cx, double cz) {
  MeshData m;
  m.name = terrain ? "terrain" : "ground";
  if (!terrain) cells = 1;
  const double step = sideM / cells;
  const double e = 0.01;  // finite-difference step of the terrain normal (m)
  for (uint32_t j = 0; j <= cells; ++j) {
    for (uint32_t i = 0; i <= cells; ++i) {
      const double x = cx - 0.5 * sideM + step * i;
      const double z = cz - 0.5 * sideM + step * j;
      const double y = terrain ? terrainHeight(x, z) : 0.0;
      glm::dvec3 n(0.0, 1.0, 0.0);
      if (terrain) {
        const double dx = (terrainHeight(x + e, z) - terrainHeight(x - e, z)) / (2.0 * e);
        const double dz = (terrainHeight(x, z + e) - terrainHeight(x, z - e)) / (2.0 * e);
        n = glm::normalize(glm::dvec3(-dx, 1.0, -dz));
      }
      m.vertices.push_back({glm::vec3(float(x), float(y), float(z)), glm::vec3(n)});
    }
  }
  const uint32_t row = cells + 1;
  for (uint32_t j = 0; j < cells; ++j) {
    for (uint32_t i = 0; i < cells; ++i) {
      const uint32_t a = j * row + i, b = a + row;
      // Counter-clockwise seen from above (+y).
      m.indices.insert(m.indices.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
  }
  return m;
}

uint32_t Scene::addMesh(MeshData mesh) {
  meshes_.push_back(std::move(mesh));
  return uint32_t(meshes_.size() - 1);
}

void Scene::addInstance(const Instance& instance) {
  if (instance.mesh >= meshes_.size()) throw std::out_of_range("Scene::addInstance: mesh index");
  const MeshData& m = meshes_[instance.mesh];
  csm::AabbWs b{glm::dvec3(1e300), glm::dvec3(-1e300)};
  for (const engine::Vertex& v : m.vertices) {
    const glm::dvec3 p = instance.translationWs + glm::dvec3(instance.linearWs * v.position);
    b.minWs = glm::min(b.minWs, p);
    b.maxWs = glm::max(b.maxWs, p);
  }
  addInstance(instance, b);
}

void Scene::addInstance(const Instance& instance, const csm::AabbWs& b) {
  if (instance.mesh >= meshes_.size()) throw std::out_of_range("Scene::addInstance: mesh index");
  instances_.push_back(instance);
  bounds_.push_back(b);
  if (instances_.size() == 1) {
    sceneBounds_ = b;
  } else {
    sceneBounds_.minWs = glm::min(sceneBounds_.minWs, b.minWs);
    sceneBounds_.maxWs = glm::max(sceneBounds_.maxWs, b.maxWs);
  }
}

uint64_t Scene::triangleCount() const {
  uint64_t n = 0;
  for (const Instance& i : instances_) n += meshes_[i.mesh].indices.size() / 3;
  return n;
}

glm::dvec3 Scene::vertexWs(size_t instance, uint32_t index) const {
  const Instance& in = instances_[instance];
  return in.translationWs + glm::dvec3(in.linearWs * meshes_[in.mesh].vertices[index].position);
}

Scene Scene::makeTestScene(const TestSceneDesc& desc) {
  Scene scene;
  scene.originWs_ = desc.originWs;
  const double groundCz = -0.3 * desc.groundSideM;
  const uint32_t ground = scene.addMesh(
      makeGroundMesh(desc.terrain, desc.groundSideM, desc.terrainCells, 0.0, groundCz));
  const uint32_t cube = scene.addMesh(makeCubeMesh());
  const uint32_t sphere = scene.addMesh(makeSphereMesh(32, 16));
  auto height = [&](double x, double z) { return desc.terrain ? terrainHeight(x, z) : 0.0; };
  auto groundMin = [&](double x0, double z0, double x1, double z1) {
    double h = 1e300;
    for (int j = 0; j <= 8; ++j)
      for (int i = 0; i <= 8; ++i)
        h = std::min(h, height(x0 + (x1 - x0) * i / 8.0, z0 + (z1 - z0) * j / 8.0));
    return h;
  };

  scene.addInstance(
      {ground, desc.originWs, glm::mat3(1.0f), {0.55f, 0.65f, 0.45f, 1.0f}, InstanceKind::kGround});
  Rng rng{0x5EED1234ull};
  // Buildings on a jittered grid ahead of the camera (which sits near local z = +25).
  for (int row = 0; row < 5; ++row) {
    for (int col = 0; col < 5; ++col) {
      if ((row * 5 + col) % 3 == 1) continue;
      const double x = -40.0 + 20.0 * col + rng.range(-4.0, 4.0);
      const double z = -8.0 - 22.0 * row + rng.range(-4.0, 4.0);
      const glm::dvec3 size(rng.range(4.0, 9.0), rng.range(5.0, 16.0), rng.range(4.0, 9.0));
      const double base =
          groundMin(x - 0.5 * size.x, z - 0.5 * size.z, x + 0.5 * size.x, z + 0.5 * size.z) - 0.3;
      const glm::dvec3 c(x, base + 0.5 * size.y, z);
      scene.addInstance({cube,
                         desc.originWs + c,
                         scaleMatrix(size),
                         {0.75f, 0.6f, 0.5f, 1.0f},
                         InstanceKind::kBuilding});
    }
  }
  // Thin poles (they test small casters) and floating spheres (curved shadow edges).
  for (int k = 0; k < 10; ++k) {
    const double x = -35.0 + 7.5 * k + rng.range(-1.0, 1.0);
    const double z = 6.0 - 9.0 * k;
    const double h = rng.range(5.0, 9.0);
    const double base = height(x, z) - 0.3;
    const glm::dvec3 size(0.3, h, 0.3);
    scene.addInstance({cube,
                       desc.originWs + glm::dvec3(x, base + 0.5 * h, z),
                       scaleMatrix(size),
                       {0.3f, 0.3f, 0.35f, 1.0f},
                       InstanceKind::kPole});
  }
  // Small crates and short posts close to the camera: casters for the near cascades.
  for (int k = 0; k < 8; ++k) {
    const double x = -10.0 + 2.8 * k + rng.range(-0.8, 0.8);
    const double z = 19.0 - 2.2 * k + rng.range(-0.8, 0.8);
    const bool post = k % 3 == 2;
    const glm::dvec3 size =
        post ? glm::dvec3(0.15, rng.range(1.5, 2.5), 0.15)
             : glm::dvec3(rng.range(0.6, 1.6), rng.range(0.6, 1.4), rng.range(0.6, 1.6));
    const double base =
        groundMin(x - 0.5 * size.x, z - 0.5 * size.z, x + 0.5 * size.x, z + 0.5 * size.z) - 0.1;
    scene.addInstance({cube,
                       desc.originWs + glm::dvec3(x, base + 0.5 * size.y, z),
                       scaleMatrix(size),
                       {0.6f, 0.45f, 0.3f, 1.0f},
                       post ? InstanceKind::kPole : InstanceKind::kBuilding});
  }
  for (int k = 0; k < 7; ++k) {
    const double x = 30.0 - 10.0 * k + rng.range(-2.0, 2.0);
    const double z = 2.0 - 14.0 * k + rng.range(-2.0, 2.0);
    const double r = rng.range(1.2, 2.5);
    const double y = height(x, z) + r + rng.range(2.0, 5.0);
    scene.addInstance({sphere,
                       desc.originWs + glm::dvec3(x, y, z),
                       scaleMatrix(glm::dvec3(r)),
                       {0.3f, 0.6f, 0.3f, 1.0f},
                       InstanceKind::kSphere});
  }
  return scene;
}

std::vector<Receiver> Scene::sampleReceivers(uint32_t count, double wallFraction,
                                             const glm::dvec3& regionMin,
                                             const glm::dvec3& regionMax, uint32_t seed) const {
  struct Tri {
    size_t instance;
    uint32_t i0, i1, i2;
    double area;
  };
  std::vector<Tri> groundTris, wallTris;
  const glm::dvec3 lo = originWs_ + regionMin, hi = originWs_ + regionMax;
  auto inside = [&](const glm::dvec3& p) {
    return p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y && p.z <= hi.z;
  };
  for (size_t k = 0; k < instances_.size(); ++k) {
    const Instance& in = instances_[k];
    if (in.kind != InstanceKind::kGround && in.kind != InstanceKind::kBuilding) continue;
    const MeshData& m = meshes_[in.mesh];
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      const uint32_t i0 = m.indices[t], i1 = m.indices[t + 1], i2 = m.indices[t + 2];
      const glm::dvec3 a = vertexWs(k, i0), b = vertexWs(k, i1), c = vertexWs(k, i2);
      if (!inside((a + b + c) / 3.0)) continue;
      const glm::dvec3 cr = glm::cross(b - a, c - a);
      const double area = 0.5 * glm::length(cr);
      if (!(area > 0.0)) continue;
      if (in.kind == InstanceKind::kGround) {
        groundTris.push_back({k, i0, i1, i2, area});
      } else if (std::abs(cr.y) < 0.1 * glm::length(cr)) {
        wallTris.push_back({k, i0, i1, i2, area});
      }
    }
  }
  Rng rng{0xC0FFEEull ^ (uint64_t(seed) << 17)};
  std::vector<Receiver> out;
  out.reserve(count);
  auto pick = [&](const std::vector<Tri>& tris, uint32_t n) {
    if (tris.empty()) return;
    std::vector<double> cdf(tris.size());
    double sum = 0.0;
    for (size_t i = 0; i < tris.size(); ++i) cdf[i] = (sum += tris[i].area);
    for (uint32_t j = 0; j < n; ++j) {
      const double u = rng.uniform() * sum;
      const size_t ti = size_t(std::lower_bound(cdf.begin(), cdf.end(), u) - cdf.begin());
      const Tri& t = tris[std::min(ti, tris.size() - 1)];
      double r1 = rng.uniform(), r2 = rng.uniform();
      if (r1 + r2 > 1.0) {
        r1 = 1.0 - r1;
        r2 = 1.0 - r2;
      }
      const Instance& in = instances_[t.instance];
      const MeshData& m = meshes_[in.mesh];
      const glm::dvec3 a = vertexWs(t.instance, t.i0), b = vertexWs(t.instance, t.i1),
                       c = vertexWs(t.instance, t.i2);
      const glm::vec3 nMs = m.vertices[t.i0].normal * float(1.0 - r1 - r2) +
                            m.vertices[t.i1].normal * float(r1) +
                            m.vertices[t.i2].normal * float(r2);
      const glm::mat3 normalMatrix = glm::transpose(glm::inverse(in.linearWs));
      Receiver rcv;
      rcv.posWs = a + r1 * (b - a) + r2 * (c - a);
      rcv.normalWs = glm::normalize(normalMatrix * nMs);
      rcv.kind = in.kind;
      out.push_back(rcv);
    }
  };
  const uint32_t walls = wallTris.empty() ? 0u : uint32_t(std::lround(count * wallFraction));
  pick(groundTris, count - walls);
  pick(wallTris, walls);
  return out;
}

csm::CasterSet Scene::casterSet() const {
  csm::CasterSet set;
  set.reserve(instances_.size());
  for (const csm::AabbWs& b : bounds_) {
    const csm::Result<uint32_t> r = set.addBox(b.minWs, b.maxWs);
    if (!r.ok()) throw std::runtime_error("CasterSet: " + r.error().message());
  }
  set.build();
  return set;
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Ray (o, d) against a sphere: nearest t > tMin, or +inf.
double raySphere(const glm::dvec3& o, const glm::dvec3& d, const SphereWs& s, double tMin) {
  const glm::dvec3 oc = o - s.centerWs;
  const double b = glm::dot(oc, d);
  const double c = glm::dot(oc, oc) - s.radiusM * s.radiusM;
  const double disc = b * b - c * glm::dot(d, d);
  if (disc < 0.0) return kInf;
  const double sq = std::sqrt(disc);
  const double dd = glm::dot(d, d);
  const double t0 = (-b - sq) / dd;
  const double t1 = (-b + sq) / dd;
  if (t0 > tMin) return t0;
  if (t1 > tMin) return t1;
  return kInf;
}

// Ray against an AABB (slabs): nearest t > tMin, or +inf.
double rayBox(const glm::dvec3& o, const glm::dvec3& d, const csm::AabbWs& b, double tMin) {
  double t0 = -kInf, t1 = kInf;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-300) {
      if (o[a] < b.minWs[a] || o[a] > b.maxWs[a]) return kInf;
      continue;
    }
    double ta = (b.minWs[a] - o[a]) / d[a];
    double tb = (b.maxWs[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1) return kInf;
  if (t0 > tMin) return t0;
  if (t1 > tMin) return t1;
  return kInf;
}

}  // namespace

AnalyticShapes::RayHit AnalyticShapes::intersect(const glm::dvec3& o, const glm::dvec3& d) const {
  RayHit hit{kInf, false};
  if (d.y < 0.0) {
    const double t = -o.y / d.y;
    const glm::dvec3 q = o + t * d;
    if (std::abs(q.x - planeCenterWs.x) <= planeHalfM &&
        std::abs(q.z - planeCenterWs.z) <= planeHalfM) {
      hit = {t, true};
    }
  }
  for (const SphereWs& s : spheres) {
    const double t = raySphere(o, d, s, 0.0);
    if (t < hit.t) hit = {t, false};
  }
  for (const csm::AabbWs& b : boxes) {
    const double t = rayBox(o, d, b, 0.0);
    if (t < hit.t) hit = {t, false};
  }
  return hit;
}

bool AnalyticShapes::occluded(const glm::dvec3& posWs, const glm::dvec3& toLight) const {
  for (const SphereWs& s : spheres) {
    if (raySphere(posWs, toLight, s, 1e-6) < kInf) return true;
  }
  for (const csm::AabbWs& b : boxes) {
    if (rayBox(posWs, toLight, b, 1e-6) < kInf) return true;
  }
  return false;
}

Scene AnalyticShapes::scene(int sphereSegments, int sphereRings) const {
  Scene scene;
  // Ground: a 2 x 2 quad in xz scaled by the instance.
  MeshData ground;
  ground.name = "ground";
  ground.vertices = {{{-1, 0, -1}, {0, 1, 0}},
                     {{1, 0, -1}, {0, 1, 0}},
                     {{1, 0, 1}, {0, 1, 0}},
                     {{-1, 0, 1}, {0, 1, 0}}};
  ground.indices = {0, 2, 1, 0, 3, 2};
  const uint32_t plane = scene.addMesh(std::move(ground));
  const uint32_t sphere = scene.addMesh(makeSphereMesh(sphereSegments, sphereRings));
  const uint32_t cube = scene.addMesh(makeCubeMesh());
  auto add = [&](uint32_t mesh, const glm::dvec3& t, const glm::dvec3& scale,
                 const glm::vec4& color, InstanceKind kind, const csm::AabbWs& box) {
    const glm::mat3 linear(glm::vec3(scale.x, 0, 0), glm::vec3(0, scale.y, 0),
                           glm::vec3(0, 0, scale.z));
    scene.addInstance({mesh, t, linear, color, kind}, box);
  };
  // The ground receives and casts (so that self-shadowing acne would show).
  add(plane, planeCenterWs, {planeHalfM, 1.0, planeHalfM}, {0.8f, 0.8f, 0.8f, 1.0f},
      InstanceKind::kGround,
      {planeCenterWs - glm::dvec3(planeHalfM, 0.0, planeHalfM),
       planeCenterWs + glm::dvec3(planeHalfM, 0.0, planeHalfM)});
  for (const SphereWs& s : spheres) {
    add(sphere, s.centerWs, glm::dvec3(s.radiusM), {0.9f, 0.3f, 0.2f, 1.0f}, InstanceKind::kSphere,
        {s.centerWs - glm::dvec3(s.radiusM), s.centerWs + glm::dvec3(s.radiusM)});
  }
  for (const csm::AabbWs& b : boxes) {
    add(cube, 0.5 * (b.minWs + b.maxWs), b.maxWs - b.minWs, {0.2f, 0.4f, 0.9f, 1.0f},
        InstanceKind::kBuilding, b);
  }
  return scene;
}

}  // namespace glue
