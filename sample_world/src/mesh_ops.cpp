// OpenMesh side of the sample world: normals, Decimater LODs, mesh file loading, hashes.
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "mesh_ops.hpp"
#include "mesh_parse.hpp"

namespace world {

namespace {

using OmMesh = OpenMesh::TriMesh_ArrayKernelT<>;

// Fills an OpenMesh mesh from positions and triangles. A triangle OpenMesh refuses (it would
// make an edge or vertex non-manifold) gets vertices of its own instead of being dropped.
void toOpenMesh(const std::vector<glm::vec3>& positions, const std::vector<std::uint32_t>& indices,
                OmMesh& mesh) {
  std::vector<OmMesh::VertexHandle> handles;
  handles.reserve(positions.size());
  for (const glm::vec3& p : positions) handles.push_back(mesh.add_vertex({p.x, p.y, p.z}));
  for (std::size_t t = 0; t + 2 < indices.size(); t += 3) {
    const auto a = handles[indices[t]], b = handles[indices[t + 1]], c = handles[indices[t + 2]];
    if (a == b || b == c || a == c) continue;
    if (!mesh.add_face(a, b, c).is_valid()) {
      const auto pa = mesh.point(a), pb = mesh.point(b), pc = mesh.point(c);
      mesh.add_face(mesh.add_vertex(pa), mesh.add_vertex(pb), mesh.add_vertex(pc));
    }
  }
}

// Extracts positions, OpenMesh vertex normals and triangles (unreferenced vertices dropped).
MeshData fromOpenMesh(OmMesh& mesh) {
  mesh.request_face_normals();
  mesh.request_vertex_normals();
  mesh.update_normals();
  MeshData out;
  std::vector<std::int64_t> remap(mesh.n_vertices(), -1);
  for (const auto fh : mesh.faces()) {
    if (mesh.status(fh).deleted()) continue;
    for (const auto vh : mesh.fv_range(fh)) {
      std::int64_t& r = remap[static_cast<std::size_t>(vh.idx())];
      if (r < 0) {
        r = static_cast<std::int64_t>(out.positions.size());
        const auto p = mesh.point(vh);
        auto n = mesh.normal(vh);
        const float len = n.length();
        if (!(len > 1e-20f)) n = mesh.normal(fh);
        out.positions.emplace_back(p[0], p[1], p[2]);
        out.normals.push_back(glm::normalize(glm::vec3(n[0], n[1], n[2])));
      }
      out.indices.push_back(static_cast<std::uint32_t>(r));
    }
  }
  for (glm::vec3& n : out.normals) {
    if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z)) n = {0.0f, 1.0f, 0.0f};
  }
  return out;
}

}  // namespace

MeshData finishMesh(const std::vector<glm::vec3>& positions,
                    const std::vector<std::uint32_t>& indices) {
  OmMesh mesh;
  mesh.request_face_status();
  toOpenMesh(positions, indices, mesh);
  return fromOpenMesh(mesh);
}

MeshData decimate(const MeshData& in, double targetFraction) {
  OmMesh mesh;
  mesh.request_vertex_status();
  mesh.request_edge_status();
  mesh.request_halfedge_status();
  mesh.request_face_status();
  toOpenMesh(in.positions, in.indices, mesh);
  // Boundary vertices stay: terrain chunks keep matching edges (no cracks between LODs of
  // neighbours), open pieces keep their outline.
  for (const auto vh : mesh.vertices()) {
    if (mesh.is_boundary(vh)) mesh.status(vh).set_locked(true);
  }
  mesh.request_face_normals();
  mesh.update_face_normals();
  using Decimater = OpenMesh::Decimater::DecimaterT<OmMesh>;
  Decimater decimater(mesh);
  OpenMesh::Decimater::ModQuadricT<OmMesh>::Handle quadric;
  OpenMesh::Decimater::ModNormalFlippingT<OmMesh>::Handle flipping;
  decimater.add(quadric);
  decimater.add(flipping);
  decimater.module(quadric).unset_max_err();
  decimater.module(flipping).set_max_normal_deviation(75.0);
  if (!decimater.initialize()) return in;
  const auto target = static_cast<std::size_t>(
      std::max(4.0, std::floor(static_cast<double>(mesh.n_vertices()) * targetFraction)));
  decimater.decimate_to(target);
  mesh.garbage_collection();
  MeshData out = fromOpenMesh(mesh);
  if (out.indices.empty()) return in;
  return out;
}

