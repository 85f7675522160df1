#include "csm/culling.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

namespace csm {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::uint32_t kLeafSize = 8;

// One cascade's light box extruded without limit toward the light:
// { centre + x*right + y*up + z*forward : |x| <= hx, |y| <= hy, z <= zFar }.
struct Volume {
  glm::dvec3 centerWs;
  glm::dvec3 axis[3];  // right, up, forward (world)
  double hx, hy, zFar;
  double texelM;
  float minSizeM;               // casters whose light-space size is below this are dropped
  glm::dvec3 absAxis[3];        // |right|, |up|, |forward| componentwise
  glm::dvec3 worldLo, worldHi;  // the volume projected on the world axes, about its centre
};

Volume makeVolume(const glm::dmat3& basisWs, const Cascade& c, float minCasterTexels) noexcept {
  Volume v;
  v.centerWs = c.boxCenterWs;
  for (int k = 0; k < 3; ++k) v.axis[k] = basisWs[k];
  v.hx = c.halfExtentLs.x;
  v.hy = c.halfExtentLs.y;
  v.zFar = c.depthFarLs;
  v.texelM = c.texelSizeM();
  v.minSizeM = static_cast<float>(minCasterTexels * v.texelM);
  for (int k = 0; k < 3; ++k) v.absAxis[k] = glm::abs(v.axis[k]);
  for (int j = 0; j < 3; ++j) {
    const double r = v.hx * v.absAxis[0][j] + v.hy * v.absAxis[1][j];
    double f = v.axis[2][j];
    if (std::abs(f) <= 1e-12) f = 0.0;
    v.worldLo[j] = f > 0.0 ? -kInf : -r + v.zFar * f;
    v.worldHi[j] = f < 0.0 ? kInf : r + v.zFar * f;
    if (f == 0.0) {
      v.worldLo[j] = -r;
      v.worldHi[j] = r;
    }
  }
  return v;
}

// Conservative test for tree nodes: the 3 light axes and the 3 world axes, with every
// projection of the volume precomputed.
bool nodeIntersects(const Volume& v, const glm::dvec3& d, const glm::dvec3& e) noexcept {
  if (glm::any(glm::greaterThan(d - e, v.worldHi)) || glm::any(glm::lessThan(d + e, v.worldLo))) {
    return false;
  }
  const double x = glm::dot(d, v.axis[0]), rx = glm::dot(e, v.absAxis[0]);
  if (std::abs(x) > v.hx + rx) return false;
  const double y = glm::dot(d, v.axis[1]), ry = glm::dot(e, v.absAxis[1]);
  if (std::abs(y) > v.hy + ry) return false;
  const double z = glm::dot(d, v.axis[2]), rz = glm::dot(e, v.absAxis[2]);
  return z - rz <= v.zFar;
}

// Interval of the volume projected on direction L, relative to the volume's centre.
void projectVolume(const Volume& v, const glm::dvec3& l, double& lo, double& hi) noexcept {
  const double r =
      v.hx * std::abs(glm::dot(v.axis[0], l)) + v.hy * std::abs(glm::dot(v.axis[1], l));
  // An axis orthogonal to the light (the light's own x and y, forward x world) has f = 0
  // exactly in theory but ~1e-17 after rounding, which would make the projection half-infinite
  // and keep boxes that lie beside the volume: treat |f| below 1e-12 |L| as zero.
  double f = glm::dot(v.axis[2], l);
  if (std::abs(f) <= 1e-12 * glm::length(l)) f = 0.0;
  lo = -r;
  hi = r;
  if (f > 0.0) {
    lo = -kInf;
    hi += v.zFar * f;
  } else if (f < 0.0) {
    hi = kInf;
    lo += v.zFar * f;
  }
}

// True if the box (centre offset d from the volume's centre, half extents e) is separated from
// the volume along direction L.
bool separatedOn(const Volume& v, const glm::dvec3& d, const glm::dvec3& e,
                 const glm::dvec3& l) noexcept {
  double lo, hi;
  projectVolume(v, l, lo, hi);
  const double c = glm::dot(d, l);
  const double r = e.x * std::abs(l.x) + e.y * std::abs(l.y) + e.z * std::abs(l.z);
  return c - r > hi || c + r < lo;
}

// Separating-axis test. `exact` adds the 9 edge-edge axes (exact for a box); without them the
// test is conservative (never reports a miss for an intersecting box), enough for tree nodes.
bool boxIntersects(const Volume& v, const glm::dvec3& centerWs, const glm::dvec3& e,
                   bool exact) noexcept {
  const glm::dvec3 d = centerWs - v.centerWs;
  static const glm::dvec3 kWorld[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int k = 0; k < 3; ++k) {
    if (separatedOn(v, d, e, v.axis[k])) return false;
    if (separatedOn(v, d, e, kWorld[k])) return false;
  }
  if (exact) {
    for (int k = 0; k < 3; ++k) {
      for (int j = 0; j < 3; ++j) {
        const glm::dvec3 l = glm::cross(v.axis[k], kWorld[j]);
        if (glm::dot(l, l) < 1e-18) continue;  // parallel edges: covered by the face axes
        if (separatedOn(v, d, e, l)) return false;
      }
    }
  }
  return true;
}

bool sphereIntersects(const Volume& v, const glm::dvec3& centerWs, double radius) noexcept {
  const glm::dvec3 d = centerWs - v.centerWs;
  const glm::dvec3 q(glm::dot(d, v.axis[0]), glm::dot(d, v.axis[1]), glm::dot(d, v.axis[2]));
  const double dx = q.x - std::clamp(q.x, -v.hx, v.hx);
  const double dy = q.y - std::clamp(q.y, -v.hy, v.hy);
  const double dz = q.z - std::min(q.z, v.zFar);
  return dx * dx + dy * dy + dz * dz <= radius * radius;
}

// Light-space size (larger of the x and y extents) of a caster's bounds.
double lightSpaceSize(const Volume& v, const glm::dvec3& e, bool sphere) noexcept {
  if (sphere) return 2.0 * e.x;
  auto extent = [&](const glm::dvec3& a) {
    return 2.0 * (e.x * std::abs(a.x) + e.y * std::abs(a.y) + e.z * std::abs(a.z));
  };
  return std::max(extent(v.axis[0]), extent(v.axis[1]));
}

}  // namespace

