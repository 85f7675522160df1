// OpenMesh side of the sample world: normals, Decimater LODs, mesh file loading, hashes.
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <OpenMesh/Tools/Decimater/BaseDecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModAspectRatioT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>
#include <OpenMesh/Tools/Utils/HeapT.hh>

#include <algorithm>
#include <array>
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

// OpenMesh's triangle mesh with the two connectivity queries the Decimater makes for every
// candidate collapse written inline. The distribution's OpenMesh library is built with its
// assertions on: its out-of-line TriConnectivity::is_collapse_ok builds and compares a type
// name at each of its status reads, three quarters of the decimation time of a 2-million-
// triangle mesh. These are the same tests; DecimaterT calls them on its mesh type, so they hide
// the library's.
struct OmMesh : OpenMesh::TriMesh_ArrayKernelT<> {
  // Whether collapsing v0v1 (v0 into v1) keeps the mesh manifold: the edge and its vertices
  // alive, no triangle beside it with both its other edges on the boundary, the two one-rings
  // sharing no vertex but those of the triangles beside the edge (the link condition), and no
  // interior edge joining two boundary vertices.
  bool is_collapse_ok(HalfedgeHandle v0v1) {
    if (status(edge_handle(v0v1)).deleted()) return false;
    const HalfedgeHandle v1v0 = opposite_halfedge_handle(v0v1);
    const VertexHandle v0 = to_vertex_handle(v1v0), v1 = to_vertex_handle(v0v1);
    if (status(v0).deleted() || status(v1).deleted()) return false;
    const bool left = !is_boundary(v0v1), right = !is_boundary(v1v0);
    auto dangling = [&](HalfedgeHandle h) {
      const HalfedgeHandle h1 = next_halfedge_handle(h), h2 = next_halfedge_handle(h1);
      return is_boundary(opposite_halfedge_handle(h1)) && is_boundary(opposite_halfedge_handle(h2));
    };
    if ((left && dangling(v0v1)) || (right && dangling(v1v0))) return false;
    const VertexHandle vl = to_vertex_handle(next_halfedge_handle(v0v1));
    const VertexHandle vr = to_vertex_handle(next_halfedge_handle(v1v0));
    // Mark v1's neighbours (a stamp per vertex: linear in the valences, poles included).
    if (stamp_.size() != n_vertices()) stamp_.assign(n_vertices(), 0);
    if (++stampNow_ == 0) {
      std::fill(stamp_.begin(), stamp_.end(), 0u);
      stampNow_ = 1;
    }
    for (const VertexHandle w : vv_range(v1)) stamp_[static_cast<std::size_t>(w.idx())] = stampNow_;
    for (const VertexHandle w : vv_range(v0)) {
      if (stamp_[static_cast<std::size_t>(w.idx())] == stampNow_ && !(left && w == vl) &&
          !(right && w == vr)) {
        return false;
      }
    }
    return !(is_boundary(v0) && is_boundary(v1) && left && right);
  }

  // The halfedge from `from` to `to`, invalid when they share no edge.
  HalfedgeHandle find_halfedge(VertexHandle from, VertexHandle to) const {
    for (const HalfedgeHandle h : voh_range(from)) {
      if (to_vertex_handle(h) == to) return h;
    }
    return HalfedgeHandle();
  }

 private:
  std::vector<std::uint32_t> stamp_;
  std::uint32_t stampNow_ = 0;
};

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

// A triangle with its (unnormalised) normal, for many point distance queries.
struct FaceGeometry {
  glm::vec3 a, b, c, n;
  float nn = 0.0f;  // |n|^2
};

FaceGeometry faceGeometry(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  const glm::vec3 n = glm::cross(b - a, c - a);
  return {a, b, c, n, glm::dot(n, n)};
}

// Whether p is at least sqrt(d2) from f's plane, hence from f (one dot product; false for a
// degenerate face, whose plane is undefined).
bool beyondPlane(const FaceGeometry& f, const glm::vec3& p, float d2) {
  const float s = glm::dot(f.n, p - f.a);
  return s * s >= d2 * f.nn && f.nn > 0.0f;
}

bool within(const FaceGeometry& f, const glm::vec3& p, float d2) {
  return !beyondPlane(f, p, d2) && pointTriangleDistance2(p, f.a, f.b, f.c) <= d2;
}

glm::vec3 toGlm(const OmMesh::Point& p) {
  return {p[0], p[1], p[2]};
}