namespace {

// Squared distance from p to triangle abc (closest point by Voronoi regions of the triangle).
float pointTriangleDistance2(const glm::vec3& p, const glm::vec3& a, const glm::vec3& b,
                             const glm::vec3& c) {
  const glm::vec3 ab = b - a, ac = c - a, ap = p - a;
  const float d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  auto d2To = [&](const glm::vec3& q) { return glm::dot(p - q, p - q); };
  if (d1 <= 0.0f && d2 <= 0.0f) return d2To(a);
  const glm::vec3 bp = p - b;
  const float d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0.0f && d4 <= d3) return d2To(b);
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0f && d1 >= 0.0f && d3 <= 0.0f) return d2To(a + ab * (d1 / (d1 - d3)));
  const glm::vec3 cp = p - c;
  const float d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0.0f && d5 <= d6) return d2To(c);
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0f && d2 >= 0.0f && d6 <= 0.0f) return d2To(a + ac * (d2 / (d2 - d6)));
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0.0f && (d4 - d3) >= 0.0f && (d5 - d6) >= 0.0f) {
    return d2To(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
  }
  const float denom = va + vb + vc;
  if (!(std::abs(denom) > 0.0f)) {  // degenerate triangle: its edges' end points
    return std::min({d2To(a), d2To(b), d2To(c)});
  }
  return d2To(a + ab * (vb / denom) + ac * (vc / denom));
}

// Largest distance from `from`'s vertices and triangle centroids to the surface of `to`.
double oneSidedDistance(const MeshData& from, const MeshData& to) {
  struct Tri {
    glm::vec3 a, b, c, lo, hi;
  };
  std::vector<Tri> tris;
  tris.reserve(to.indices.size() / 3);
  for (std::size_t t = 0; t + 2 < to.indices.size(); t += 3) {
    const glm::vec3 a = to.positions[to.indices[t]], b = to.positions[to.indices[t + 1]],
                    c = to.positions[to.indices[t + 2]];
    tris.push_back({a, b, c, glm::min(a, glm::min(b, c)), glm::max(a, glm::max(b, c))});
  }
  if (tris.empty()) return from.positions.empty() ? 0.0 : std::numeric_limits<double>::infinity();
  std::vector<glm::vec3> points = from.positions;
  for (std::size_t t = 0; t + 2 < from.indices.size(); t += 3) {
    points.push_back((from.positions[from.indices[t]] + from.positions[from.indices[t + 1]] +
                      from.positions[from.indices[t + 2]]) /
                     3.0f);
  }
  float worst2 = 0.0f;
  for (const glm::vec3& p : points) {
    float best2 = std::numeric_limits<float>::max();
    for (const Tri& tri : tris) {
      const glm::vec3 gap = glm::max(glm::max(tri.lo - p, p - tri.hi), glm::vec3(0.0f));
      if (glm::dot(gap, gap) >= best2) continue;
      best2 = std::min(best2, pointTriangleDistance2(p, tri.a, tri.b, tri.c));
      if (best2 <= worst2) break;  // cannot raise the maximum
    }
    worst2 = std::max(worst2, best2);
  }
  return std::sqrt(static_cast<double>(worst2));
}

}  // namespace

double simplificationErrorM(const MeshData& original, const MeshData& simplified) {
  return std::max(oneSidedDistance(original, simplified), oneSidedDistance(simplified, original));
}

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}

}  // namespace

std::optional<MeshData> loadMeshFile(const std::string& path, double sizeM, WorldError* error) {
  auto fail = [&](const std::string& reason) -> std::optional<MeshData> {
    if (error) error->message = "--mesh " + path + ": " + reason;
    return std::nullopt;
  };
  namespace fs = std::filesystem;
  if (path.empty()) {
    if (error) error->message = "--mesh: the path is empty (allowed a .obj, .ply or .off file)";
    return std::nullopt;
  }
  if (!(sizeM > 0.0) || !std::isfinite(sizeM) || sizeM > kMaxMeshCoordinate) {
    return fail("the target size " + num(sizeM) + " m is outside (0, " + num(kMaxMeshCoordinate) +
                "]");
  }
  std::error_code ec;
  if (!fs::exists(path, ec)) return fail("file not found");
  if (!fs::is_regular_file(path, ec)) return fail("not a regular file");
  const auto size = fs::file_size(path, ec);
  if (ec) return fail("cannot read its size (" + ec.message() + ")");
  if (size == 0) return fail("file is empty (0 bytes)");
  if (size > kMaxMeshFileBytes) {
    return fail("the file has " + std::to_string(size) + " bytes, allowed at most " +
                std::to_string(kMaxMeshFileBytes));
  }
  const std::string ext = lower(fs::path(path).extension().string().substr(
      fs::path(path).extension().string().empty() ? 0 : 1));
  if (ext != "obj" && ext != "ply" && ext != "off") {
    return fail("unsupported extension '." + ext + "' (allowed: .obj, .ply, .off)");
  }
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    if (!in) return fail("cannot be opened for reading");
    bytes.resize(static_cast<std::size_t>(size));
    in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (in.gcount() != static_cast<std::streamsize>(bytes.size())) {
      return fail("could not read all " + std::to_string(size) + " bytes");
    }
  }
  std::string parseError;
  std::optional<ParsedMesh> parsed = parseMeshBytes(bytes, ext, &parseError);
  bytes.clear();
  bytes.shrink_to_fit();
  if (!parsed) return fail(parseError);
  std::optional<MeshData> data = meshFromParsed(*parsed, sizeM, &parseError);
  if (!data) return fail(parseError);
  return data;
}