namespace {

std::optional<ValidationError> checkSphere(const glm::dvec3& centerWs, double radiusM) {
  for (int i = 0; i < 3; ++i) {
    if (!(std::abs(centerWs[i]) <= kMaxWorldCoordinateM)) {
      return ValidationError{"caster.centerWs[" + std::to_string(i) + "]", centerWs[i],
                             "a coordinate in metres in [-1e9, 1e9] (kMaxWorldCoordinateM)"};
    }
  }
  if (!(radiusM >= 0.0 && radiusM <= 1e9)) {
    return ValidationError{"caster.radiusM", radiusM, "a radius in metres in [0, 1e9]"};
  }
  return std::nullopt;
}

std::optional<ValidationError> checkBox(const glm::dvec3& minWs, const glm::dvec3& maxWs) {
  for (int i = 0; i < 3; ++i) {
    if (!(std::abs(minWs[i]) <= kMaxWorldCoordinateM)) {
      return ValidationError{"caster.minWs[" + std::to_string(i) + "]", minWs[i],
                             "a coordinate in metres in [-1e9, 1e9] (kMaxWorldCoordinateM)"};
    }
    if (!(std::abs(maxWs[i]) <= kMaxWorldCoordinateM) || !(maxWs[i] >= minWs[i])) {
      return ValidationError{"caster.maxWs[" + std::to_string(i) + "]", maxWs[i],
                             "a coordinate in [caster.minWs[" + std::to_string(i) + "], 1e9]"};
    }
  }
  return std::nullopt;
}

std::optional<ValidationError> checkIndex(std::uint32_t i, std::size_t size) {
  if (i >= size) {
    return ValidationError{"caster index", double(i),
                           "an index below the set's size " + std::to_string(size)};
  }
  return std::nullopt;
}

// A float at least `h` (bounds narrowed to float stay conservative).
float roundUp(double h) noexcept {
  float f = static_cast<float>(h);
  if (static_cast<double>(f) < h) f = std::nextafter(f, std::numeric_limits<float>::max());
  return f;
}

constexpr std::uint32_t kNoParent = std::numeric_limits<std::uint32_t>::max();

}  // namespace