// Keeps every vertex a collapse removes within a tolerance of the surface, the rule of OpenMesh's
// ModHausdorffT: each removed vertex is kept by its nearest face, and a collapse is legal only
// while every point kept by the faces around the removed vertex (and the vertex itself) lies
// within the tolerance of one of the faces left around it. Evaluated without copying the points,
// each point tried first against the face that keeps it, each face rejected by its plane's
// distance before the exact distance (ModHausdorffT copies every point of the ring and measures
// it against each face in turn: most of a large mesh's LOD time).
template <class MeshT>
class ModRemovedPointsT : public OpenMesh::Decimater::ModBaseT<MeshT> {
 public:
  DECIMATING_MODULE(ModRemovedPointsT, MeshT, RemovedPoints);

  explicit ModRemovedPointsT(MeshT& mesh) : Base(mesh, true) { mesh.add_property(points_); }
  ~ModRemovedPointsT() override { Base::mesh().remove_property(points_); }
  ModRemovedPointsT(const ModRemovedPointsT&) = delete;
  ModRemovedPointsT& operator=(const ModRemovedPointsT&) = delete;

  void setTolerance(double toleranceM) {
    tolerance2_ = static_cast<float>(toleranceM * toleranceM);
  }

  float collapse_priority(const CollapseInfo& ci) override {
    Mesh& mesh = Base::mesh();
    after_.clear();
    ring_.clear();
    for (const auto fh : mesh.vf_range(ci.v0)) {
      std::size_t k = kNone;
      if (fh != ci.fl && fh != ci.fr) {
        k = after_.size();
        after_.push_back(faceAfter(fh, ci.v0, ci.p1));
      }
      ring_.push_back({fh, k});
    }
    if (!covered(toGlm(ci.p0), kNone)) return float(Base::ILLEGAL_COLLAPSE);
    for (const auto& [fh, k] : ring_) {
      for (const glm::vec3& p : mesh.property(points_, fh)) {
        if (!covered(p, k)) return float(Base::ILLEGAL_COLLAPSE);
      }
    }
    return float(Base::LEGAL_COLLAPSE);
  }

  void preprocess_collapse(const CollapseInfo& ci) override {
    moved_.clear();
    for (const auto fh : Base::mesh().vf_range(ci.v0)) {
      if (fh != ci.fl && fh != ci.fr) moved_.push_back(fh);
    }
  }

  // The points of the faces that moved or went (and the removed vertex) go to their nearest face
  // around the kept vertex; the other faces keep theirs.
  void postprocess_collapse(const CollapseInfo& ci) override {
    Mesh& mesh = Base::mesh();
    after_.clear();
    afterFaces_.clear();
    for (const auto fh : mesh.vf_range(ci.v1)) {
      afterFaces_.push_back(fh);
      after_.push_back(faceAfter(fh, ci.v1, ci.p1));
    }
    if (after_.empty()) return;
    pending_.clear();
    for (const auto fh : moved_) {
      const std::size_t own = static_cast<std::size_t>(
          std::find(afterFaces_.begin(), afterFaces_.end(), fh) - afterFaces_.begin());
      take(fh, own);
    }
    if (ci.fl.is_valid()) take(ci.fl, kNone);
    if (ci.fr.is_valid()) take(ci.fr, kNone);
    pending_.push_back({toGlm(ci.p0), kNone});
    for (const auto& [p, own] : pending_) {
      std::size_t best = own < after_.size() ? own : 0;
      float best2 = pointTriangleDistance2(p, after_[best].a, after_[best].b, after_[best].c);
      for (std::size_t k = 0; k < after_.size(); ++k) {
        if (k == best || beyondPlane(after_[k], p, best2)) continue;
        const float d2 = pointTriangleDistance2(p, after_[k].a, after_[k].b, after_[k].c);
        if (d2 < best2) {
          best2 = d2;
          best = k;
        }
      }
      mesh.property(points_, afterFaces_[best]).push_back(p);
    }
  }

 private:
  static constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

  // Face fh with vertex v at p.
  FaceGeometry faceAfter(typename Mesh::FaceHandle fh, typename Mesh::VertexHandle v,
                         const typename Mesh::Point& p) {
    glm::vec3 q[3];
    int i = 0;
    for (const auto vh : Base::mesh().fv_range(fh)) {
      q[i++] = toGlm(vh == v ? p : Base::mesh().point(vh));
    }
    return faceGeometry(q[0], q[1], q[2]);
  }

  // Whether p lies within the tolerance of a face of after_, face `first` tried first.
  bool covered(const glm::vec3& p, std::size_t first) const {
    if (first < after_.size() && within(after_[first], p, tolerance2_)) return true;
    for (std::size_t k = 0; k < after_.size(); ++k) {
      if (k != first && within(after_[k], p, tolerance2_)) return true;
    }
    return false;
  }

