// The cache's texel rectangles: world texel indices of a cascade's light-space grid (anchored at
// the world origin), the parts of a static layer that went stale when its box moved or a caster
// changed, disjoint unions of them, and their places in a toroidal layer. Pure arithmetic: the
// renderer's cached pass (csm::vk, RendererOptions::cache) records what these compute.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/mat3x3.hpp>

#include "csm/types.hpp"

namespace csm {

/// floor(a / b) for b > 0 or b < 0 (C++'s division truncates toward zero).
[[nodiscard]] constexpr std::int64_t floorDiv(std::int64_t a, std::int64_t b) noexcept {
  const std::int64_t q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

/// a mod b with the sign of b: in [0, b) for b > 0.
[[nodiscard]] constexpr std::int64_t floorMod(std::int64_t a, std::int64_t b) noexcept {
  return a - floorDiv(a, b) * b;
}

/// A half-open rectangle [x0, x1) x [y0, y1) of texel indices.
struct TexelRect {
  std::int64_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  [[nodiscard]] bool empty() const noexcept { return x0 >= x1 || y0 >= y1; }
  [[nodiscard]] TexelRect intersect(const TexelRect& o) const noexcept;
  [[nodiscard]] std::uint64_t area() const noexcept;
  friend bool operator==(const TexelRect&, const TexelRect&) = default;
};

/// The world texel rectangle a world box covers in a cascade with texels of `texel` metres and
/// the light basis `basisT` (world -> light space, the grid about the origin): the texels whose
/// index range holds the box's light-space x, y, widened by one texel each side (a caster covers
/// a texel by its centre) and by ceil(marginTexels) more (a thin caster's rim).
[[nodiscard]] TexelRect boxTexels(const AabbWs& box, const glm::dmat3& basisT, double texel,
                                  float marginTexels = 0.0f) noexcept;

/// The stale parts of a static layer that holds box `old` (when `valid`) for box `box`: the
/// newly exposed rows and columns, and what of `box` lies under the `pending` world boxes
/// (boxTexels). Replaced by the whole box when the layer is not valid or the parts add up to a
/// layer or more (one full render is then no dearer). The parts may overlap (addDisjoint).
/// Returns whether `out` is the whole box.
bool staleRects(bool valid, const TexelRect& old, const TexelRect& box,
                const std::vector<AabbWs>& pending, const glm::dmat3& basisT, double texel,
                std::vector<TexelRect>& out);

/// Adds to `rects` (disjoint) the part of `r` they do not cover yet, as disjoint rectangles.
void addDisjoint(std::vector<TexelRect>& rects, const TexelRect& r);

/// The sum of the rectangles' areas.
[[nodiscard]] std::uint64_t totalArea(const std::vector<TexelRect>& rects) noexcept;

/// One part of a world rectangle in a toroidal layer of R x R texels whose world texel
/// (anchorX, anchorY) sits at layer texel (0, 0): the part inside block (mx, my) of the
/// anchor-relative index space, and where it lies in the layer (within [0, R)^2): layer x =
/// world x - anchorX - mx R.
struct LayerRect {
  TexelRect world;
  std::int64_t mx = 0, my = 0;
  TexelRect layer;
};

/// The parts of world rectangle `r` in a toroidal layer of `res` texels a side anchored at
/// (anchorX, anchorY), one per block it touches (up to four for a rectangle no wider than a
/// layer), in order of mx, then my. Empty for an empty rectangle.
void splitIntoLayer(std::int64_t anchorX, std::int64_t anchorY, std::int64_t res,
                    const TexelRect& r, std::vector<LayerRect>& out);

}  // namespace csm