void CasterSet::grow() {
  centerX_.push_back(0.0);
  centerY_.push_back(0.0);
  centerZ_.push_back(0.0);
  halfX_.push_back(0.0f);
  halfY_.push_back(0.0f);
  halfZ_.push_back(0.0f);
  kind_.push_back(kRemoved);
}

void CasterSet::storeSphere(std::uint32_t i, const glm::dvec3& centerWs, double radiusM) {
  if (i == size()) grow();
  centerX_[i] = centerWs.x;
  centerY_[i] = centerWs.y;
  centerZ_[i] = centerWs.z;
  // Round the radius up when it is narrowed to float, so the bounds stay conservative.
  const float r = roundUp(radiusM);
  halfX_[i] = r;
  halfY_[i] = r;
  halfZ_[i] = r;
  kind_[i] = kSphere;
}

void CasterSet::storeBox(std::uint32_t i, const glm::dvec3& minWs, const glm::dvec3& maxWs) {
  if (i == size()) grow();
  const glm::dvec3 c = 0.5 * (minWs + maxWs);
  centerX_[i] = c.x;
  centerY_[i] = c.y;
  centerZ_[i] = c.z;
  auto half = [](double lo, double hi, double mid) {
    return roundUp(std::max(hi - mid, mid - lo));
  };
  halfX_[i] = half(minWs.x, maxWs.x, c.x);
  halfY_[i] = half(minWs.y, maxWs.y, c.y);
  halfZ_[i] = half(minWs.z, maxWs.z, c.z);
  kind_[i] = kBox;
}

Result<std::uint32_t> CasterSet::addSphere(const glm::dvec3& centerWs, double radiusM) {
  if (auto e = checkSphere(centerWs, radiusM)) return *e;
  const auto index = static_cast<std::uint32_t>(size());
  storeSphere(index, centerWs, radiusM);
  if (margin_.size() == index) margin_.push_back(0.0f);
  return index;
}

Result<std::uint32_t> CasterSet::addBox(const glm::dvec3& minWs, const glm::dvec3& maxWs) {
  if (auto e = checkBox(minWs, maxWs)) return *e;
  const auto index = static_cast<std::uint32_t>(size());
  storeBox(index, minWs, maxWs);
  if (margin_.size() == index) margin_.push_back(0.0f);
  return index;
}

Result<std::uint32_t> CasterSet::setSphere(std::uint32_t i, const glm::dvec3& centerWs,
                                           double radiusM) {
  if (auto e = checkIndex(i, size())) return *e;
  if (auto e = checkSphere(centerWs, radiusM)) return *e;
  storeSphere(i, centerWs, radiusM);
  refit(i);
  return i;
}

Result<std::uint32_t> CasterSet::setBox(std::uint32_t i, const glm::dvec3& minWs,
                                        const glm::dvec3& maxWs) {
  if (auto e = checkIndex(i, size())) return *e;
  if (auto e = checkBox(minWs, maxWs)) return *e;
  storeBox(i, minWs, maxWs);
  refit(i);
  return i;
}

Result<std::uint32_t> CasterSet::remove(std::uint32_t i) {
  if (auto e = checkIndex(i, size())) return *e;
  // The hierarchy keeps its bounds (still conservative); queries skip the caster.
  kind_[i] = kRemoved;
  return i;
}