  void take(typename Mesh::FaceHandle fh, std::size_t own) {
    std::vector<glm::vec3>& points = Base::mesh().property(points_, fh);
    for (const glm::vec3& p : points) pending_.push_back({p, own});
    points.clear();
    points.shrink_to_fit();
  }

  OpenMesh::FPropHandleT<std::vector<glm::vec3>> points_;
  float tolerance2_ = 0.0f;
  // Scratch, kept to save allocations.
  std::vector<FaceGeometry> after_;
  std::vector<typename Mesh::FaceHandle> afterFaces_, moved_;
  std::vector<std::pair<typename Mesh::FaceHandle, std::size_t>> ring_;
  std::vector<std::pair<glm::vec3, std::size_t>> pending_;
};

// Fills a mesh for decimation: status flags, boundary vertices locked, face normals.
void toDecimatable(const MeshData& in, OmMesh& mesh) {
  mesh.request_vertex_status();
  mesh.request_edge_status();
  mesh.request_halfedge_status();
  mesh.request_face_status();
  toOpenMesh(in.positions, in.indices, mesh);
  for (const auto vh : mesh.vertices()) {
    if (mesh.is_boundary(vh)) mesh.status(vh).set_locked(true);
  }
  mesh.request_face_normals();
  mesh.update_face_normals();
}

// OpenMesh's DecimaterT with the same collapses in the same order (a heap of vertices keyed by
// the priority of their cheapest legal collapse), but a vertex's candidate collapses are ordered
// by priority first and tested for legality (topology, then the binary modules, cheapest first)
// only until one passes: DecimaterT tests every candidate and keeps the cheapest legal one, the
// same collapse at several times the cost.
class CheapestFirstDecimater : public OpenMesh::Decimater::BaseDecimaterT<OmMesh> {
 public:
  using Module = OpenMesh::Decimater::ModBaseT<OmMesh>;

  explicit CheapestFirstDecimater(OmMesh& mesh) : BaseDecimaterT(mesh), mesh_(mesh) {
    mesh_.add_property(priority_);
    mesh_.add_property(position_);
    mesh_.add_property(target_);
  }
  ~CheapestFirstDecimater() {
    mesh_.remove_property(priority_);
    mesh_.remove_property(position_);
    mesh_.remove_property(target_);
  }
  CheapestFirstDecimater(const CheapestFirstDecimater&) = delete;
  CheapestFirstDecimater& operator=(const CheapestFirstDecimater&) = delete;

  /// Collapses until no vertex has a legal collapse: `priority` orders them (the module
  /// initialize() chose), `binary` are the added binary modules, cheapest first.
  void decimate(Module& priority, const std::vector<Module*>& binary) {
    priorityModule_ = &priority;
    binary_ = binary;
    Heap heap(HeapInterface{mesh_, priority_, position_});
    heap_ = &heap;
    heap.reserve(mesh_.n_vertices());
    for (const auto vh : mesh_.vertices()) {
      heap.reset_heap_position(vh);
      if (!mesh_.status(vh).deleted()) heapVertex(vh);
    }
    std::vector<OmMesh::VertexHandle> support;
    while (!heap.empty()) {
      const OmMesh::VertexHandle vh = heap.front();
      const OmMesh::HalfedgeHandle v0v1 = mesh_.property(target_, vh);
      heap.pop_front();
      CollapseInfo ci(mesh_, v0v1);
      if (!is_collapse_legal(ci)) continue;  // the mesh changed since it was queued
      support.clear();
      for (const auto w : mesh_.vv_range(ci.v0)) support.push_back(w);
      preprocess_collapse(ci);
      mesh_.collapse(v0v1);
      for (const auto fh : mesh_.vf_range(ci.v1)) {
        if (!mesh_.status(fh).deleted()) mesh_.set_normal(fh, mesh_.calc_face_normal(fh));
      }
      postprocess_collapse(ci);
      for (const auto w : support) heapVertex(w);
    }
    heap_ = nullptr;
  }

 private:
  struct HeapInterface {
    OmMesh& mesh;
    OpenMesh::VPropHandleT<float> priority;
    OpenMesh::VPropHandleT<int> position;
    bool less(OmMesh::VertexHandle a, OmMesh::VertexHandle b) {
      return mesh.property(priority, a) < mesh.property(priority, b);
    }
    bool greater(OmMesh::VertexHandle a, OmMesh::VertexHandle b) {
      return mesh.property(priority, a) > mesh.property(priority, b);
    }
    int get_heap_position(OmMesh::VertexHandle v) { return mesh.property(position, v); }
    void set_heap_position(OmMesh::VertexHandle v, int i) { mesh.property(position, v) = i; }
  };
  using Heap = OpenMesh::Utils::HeapT<OmMesh::VertexHandle, HeapInterface>;

