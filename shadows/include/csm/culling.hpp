// Per-cascade caster culling against each cascade's light box extruded toward the light.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "csm/cascades.hpp"

namespace csm {

class CasterSet;
struct CullResult;
void cullCasters(const CasterSet& casters, const CascadeFrame& frame, float minCasterTexels,
                 CullResult& out, std::span<const glm::dmat3> cascadeBasesWs);
void cullCastersBruteForce(const CasterSet& casters, const CascadeFrame& frame,
                           float minCasterTexels, CullResult& out,
                           std::span<const glm::dmat3> cascadeBasesWs);

/// Caster bounds in structure-of-arrays form plus a bounding-volume hierarchy over them, so a
/// query costs in proportion to what lies near the cascades, not to the size of the world.
/// Each caster is a sphere or an axis-aligned box; its index is the order of insertion.
///
/// Moving casters cost what changed: setBox / setSphere change one caster's bounds and refit the
/// hierarchy's nodes above it (O(leaf size + depth)), remove() takes one out of every query, and
/// casters added after build() are tested one by one until the next build(). A refitted node may
/// grow as its casters move apart, so a query visits more of the tree; rebuild (build()) when
/// many casters have moved far.
class CasterSet {
 public:
  /// Adds a bounding sphere and returns the caster's index, or refuses a non-finite centre or
  /// a radius outside [0, 1e9] (nothing is added then).
  Result<std::uint32_t> addSphere(const glm::dvec3& centerWs, double radiusM);
  /// Adds an axis-aligned box and returns the caster's index, or refuses non-finite corners or
  /// min > max on any axis (nothing is added then).
  Result<std::uint32_t> addBox(const glm::dvec3& minWs, const glm::dvec3& maxWs);
  /// Caster i is drawn widened by `texels` of each cascade in the light's plane (a thin caster,
  /// RendererOptions::thinCasterWidenTexels): it reaches a cascade whose box, grown by that many
  /// of its texels in x and y, its bounds meet. Refuses a margin outside [0, 64] or an index out
  /// of range. No rebuild needed.
  Result<std::uint32_t> setMarginTexels(std::uint32_t i, float texels);
  [[nodiscard]] float marginTexels(std::uint32_t i) const noexcept {
    return i < margin_.size() ? margin_[i] : 0.0f;
  }
  /// New bounds for caster i (a sphere, or an axis-aligned box), with the refusals of addSphere /
  /// addBox, and an index out of range refused; a removed caster is back in the queries. The
  /// hierarchy is refitted above it (no rebuild). On a refusal nothing changes.
  Result<std::uint32_t> setSphere(std::uint32_t i, const glm::dvec3& centerWs, double radiusM);
  Result<std::uint32_t> setBox(std::uint32_t i, const glm::dvec3& minWs, const glm::dvec3& maxWs);
  /// Takes caster i out of every query (its index stays; setBox / setSphere bring it back).
  Result<std::uint32_t> remove(std::uint32_t i);
  [[nodiscard]] bool removed(std::uint32_t i) const noexcept {
    return i < kind_.size() && kind_[i] == kRemoved;
  }
  /// Removes every caster.
  void clear() noexcept;
  /// Reserves room for `count` casters.
  void reserve(std::size_t count);

  /// Builds (or rebuilds) the hierarchy over every caster. Queries before build() test every
  /// caster; casters added after it are tested one by one (unindexedCount()) until the next
  /// build(). O(n log n).
  void build();
  [[nodiscard]] bool built() const noexcept { return built_; }
  /// Casters added since the last build(), outside the hierarchy.
  [[nodiscard]] std::size_t unindexedCount() const noexcept {
    return built_ ? size() - indexed_ : size();
  }
  [[nodiscard]] std::size_t size() const noexcept { return centerX_.size(); }

  /// Bounds of caster i as an AABB.
  [[nodiscard]] AabbWs bounds(std::uint32_t i) const noexcept;
  [[nodiscard]] bool isSphere(std::uint32_t i) const noexcept { return kind_[i] == kSphere; }

 private:
  static constexpr std::uint8_t kSphere = 0, kBox = 1, kRemoved = 2;
  // One more caster slot (removed until stored).
  void grow();
  // The bounds of caster i (stored as they are when added), then the nodes above it refitted.
  void storeSphere(std::uint32_t i, const glm::dvec3& centerWs, double radiusM);
  void storeBox(std::uint32_t i, const glm::dvec3& minWs, const glm::dvec3& maxWs);
  void refit(std::uint32_t i);
  friend void cullCasters(const CasterSet&, const CascadeFrame&, float, CullResult&,
                          std::span<const glm::dmat3>);
  friend void cullCastersBruteForce(const CasterSet&, const CascadeFrame&, float, CullResult&,
                                    std::span<const glm::dmat3>);
  struct Node {
    // World-space AABB of everything below the node; children or leaf range.
    glm::dvec3 minWs;
    glm::dvec3 maxWs;
    std::uint32_t first;  // leaf: first index into order_; inner: left child index
    std::uint32_t count;  // leaf: number of casters; inner: 0 (right child = left + 1)
  };

  // Structure of arrays: centres in double (worlds reach 1e7 m), half extents in float.
  std::vector<double> centerX_, centerY_, centerZ_;
  std::vector<float> halfX_, halfY_, halfZ_;
  std::vector<std::uint8_t> kind_;  // kSphere (half extents all = radius), kBox, kRemoved
  std::vector<float> margin_;       // texels each caster is widened by (empty: none)
  float maxMargin_ = 0.0f;          // the largest of them (tree nodes are tested with it)
  std::vector<std::uint32_t> order_;
  std::vector<Node> nodes_;
  std::vector<std::uint32_t> parent_;  // per node (the root's: kNoParent)
  std::vector<std::uint32_t> leafOf_;  // per indexed caster: the leaf holding it
  std::uint32_t indexed_ = 0;          // casters [0, indexed_) are in the hierarchy
  bool built_ = false;
};

/// Per-cascade lists of caster indices to draw.
struct CullResult {
  std::array<std::vector<std::uint32_t>, kMaxCascades> visible;
  /// Number of hierarchy nodes and casters tested (for benchmarks and reports).
  std::uint64_t nodesVisited = 0;
  std::uint64_t castersTested = 0;
};

/// Fills `out.visible[c]` for each non-empty cascade c of `frame` with every caster whose bounds
/// intersect the cascade's light box extruded without limit toward the light (x, y within the
/// box grown by the caster's margin in the cascade's texels, light-space z <= depthFarLs), in
/// increasing index order, except casters whose bounds
/// span fewer than `minCasterTexels` of that cascade's texels (0: keep all). Exact per caster
/// (sphere-box and box-box separating-axis tests); the hierarchy only skips what cannot
/// intersect. Reuses `out`'s storage.
///
/// Each cascade's box is in `cascadeBasesWs[c]` where that is given (a cached cascade deferred
/// across a change of light is drawn in the basis its layer shows: CacheCascadePlan::basis),
/// else in the frame's light basis.
void cullCasters(const CasterSet& casters, const CascadeFrame& frame, float minCasterTexels,
                 CullResult& out, std::span<const glm::dmat3> cascadeBasesWs = {});

/// The same answer by testing every caster against every cascade (reference for tests).
void cullCastersBruteForce(const CasterSet& casters, const CascadeFrame& frame,
                           float minCasterTexels, CullResult& out,
                           std::span<const glm::dmat3> cascadeBasesWs = {});

}  // namespace csm