void CasterSet::refit(std::uint32_t i) {
  if (!built_ || i >= indexed_) return;
  std::uint32_t n = leafOf_[i];
  {
    Node& leaf = nodes_[n];
    glm::dvec3 lo(kInf), hi(-kInf);
    for (std::uint32_t k = leaf.first; k < leaf.first + leaf.count; ++k) {
      const std::uint32_t j = order_[k];
      const glm::dvec3 c(centerX_[j], centerY_[j], centerZ_[j]);
      const glm::dvec3 e(halfX_[j], halfY_[j], halfZ_[j]);
      lo = glm::min(lo, c - e);
      hi = glm::max(hi, c + e);
    }
    leaf.minWs = lo;
    leaf.maxWs = hi;
  }
  for (n = parent_[n]; n != kNoParent; n = parent_[n]) {
    Node& node = nodes_[n];
    const Node& l = nodes_[node.first];
    const Node& r = nodes_[node.first + 1];
    const glm::dvec3 lo = glm::min(l.minWs, r.minWs), hi = glm::max(l.maxWs, r.maxWs);
    if (lo == node.minWs && hi == node.maxWs) break;  // nothing above changes either
    node.minWs = lo;
    node.maxWs = hi;
  }
}

Result<std::uint32_t> CasterSet::setMarginTexels(std::uint32_t i, float texels) {
  if (i >= size()) {
    return ValidationError{"caster index", double(i),
                           "an index below the set's size " + std::to_string(size())};
  }
  if (!(texels >= 0.0f && texels <= 64.0f)) {
    return ValidationError{"caster.marginTexels", double(texels), "texels in [0, 64]"};
  }
  if (margin_.size() < size()) margin_.resize(size(), 0.0f);
  margin_[i] = texels;
  maxMargin_ = std::max(maxMargin_, texels);
  return i;
}

void CasterSet::clear() noexcept {
  parent_.clear();
  leafOf_.clear();
  indexed_ = 0;
  margin_.clear();
  maxMargin_ = 0.0f;
  centerX_.clear();
  centerY_.clear();
  centerZ_.clear();
  halfX_.clear();
  halfY_.clear();
  halfZ_.clear();
  kind_.clear();
  order_.clear();
  nodes_.clear();
  built_ = false;
}

void CasterSet::reserve(std::size_t count) {
  centerX_.reserve(count);
  centerY_.reserve(count);
  centerZ_.reserve(count);
  halfX_.reserve(count);
  halfY_.reserve(count);
  halfZ_.reserve(count);
  kind_.reserve(count);
}

AabbWs CasterSet::bounds(std::uint32_t i) const noexcept {
  const glm::dvec3 c(centerX_[i], centerY_[i], centerZ_[i]);
  const glm::dvec3 e(halfX_[i], halfY_[i], halfZ_[i]);
  return {c - e, c + e};
}

namespace {

// A caster as the tree builder sees it: contiguous, so partitioning touches no other memory.
struct BuildItem {
  glm::dvec3 center;
  glm::vec3 half;
  std::uint32_t index;
};

}  // namespace