  // Queues vh with its cheapest legal collapse (ties: the first around it), or unqueues it.
  void heapVertex(OmMesh::VertexHandle vh) {
    candidates_.clear();
    for (const auto heh : mesh_.voh_range(vh)) {
      candidates_.push_back({priorityModule_->collapse_priority(CollapseInfo(mesh_, heh)), heh});
    }
    std::stable_sort(candidates_.begin(), candidates_.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    OmMesh::HalfedgeHandle target;
    float best = std::numeric_limits<float>::max();
    for (const auto& [prio, heh] : candidates_) {
      if (!(prio >= 0.0f && prio < best)) continue;
      const CollapseInfo ci(mesh_, heh);
      if (!is_collapse_legal(ci)) continue;
      bool legal = true;
      for (Module* m : binary_) {
        if (m->collapse_priority(ci) < 0.0f) {
          legal = false;
          break;
        }
      }
      if (legal) {
        target = heh;
        best = prio;
        break;
      }
    }
    mesh_.property(target_, vh) = target;
    if (target.is_valid()) {
      mesh_.property(priority_, vh) = best;
      if (heap_->is_stored(vh)) {
        heap_->update(vh);
      } else {
        heap_->insert(vh);
      }
    } else {
      if (heap_->is_stored(vh)) heap_->remove(vh);
      mesh_.property(priority_, vh) = -1.0f;
    }
  }

  OmMesh& mesh_;
  OpenMesh::VPropHandleT<float> priority_;
  OpenMesh::VPropHandleT<int> position_;
  OpenMesh::VPropHandleT<OmMesh::HalfedgeHandle> target_;
  Module* priorityModule_ = nullptr;
  std::vector<Module*> binary_;
  Heap* heap_ = nullptr;
  std::vector<std::pair<float, OmMesh::HalfedgeHandle>> candidates_;
};

// One Decimater run over a mesh: quadric error orders the collapses; a collapse is legal only
// while no face normal turns by more than 60 degrees, no triangle gets thinner than 1:10 (the
// cheap tests first) and every removed vertex stays within the tolerance of the new surface
// (ModRemovedPointsT). decimateWithin() again with a larger tolerance goes on from where the
// run stopped: each collapse still kept every removed vertex within the tolerance of its time.
class BoundedDecimation {
 public:
  explicit BoundedDecimation(const MeshData& in) : decimater_(mesh_) {
    toDecimatable(in, mesh_);
    decimater_.add(quadric_);
    decimater_.add(flipping_);
    decimater_.add(aspect_);
    decimater_.add(points_);
    decimater_.module(quadric_).unset_max_err();
    decimater_.module(flipping_).set_max_normal_deviation(60.0);
    decimater_.module(aspect_).set_aspect_ratio(10.0f);
    decimater_.module(aspect_).set_binary(true);
    ok_ = decimater_.initialize();
  }

  /// Collapses while every removed vertex stays within `toleranceM`.
  void decimateWithin(double toleranceM) {
    if (!ok_) return;
    decimater_.module(points_).setTolerance(toleranceM);
    decimater_.decimate(
        decimater_.module(quadric_),
        {&decimater_.module(flipping_), &decimater_.module(aspect_), &decimater_.module(points_)});
  }
  /// The mesh now (ends the run).
  [[nodiscard]] MeshData finish() {
    mesh_.garbage_collection();
    return fromOpenMesh(mesh_);
  }

 private:
  OmMesh mesh_;
  CheapestFirstDecimater decimater_;
  OpenMesh::Decimater::ModQuadricT<OmMesh>::Handle quadric_;
  OpenMesh::Decimater::ModNormalFlippingT<OmMesh>::Handle flipping_;
  OpenMesh::Decimater::ModAspectRatioT<OmMesh>::Handle aspect_;
  ModRemovedPointsT<OmMesh>::Handle points_;
  bool ok_ = false;
};

// One error-bounded Decimater run of `in` (the mesh itself when nothing is left).
MeshData decimateWithin(const MeshData& in, double toleranceM) {
  BoundedDecimation run(in);
  run.decimateWithin(toleranceM);
  MeshData out = run.finish();
  if (out.indices.empty()) return in;
  return out;
}

}  // namespace