std::optional<MeshData> meshFromParsed(const ParsedMesh& parsed, double sizeM, std::string* error) {
  auto fail = [&](const std::string& reason) -> std::optional<MeshData> {
    if (error) *error = reason;
    return std::nullopt;
  };
  const std::size_t n = parsed.vertexCount();
  if (parsed.triangles.empty()) return fail("contains no triangles (no face data)");
  // Every coordinate as written: finite and within range (so that extents and the scale below
  // are finite in double); only vertices that triangles use count for the size.
  static constexpr const char* kAxis[3] = {"x", "y", "z"};
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  std::vector<bool> used(n, false);
  for (const std::uint32_t i : parsed.triangles) used[i] = true;
  for (std::size_t v = 0; v < n; ++v) {
    for (int a = 0; a < 3; ++a) {
      const double c = parsed.xyz[3 * v + static_cast<std::size_t>(a)];
      if (!std::isfinite(c) || std::abs(c) > kMaxMeshCoordinate) {
        return fail("vertex " + std::to_string(v) + ": " + kAxis[a] + " = " + num(c) +
                    " is outside the allowed [-" + num(kMaxMeshCoordinate) + ", " +
                    num(kMaxMeshCoordinate) + "]");
      }
      if (!used[v]) continue;
      lo[a] = std::min(lo[a], c);
      hi[a] = std::max(hi[a], c);
    }
  }
  const glm::dvec3 ext3 = hi - lo;
  const double largest = std::max({ext3.x, ext3.y, ext3.z});
  if (!(largest >= kMinMeshExtent)) {
    return fail("its largest extent " + num(largest) + " is below the allowed minimum " +
                num(kMinMeshExtent) + " (all vertices (nearly) coincide)");
  }
  const double scale = sizeM / largest;
  const glm::dvec3 base(0.5 * (lo.x + hi.x), lo.y, 0.5 * (lo.z + hi.z));
  std::vector<glm::vec3> positions(n);
  for (std::size_t v = 0; v < n; ++v) {
    const glm::dvec3 p(parsed.xyz[3 * v], parsed.xyz[3 * v + 1], parsed.xyz[3 * v + 2]);
    const glm::dvec3 q = (p - base) * scale;
    // After the transform: finite and within the target size (checked, not assumed).
    for (int a = 0; a < 3; ++a) {
      if (!std::isfinite(q[a]) || std::abs(q[a]) > sizeM * 1.0001) {
        return fail("vertex " + std::to_string(v) + ": scaled " + kAxis[a] + " = " + num(q[a]) +
                    " is outside the allowed [-" + num(sizeM) + ", " + num(sizeM) + "] m");
      }
    }
    positions[v] = glm::vec3(q);
  }
  // OpenMesh reports each non-manifold face it is given on its error stream ("complex vertex");
  // finishMesh handles them (own vertices), so a user's file does not flood stderr.
  omerr().disable();
  MeshData data = finishMesh(positions, parsed.triangles);
  omerr().enable();
  if (data.indices.empty()) return fail("contains no triangles (every face is degenerate)");
  for (const glm::vec3& p : data.positions) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      return fail("a vertex is not finite after OpenMesh's processing");
    }
  }
  return data;
}

std::uint64_t hashBytes(std::uint64_t h, const void* data, std::size_t size) noexcept {
  const auto* b = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < size; ++i) {
    h ^= b[i];
    h *= 1099511628211ull;
  }
  return h;
}

std::uint64_t meshHash(const MeshData& mesh) noexcept {
  std::uint64_t h = 14695981039346656037ull;
  h = hashBytes(h, mesh.positions.data(), mesh.positions.size() * sizeof(glm::vec3));
  h = hashBytes(h, mesh.normals.data(), mesh.normals.size() * sizeof(glm::vec3));
  h = hashBytes(h, mesh.indices.data(), mesh.indices.size() * sizeof(std::uint32_t));
  return h;
}

}  // namespace world