void CasterSet::build() {
  const auto n = static_cast<std::uint32_t>(size());
  std::vector<BuildItem> items(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    items[i] = {{centerX_[i], centerY_[i], centerZ_[i]}, {halfX_[i], halfY_[i], halfZ_[i]}, i};
  }
  nodes_.clear();
  parent_.clear();
  order_.resize(n);
  if (n > 0) {
    nodes_.reserve(2 * (n / kLeafSize + 1));
    nodes_.push_back(Node{});
    parent_.push_back(kNoParent);
    // Iterative top-down median split on the axis along which the centres spread most.
    struct Task {
      std::uint32_t node, begin, end;
    };
    std::vector<Task> tasks{{0, 0, n}};
    while (!tasks.empty()) {
      const Task t = tasks.back();
      tasks.pop_back();
      glm::dvec3 lo(kInf), hi(-kInf), cLo(kInf), cHi(-kInf);
      for (std::uint32_t k = t.begin; k < t.end; ++k) {
        const glm::dvec3 e(items[k].half);
        lo = glm::min(lo, items[k].center - e);
        hi = glm::max(hi, items[k].center + e);
        cLo = glm::min(cLo, items[k].center);
        cHi = glm::max(cHi, items[k].center);
      }
      nodes_[t.node].minWs = lo;
      nodes_[t.node].maxWs = hi;
      if (t.end - t.begin <= kLeafSize) {
        nodes_[t.node].first = t.begin;
        nodes_[t.node].count = t.end - t.begin;
        continue;
      }
      const glm::dvec3 spread = cHi - cLo;
      const int axis =
          spread.x >= spread.y ? (spread.x >= spread.z ? 0 : 2) : (spread.y >= spread.z ? 1 : 2);
      const std::uint32_t mid = t.begin + (t.end - t.begin) / 2;
      std::nth_element(items.begin() + t.begin, items.begin() + mid, items.begin() + t.end,
                       [axis](const BuildItem& a, const BuildItem& b) {
                         return a.center[axis] < b.center[axis];
                       });
      const auto left = static_cast<std::uint32_t>(nodes_.size());
      nodes_.push_back(Node{});
      nodes_.push_back(Node{});
      parent_.push_back(t.node);
      parent_.push_back(t.node);
      nodes_[t.node].first = left;
      nodes_[t.node].count = 0;
      tasks.push_back({left + 1, mid, t.end});
      tasks.push_back({left, t.begin, mid});
    }
  }
  for (std::uint32_t k = 0; k < n; ++k) order_[k] = items[k].index;
  leafOf_.assign(n, 0);
  for (std::uint32_t node = 0; node < nodes_.size(); ++node) {
    if (nodes_[node].count == 0) continue;
    for (std::uint32_t k = nodes_[node].first; k < nodes_[node].first + nodes_[node].count; ++k) {
      leafOf_[order_[k]] = node;
    }
  }
  indexed_ = n;
  built_ = true;
}

namespace {

// `v` grown by `texels` of its texels in the light's x and y (a widened caster's reach; tree
// nodes are tested against the volume grown by the set's largest margin).
Volume grown(const Volume& v, float texels) noexcept {
  if (!(texels > 0.0f)) return v;
  Volume g = v;
  const double m = double(texels) * v.texelM;
  g.hx += m;
  g.hy += m;
  for (int j = 0; j < 3; ++j) {
    const double r = m * (v.absAxis[0][j] + v.absAxis[1][j]);
    g.worldLo[j] -= r;
    g.worldHi[j] += r;
  }
  return g;
}

// Shared by both culling paths: the exact per-caster test, size threshold and margin included.
bool casterVisible(const Volume& v, const glm::dvec3& c, const glm::dvec3& e, bool sphere,
                   float marginTexels) noexcept {
  if (v.minSizeM > 0.0f && lightSpaceSize(v, e, sphere) < static_cast<double>(v.minSizeM)) {
    return false;
  }
  const Volume g = grown(v, marginTexels);
  return sphere ? sphereIntersects(g, c, e.x) : boxIntersects(g, c, e, true);
}

// The light basis cascade `ci` is culled in: its own where given, else the frame's.
const glm::dmat3& cascadeBasis(const CascadeFrame& frame, std::span<const glm::dmat3> bases,
                               std::uint32_t ci) noexcept {
  return ci < bases.size() ? bases[ci] : frame.lightBasisWs;
}

}  // namespace

void cullCastersBruteForce(const CasterSet& casters, const CascadeFrame& frame,
                           float minCasterTexels, CullResult& out,
                           std::span<const glm::dmat3> cascadeBasesWs) {
  out.nodesVisited = 0;
  out.castersTested = 0;
  for (auto& list : out.visible) list.clear();
  const auto n = static_cast<std::uint32_t>(casters.size());
  for (std::uint32_t ci = 0; ci < frame.cascadeCount; ++ci) {
    const Cascade& cascade = frame.cascades[ci];
    if (cascade.empty) continue;
    const Volume v = makeVolume(cascadeBasis(frame, cascadeBasesWs, ci), cascade, minCasterTexels);
    for (std::uint32_t i = 0; i < n; ++i) {
      if (casters.kind_[i] == CasterSet::kRemoved) continue;
      const glm::dvec3 c(casters.centerX_[i], casters.centerY_[i], casters.centerZ_[i]);
      const glm::dvec3 e(casters.halfX_[i], casters.halfY_[i], casters.halfZ_[i]);
      ++out.castersTested;
      if (casterVisible(v, c, e, casters.kind_[i] == CasterSet::kSphere, casters.marginTexels(i))) {
        out.visible[ci].push_back(i);
      }
    }
  }
}