namespace {

// Triangles of a mesh bucketed in a uniform grid for nearest-surface queries: cells about one
// and a half times the mean triangle's size (a surface mesh fills few of the cells a
// triangles-per-volume rule sizes), 8 million at most, stored as one index array.
class TriangleGrid {
 public:
  explicit TriangleGrid(const MeshData& m) {
    tris_.reserve(m.indices.size() / 3);
    double meanExtent = 0.0;
    for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      const glm::vec3 a = m.positions[m.indices[t]], b = m.positions[m.indices[t + 1]],
                      c = m.positions[m.indices[t + 2]];
      tris_.push_back({a, b, c});
      const glm::vec3 tlo = glm::min(a, glm::min(b, c)), thi = glm::max(a, glm::max(b, c));
      lo_ = glm::min(lo_, tlo);
      hi_ = glm::max(hi_, thi);
      const glm::vec3 e = thi - tlo;
      meanExtent += std::max({e.x, e.y, e.z});
    }
    if (tris_.empty()) return;
    meanExtent /= static_cast<double>(tris_.size());
    const glm::vec3 extent = glm::max(hi_ - lo_, glm::vec3(1e-6f));
    constexpr double kMaxCells = 8e6;
    cell_ = std::max(static_cast<float>(1.5 * meanExtent),
                     std::max({extent.x, extent.y, extent.z}) / 1024.0f);
    for (;; cell_ *= 1.25f) {
      for (int k = 0; k < 3; ++k) {
        n_[k] = std::max(1, static_cast<int>(std::ceil(extent[k] / cell_)));
      }
      if (double(n_.x) * n_.y * n_.z <= kMaxCells) break;
    }
    // Two passes over the triangles' cell ranges: counts, then the triangles in place.
    start_.assign(static_cast<std::size_t>(n_[0]) * n_[1] * n_[2] + 1, 0);
    auto forCells = [&](const Tri& tri, auto&& f) {
      const glm::ivec3 c0 = cellOf(glm::min(tri.a, glm::min(tri.b, tri.c)));
      const glm::ivec3 c1 = cellOf(glm::max(tri.a, glm::max(tri.b, tri.c)));
      for (int z = c0.z; z <= c1.z; ++z) {
        for (int y = c0.y; y <= c1.y; ++y) {
          for (int x = c0.x; x <= c1.x; ++x) f(index({x, y, z}));
        }
      }
    };
    for (const Tri& tri : tris_) forCells(tri, [&](std::size_t i) { ++start_[i + 1]; });
    for (std::size_t i = 1; i < start_.size(); ++i) start_[i] += start_[i - 1];
    std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
    ids_.resize(start_.back());
    for (std::uint32_t t = 0; t < tris_.size(); ++t) {
      forCells(tris_[t], [&](std::size_t i) { ids_[fill[i]++] = t; });
    }
  }
  [[nodiscard]] bool empty() const { return tris_.empty(); }

  // Squared distance from p to the surface, or any value <= stopBelow2 once it is known to be
  // at most that (the caller only needs to know it does not raise its maximum).
  [[nodiscard]] float distance2(const glm::vec3& p, float stopBelow2) const {
    const glm::ivec3 c = cellOf(p);
    const glm::vec3 gap = glm::max(glm::max(lo_ - p, p - hi_), glm::vec3(0.0f));
    const float outside = glm::length(gap);
    float best2 = std::numeric_limits<float>::max();
    const int rings = std::max({n_.x, n_.y, n_.z});
    for (int r = 0; r <= rings; ++r) {
      // Cells at Chebyshev distance r from c: everything closer was seen in earlier rings.
      for (int z = std::max(0, c.z - r); z <= std::min(n_.z - 1, c.z + r); ++z) {
        for (int y = std::max(0, c.y - r); y <= std::min(n_.y - 1, c.y + r); ++y) {
          const bool faceZy = std::abs(z - c.z) == r || std::abs(y - c.y) == r;
          // Inside the ring's z and y faces every x; elsewhere only the two x faces.
          const int step = faceZy || r == 0 ? 1 : 2 * r;
          for (int x = c.x - r; x <= c.x + r; x += step) {
            if (x < 0 || x >= n_.x) continue;
            const std::size_t i = index({x, y, z});
            for (std::uint32_t k = start_[i]; k < start_[i + 1]; ++k) {
              const Tri& tri = tris_[ids_[k]];
              best2 = std::min(best2, pointTriangleDistance2(p, tri.a, tri.b, tri.c));
            }
          }
        }
      }
      // Unseen cells lie at least r cells (beyond the grid's edge for an outside point) away.
      const float reach = outside + static_cast<float>(r) * cell_;
      if (best2 <= reach * reach || best2 <= stopBelow2) break;
    }
    return best2;
  }