void cullCasters(const CasterSet& casters, const CascadeFrame& frame, float minCasterTexels,
                 CullResult& out, std::span<const glm::dmat3> cascadeBasesWs) {
  if (!casters.built_) {
    cullCastersBruteForce(casters, frame, minCasterTexels, out, cascadeBasesWs);
    return;
  }
  out.nodesVisited = 0;
  out.castersTested = 0;
  for (auto& list : out.visible) list.clear();
  if (casters.size() == 0) return;

  std::array<Volume, kMaxCascades> volumes, nodeVolumes;
  std::uint32_t rootMask = 0;
  for (std::uint32_t ci = 0; ci < frame.cascadeCount; ++ci) {
    if (frame.cascades[ci].empty) continue;
    volumes[ci] =
        makeVolume(cascadeBasis(frame, cascadeBasesWs, ci), frame.cascades[ci], minCasterTexels);
    nodeVolumes[ci] = grown(volumes[ci], casters.maxMargin_);
    rootMask |= 1u << ci;
  }
  if (rootMask == 0) return;

  auto testCaster = [&](std::uint32_t i, std::uint32_t mask) {
    if (casters.kind_[i] == CasterSet::kRemoved) return;
    const glm::dvec3 c(casters.centerX_[i], casters.centerY_[i], casters.centerZ_[i]);
    const glm::dvec3 e(casters.halfX_[i], casters.halfY_[i], casters.halfZ_[i]);
    const bool sphere = casters.kind_[i] == CasterSet::kSphere;
    for (std::uint32_t m = mask; m != 0; m &= m - 1) {
      const auto ci = static_cast<std::uint32_t>(std::countr_zero(m));
      ++out.castersTested;
      if (casterVisible(volumes[ci], c, e, sphere, casters.marginTexels(i))) {
        out.visible[ci].push_back(i);
      }
    }
  };

  // Depth-first over the tree, carrying the set of cascades each node may still touch.
  struct Item {
    std::uint32_t node;
    std::uint32_t mask;
  };
  std::array<Item, 128> stack;
  std::size_t top = 0;
  if (!casters.nodes_.empty()) stack[top++] = {0, rootMask};
  while (top > 0) {
    const Item item = stack[--top];
    const CasterSet::Node& node = casters.nodes_[item.node];
    ++out.nodesVisited;
    const glm::dvec3 nodeCenter = 0.5 * (node.minWs + node.maxWs);
    const glm::dvec3 nodeHalf = 0.5 * (node.maxWs - node.minWs);
    std::uint32_t mask = 0;
    for (std::uint32_t m = item.mask; m != 0; m &= m - 1) {
      const auto ci = static_cast<std::uint32_t>(std::countr_zero(m));
      if (nodeIntersects(nodeVolumes[ci], nodeCenter - volumes[ci].centerWs, nodeHalf)) {
        mask |= 1u << ci;
      }
    }
    if (mask == 0) continue;
    if (node.count == 0) {
      stack[top++] = {node.first + 1, mask};
      stack[top++] = {node.first, mask};
      continue;
    }
    for (std::uint32_t k = node.first; k < node.first + node.count; ++k) {
      testCaster(casters.order_[k], mask);
    }
  }
  // Casters added since the hierarchy was built.
  for (auto i = casters.indexed_; i < casters.size(); ++i) testCaster(i, rootMask);
  for (std::uint32_t ci = 0; ci < frame.cascadeCount; ++ci) {
    std::sort(out.visible[ci].begin(), out.visible[ci].end());
  }
}

}  // namespace csm