 private:
  struct Tri {
    glm::vec3 a, b, c;
  };
  [[nodiscard]] glm::ivec3 cellOf(const glm::vec3& p) const {
    const glm::vec3 f = (p - lo_) / cell_;
    return glm::clamp(glm::ivec3(glm::floor(f)), glm::ivec3(0), n_ - 1);
  }
  [[nodiscard]] std::size_t index(const glm::ivec3& c) const {
    return (static_cast<std::size_t>(c.z) * n_.y + c.y) * n_.x + c.x;
  }
  std::vector<Tri> tris_;
  glm::vec3 lo_{std::numeric_limits<float>::max()}, hi_{-std::numeric_limits<float>::max()};
  float cell_ = 1.0f;
  glm::ivec3 n_{1};
  std::vector<std::uint32_t> start_;  // cell i holds ids_[start_[i], start_[i + 1])
  std::vector<std::uint32_t> ids_;
};

// Largest distance from sample points of `from` to the surface of `to`: its vertices, and per
// triangle its centroid, edge midpoints, the points halfway between centroid and corners and,
// with `spacingM` > 0, a barycentric grid with samples at most spacingM apart along each edge
// (16 steps per edge at most).
// The distance to a surface changes by at most the distance moved, so a triangle whose
// centroid's distance plus its reach (the centroid's farthest corner) stays below the largest
// distance found so far cannot raise it: its other samples are skipped (with a margin of 1e-4
// of the maximum for the float rounding, so the result is the one every sample would give).
// On a finely tessellated mesh against its LOD that skips nearly every triangle.
double oneSidedDistance(const MeshData& from, const TriangleGrid& to, double spacingM) {
  if (to.empty()) {
    return from.positions.empty() ? 0.0 : std::numeric_limits<double>::infinity();
  }
  float worst2 = 0.0f;
  auto visit = [&](const glm::vec3& p) { worst2 = std::max(worst2, to.distance2(p, worst2)); };
  for (const glm::vec3& p : from.positions) visit(p);
  for (std::size_t t = 0; t + 2 < from.indices.size(); t += 3) {
    const glm::vec3 a = from.positions[from.indices[t]], b = from.positions[from.indices[t + 1]],
                    c = from.positions[from.indices[t + 2]];
    const glm::vec3 g = (a + b + c) / 3.0f;
    const float reach = std::sqrt(
        std::max({glm::dot(a - g, a - g), glm::dot(b - g, b - g), glm::dot(c - g, c - g)}));
    // The centroid's distance below `skipBelow` skips the triangle; above it, it is exact.
    const float skipBelow = std::sqrt(worst2) * (1.0f - 1e-4f) - reach;
    const float centre2 = to.distance2(g, skipBelow > 0.0f ? skipBelow * skipBelow : 0.0f);
    if (skipBelow > 0.0f && centre2 <= skipBelow * skipBelow) continue;
    worst2 = std::max(worst2, centre2);
    for (const glm::vec3& p : {(a + b) * 0.5f, (b + c) * 0.5f, (c + a) * 0.5f, (g + a) * 0.5f,
                               (g + b) * 0.5f, (g + c) * 0.5f}) {
      visit(p);
    }
    if (spacingM > 0.0) {
      const double longest = std::max({glm::length(b - a), glm::length(c - b), glm::length(a - c)});
      const int steps = static_cast<int>(std::min(16.0, std::ceil(longest / spacingM)));
      for (int i = 0; i <= steps; ++i) {
        for (int j = 0; i + j <= steps; ++j) {
          const float u = float(i) / float(steps), v = float(j) / float(steps);
          visit(a + (b - a) * u + (c - a) * v);
        }
      }
    }
  }
  return std::sqrt(static_cast<double>(worst2));
}

// simplificationErrorM against one original mesh for any number of simplified meshes: the
// original's grid is built once.
class ErrorMeter {
 public:
  ErrorMeter(const MeshData& original, double sampleSpacingM)
      : original_(original),
        grid_(original),
        spacingM_(std::isfinite(sampleSpacingM) && sampleSpacingM > 0.0 ? sampleSpacingM : 0.0) {}
  [[nodiscard]] double errorM(const MeshData& simplified) const {
    return std::max(oneSidedDistance(original_, TriangleGrid(simplified), spacingM_),
                    oneSidedDistance(simplified, grid_, spacingM_));
  }

 private:
  const MeshData& original_;
  TriangleGrid grid_;
  double spacingM_;
};

// The mesh's shadow outline along a direction as a coverage mask (orthographic, pixel centres
// inside any triangle, no culling: what a depth pass without culling covers).
struct OutlineMask {
  int n = 0;
  std::vector<std::uint8_t> on;
};

OutlineMask outlineMask(const MeshData& m, const glm::vec3& u, const glm::vec3& v,
                        const glm::vec2& origin, float pixel, int n) {
  OutlineMask mask{n, std::vector<std::uint8_t>(static_cast<std::size_t>(n) * n, 0)};
  // Each vertex projected once (a vertex is shared by about six triangles).
  std::vector<glm::vec2> projected(m.positions.size());
  for (std::size_t i = 0; i < m.positions.size(); ++i) {
    const glm::vec3 x = m.positions[i];
    projected[i] = (glm::vec2(glm::dot(x, u), glm::dot(x, v)) - origin) / pixel;
  }
  for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    const glm::vec2 q[3] = {projected[m.indices[t]], projected[m.indices[t + 1]],
                            projected[m.indices[t + 2]]};
    const float area =
        (q[1].x - q[0].x) * (q[2].y - q[0].y) - (q[1].y - q[0].y) * (q[2].x - q[0].x);
    if (!(std::abs(area) > 1e-12f)) continue;
    const glm::vec2 bmin = glm::min(q[0], glm::min(q[1], q[2]));
    const glm::vec2 bmax = glm::max(q[0], glm::max(q[1], q[2]));
    for (int y = std::max(0, int(std::floor(bmin.y))); y <= std::min(n - 1, int(bmax.y)); ++y) {
      for (int x = std::max(0, int(std::floor(bmin.x))); x <= std::min(n - 1, int(bmax.x)); ++x) {
        const glm::vec2 c(float(x) + 0.5f, float(y) + 0.5f);
        bool inside = true;
        for (int k = 0; k < 3 && inside; ++k) {
          const glm::vec2 a = q[k], b = q[(k + 1) % 3];
          inside = ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)) / area >= 0.0f;
        }
        if (inside) mask.on[static_cast<std::size_t>(y) * n + x] = 1;
      }
    }
  }
  return mask;
}

// Whether every pixel of `a` has a pixel of `b` within `radius` pixels.
bool coveredWithin(const OutlineMask& a, const OutlineMask& b, int radius) {
  for (int y = 0; y < a.n; ++y) {
    for (int x = 0; x < a.n; ++x) {
      if (!a.on[static_cast<std::size_t>(y) * a.n + x]) continue;
      bool near = b.on[static_cast<std::size_t>(y) * b.n + x] != 0;  // most pixels: both cover it
      for (int dy = -radius; dy <= radius && !near; ++dy) {
        for (int dx = -radius; dx <= radius && !near; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (dx * dx + dy * dy > radius * radius || xx < 0 || yy < 0 || xx >= b.n || yy >= b.n) {
            continue;
          }
          near = b.on[static_cast<std::size_t>(yy) * b.n + xx] != 0;
        }
      }
      if (!near) return false;
    }
  }
  return true;
}

// shadowOutlinesWithin against one original mesh and bound for any number of simplified
// meshes: the original's outlines are rasterised once, when first needed.
class OutlineCheck {
 public:
  OutlineCheck(const MeshData& original, double boundM) : original_(original) {
    if (!(boundM > 0.0) || original.positions.empty()) return;
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (const glm::vec3& p : original.positions) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    const float size = glm::length(hi - lo);
    // Pixels of a quarter of the bound (coarser for a mesh over 500 of them across: a part
    // flattened into a sheet leaves gaps in a raster finer than its width); a pixel counts as
    // covered when the other outline has one within the bound plus a pixel.
    pixel_ = std::max(static_cast<float>(boundM) / 4.0f, size / 500.0f);
    radius_ = static_cast<int>(std::ceil(boundM / pixel_)) + 1;
    n_ = static_cast<int>(std::ceil(size / pixel_)) + 2 * radius_ + 2;
    // 48 directions spread over a hemisphere (a Fibonacci spiral; d and -d cast the same
    // outline): dense enough that a thin part flattened into a sheet is seen nearly edge-on,
    // where its outline thins to gaps, from some of them.
    constexpr int kDirections = 48;
    for (int k = 0; k < kDirections; ++k) {
      const float z = (static_cast<float>(k) + 0.5f) / kDirections;
      const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
      const float phi = 2.39996323f * static_cast<float>(k);
      const glm::vec3 w = glm::normalize(glm::vec3(r * std::cos(phi), z, r * std::sin(phi)));
      const glm::vec3 u = glm::normalize(std::abs(w.y) > 0.9f ? glm::cross(glm::vec3(1, 0, 0), w)
                                                              : glm::cross(glm::vec3(0, 1, 0), w));
      const glm::vec3 v = glm::cross(w, u);
      const glm::vec3 centre = 0.5f * (lo + hi);
      const glm::vec2 origin =
          glm::vec2(glm::dot(centre, u), glm::dot(centre, v)) - 0.5f * pixel_ * float(n_);
      views_.push_back({u, v, origin});
    }
    masks_.resize(views_.size());
  }

  /// Whether the outlines of `simplified` and the original cover each other within the bound.
  [[nodiscard]] bool within(const MeshData& simplified) {
    for (std::size_t k = 0; k < views_.size(); ++k) {
      const View& view = views_[k];
      if (masks_[k].on.empty()) {
        masks_[k] = outlineMask(original_, view.u, view.v, view.origin, pixel_, n_);
      }
      const OutlineMask b = outlineMask(simplified, view.u, view.v, view.origin, pixel_, n_);
      if (!coveredWithin(masks_[k], b, radius_) || !coveredWithin(b, masks_[k], radius_)) {
        return false;
      }
    }
    return true;
  }

 private:
  struct View {
    glm::vec3 u, v;
    glm::vec2 origin;
  };
  const MeshData& original_;
  float pixel_ = 1.0f;
  int radius_ = 0, n_ = 0;
  std::vector<View> views_;  // none: every mesh is within (no bound, or no original)
  std::vector<OutlineMask> masks_;
};

}  // namespace

bool shadowOutlinesWithin(const MeshData& original, const MeshData& simplified, double boundM) {
  return OutlineCheck(original, boundM).within(simplified);
}

double simplificationErrorM(const MeshData& original, const MeshData& simplified,
                            double sampleSpacingM) {
  return ErrorMeter(original, sampleSpacingM).errorM(simplified);
}

MeshData decimateToError(const MeshData& in, double maxErrorM, double* errorM,
                         const Progress& progress) {
  if (errorM != nullptr) *errorM = 0.0;
  if (!(maxErrorM > 0.0) || !std::isfinite(maxErrorM) || in.indices.empty()) return in;
  // The removed vertices within the tolerance bound only part of the error; the measured
  // symmetric distance (both directions, edges and faces sampled) and the shadow outlines along
  // 48 directions decide (a pole flattened into a sheet is within its radius of the pole but
  // casts no shadow edge-on), and a smaller tolerance is tried while they fail.
  const ErrorMeter meter(in, lodSampleSpacingM(maxErrorM));
  OutlineCheck outlines(in, maxErrorM);
  double tolerance = maxErrorM;
  for (int attempt = 0; attempt < 8; ++attempt, tolerance *= 0.6) {
    if (progress) {
      char step[160];
      std::snprintf(step, sizeof step, "%u triangles to within %.3g m, try %d of at most 8",
                    in.triangleCount(), maxErrorM, attempt + 1);
      progress(step);
    }
    MeshData out = decimateWithin(in, tolerance);
    if (out.indices.size() >= in.indices.size()) break;
    if (progress) {
      char step[96];
      std::snprintf(step, sizeof step, "measuring the error of %u triangles", out.triangleCount());
      progress(step);
    }
    const double e = meter.errorM(out);
    if (progress && e <= maxErrorM) progress("checking the shadow outlines");
    if (e <= maxErrorM && outlines.within(out)) {
      if (errorM != nullptr) *errorM = e;
      return out;
    }
  }
  return in;
}

bool isClosedOutward(const MeshData& m) {
  if (m.indices.empty()) return false;
  // Positions welded by value, by sorting (maps took seconds on a 2-million-triangle mesh).
  std::vector<std::uint32_t> order(m.positions.size());
  for (std::uint32_t i = 0; i < order.size(); ++i) order[i] = i;
  auto key = [&](std::uint32_t i) {
    const glm::vec3& p = m.positions[i];
    return std::array<float, 3>{p.x, p.y, p.z};
  };
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return key(a) < key(b); });
  std::vector<std::uint32_t> id(m.positions.size());
  std::uint32_t welded = 0;
  for (std::size_t k = 0; k < order.size(); ++k) {
    if (k > 0 && key(order[k - 1]) < key(order[k])) ++welded;
    id[order[k]] = welded;
  }
  // Every directed edge once, and its reverse present: each edge shared by two faces wound
  // oppositely.
  std::vector<std::uint64_t> edges;
  edges.reserve(m.indices.size());
  double volume = 0.0;
  for (std::size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    const std::uint32_t v[3] = {id[m.indices[t]], id[m.indices[t + 1]], id[m.indices[t + 2]]};
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) return false;
    for (int e = 0; e < 3; ++e) {
      edges.push_back(std::uint64_t{v[e]} << 32 | v[(e + 1) % 3]);
    }
    const glm::dvec3 a(m.positions[m.indices[t]]), b(m.positions[m.indices[t + 1]]),
        c(m.positions[m.indices[t + 2]]);
    volume += glm::dot(a, glm::cross(b, c));
  }
  std::sort(edges.begin(), edges.end());
  if (std::adjacent_find(edges.begin(), edges.end()) != edges.end()) return false;
  for (const std::uint64_t e : edges) {
    if (!std::binary_search(edges.begin(), edges.end(), e << 32 | e >> 32)) return false;
  }
  return volume > 0.0;
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
