// The cache's texel rectangles (csm/cache_rects.hpp) against brute force: every texel of a small
// grid is counted in or out, so an off-by-one at any edge, an overlap or a lost corner fails.

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include <csm/cache_rects.hpp>

namespace {

using Texel = std::pair<std::int64_t, std::int64_t>;

std::set<Texel> texelsOf(const csm::TexelRect& r) {
  std::set<Texel> out;
  for (std::int64_t y = r.y0; y < r.y1; ++y) {
    for (std::int64_t x = r.x0; x < r.x1; ++x) out.insert({x, y});
  }
  return out;
}

// The texels of `rects`, and whether any is counted twice.
std::set<Texel> unionOf(const std::vector<csm::TexelRect>& rects, bool& overlap) {
  std::set<Texel> out;
  overlap = false;
  for (const csm::TexelRect& r : rects) {
    for (const Texel& t : texelsOf(r)) overlap |= !out.insert(t).second;
  }
  return out;
}

TEST(CacheRects, FloorDivAndModRoundTowardMinusInfinity) {
  EXPECT_EQ(csm::floorDiv(7, 4), 1);
  EXPECT_EQ(csm::floorDiv(-7, 4), -2);
  EXPECT_EQ(csm::floorDiv(-8, 4), -2);
  EXPECT_EQ(csm::floorDiv(7, -4), -2);
  EXPECT_EQ(csm::floorMod(-1, 2048), 2047);
  EXPECT_EQ(csm::floorMod(-2048, 2048), 0);
  // World texel indices 10^7 m from the origin at 1 cm texels.
  EXPECT_EQ(csm::floorMod(-1000000001, 4096), 4096 - 1000000001 % 4096);
  for (std::int64_t a = -50; a <= 50; ++a) {
    const std::int64_t q = csm::floorDiv(a, 7), m = csm::floorMod(a, 7);
    EXPECT_EQ(q * 7 + m, a);
    EXPECT_GE(m, 0);
    EXPECT_LT(m, 7);
  }
}

TEST(CacheRects, BoxTexelsHoldTheBoxWidenedByATexelAndTheMargin) {
  const glm::dmat3 identity(1.0);
  // A box 1e7 m from the origin, 0.25 m texels: x in [1e7 + 0.1, 1e7 + 0.9] covers texel
  // indices 4e7 .. 4e7 + 3; one texel more each side for centre coverage.
  csm::AabbWs box{{1e7 + 0.1, -2.3, 5.0}, {1e7 + 0.9, -2.05, 6.0}};
  csm::TexelRect r = csm::boxTexels(box, identity, 0.25);
  EXPECT_EQ(r, (csm::TexelRect{40000000 - 1, -10 - 1, 40000003 + 2, -9 + 2}));
  // A thin caster's rim: ceil(margin) texels more.
  r = csm::boxTexels(box, identity, 0.25, 0.0625f);
  EXPECT_EQ(r, (csm::TexelRect{40000000 - 2, -10 - 2, 40000003 + 3, -9 + 3}));
  // The light basis turns the box: world z becomes light x.
  const glm::dmat3 basisT(glm::dvec3(0, 0, 1), glm::dvec3(0, 1, 0), glm::dvec3(1, 0, 0));
  r = csm::boxTexels(box, glm::transpose(basisT), 1.0);
  EXPECT_EQ(r.x0, 5 - 1);
  EXPECT_EQ(r.x1, 6 + 2);
}

TEST(CacheRects, StaleRectsAreTheExposedTexelsAndThePendingBoxes) {
  const glm::dmat3 identity(1.0);
  const csm::TexelRect old{100, 200, 116, 216};
  std::vector<csm::TexelRect> out;
  bool overlap = false;
  // Every move within a layer's width: the stale parts are exactly the new box less the old.
  for (std::int64_t dy = -17; dy <= 17; dy += 3) {
    for (std::int64_t dx = -17; dx <= 17; dx += 2) {
      const csm::TexelRect box{old.x0 + dx, old.y0 + dy, old.x1 + dx, old.y1 + dy};
      const bool whole = csm::staleRects(true, old, box, {}, identity, 1.0, out);
      std::set<Texel> want = texelsOf(box);
      for (const Texel& t : texelsOf(old)) want.erase(t);
      if (want.size() >= box.area()) {
        EXPECT_TRUE(whole) << dx << ", " << dy;
        EXPECT_EQ(out, std::vector<csm::TexelRect>{box});
        continue;
      }
      EXPECT_FALSE(whole) << dx << ", " << dy;
      EXPECT_EQ(unionOf(out, overlap), want) << dx << ", " << dy;
      EXPECT_FALSE(overlap) << dx << ", " << dy;
    }
  }
  // Not valid: the whole box.
  EXPECT_TRUE(csm::staleRects(false, old, old, {}, identity, 1.0, out));
  EXPECT_EQ(out, std::vector<csm::TexelRect>{old});
  // The box kept, a changed caster under it: its texels (centre coverage: one more each side),
  // clipped to the box; one outside the box adds nothing.
  const std::vector<csm::AabbWs> pending{{{103.5, 210.2, 0.0}, {105.5, 230.0, 1.0}},
                                         {{500.0, 500.0, 0.0}, {501.0, 501.0, 1.0}}};
  EXPECT_FALSE(csm::staleRects(true, old, old, pending, identity, 1.0, out));
  EXPECT_EQ(out, std::vector<csm::TexelRect>{(csm::TexelRect{102, 209, 107, 216})});
  // Stale parts adding up to the layer: one full render instead.
  const std::vector<csm::AabbWs> everything{{{90.0, 190.0, 0.0}, {130.0, 230.0, 1.0}}};
  EXPECT_TRUE(csm::staleRects(true, old, old, everything, identity, 1.0, out));
  EXPECT_EQ(out, std::vector<csm::TexelRect>{old});
}

TEST(CacheRects, AddDisjointCoversTheUnionOnceAndNothingElse) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> pos(-12, 12), size(0, 9);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<csm::TexelRect> rects, added;
    for (int k = 0; k < 6; ++k) {
      const std::int64_t x = pos(rng), y = pos(rng);
      const csm::TexelRect r{x, y, x + size(rng), y + size(rng)};
      added.push_back(r);
      csm::addDisjoint(rects, r);
    }
    bool overlap = false, ignored = false;
    const std::set<Texel> got = unionOf(rects, overlap);
    EXPECT_EQ(got, unionOf(added, ignored)) << "trial " << trial;
    EXPECT_FALSE(overlap) << "trial " << trial;
    EXPECT_EQ(csm::totalArea(rects), got.size()) << "trial " << trial;
    for (const csm::TexelRect& r : rects) EXPECT_FALSE(r.empty()) << "trial " << trial;
  }
}

TEST(CacheRects, SplitIntoLayerWrapsEachTexelToItsToroidalPlace) {
  const std::int64_t res = 16;
  std::vector<csm::LayerRect> parts;
  // Anchors near the origin and 10^7 m away at 1 cm texels; rectangles straddling the anchor's
  // block edges, one inside a block, one as wide as the layer.
  for (const std::int64_t anchor : {std::int64_t(-5), std::int64_t(1000000003)}) {
    for (const csm::TexelRect& r :
         {csm::TexelRect{anchor + 10, anchor - 3, anchor + 21, anchor + 4},
          csm::TexelRect{anchor + 1, anchor + 2, anchor + 5, anchor + 9},
          csm::TexelRect{anchor + 7, anchor + 7, anchor + 7 + res, anchor + 7 + res}}) {
      csm::splitIntoLayer(anchor, anchor, res, r, parts);
      ASSERT_FALSE(parts.empty());
      EXPECT_LE(parts.size(), 4u);
      std::vector<csm::TexelRect> worlds;
      std::set<Texel> layerTexels;
      for (const csm::LayerRect& p : parts) {
        worlds.push_back(p.world);
        // The layer rectangle is the world part less the block's origin, inside the layer, and
        // every world texel lands where the wrap puts it.
        EXPECT_EQ(p.layer.x0, p.world.x0 - anchor - p.mx * res);
        EXPECT_EQ(p.layer.y0, p.world.y0 - anchor - p.my * res);
        EXPECT_EQ(p.layer.x1 - p.layer.x0, p.world.x1 - p.world.x0);
        EXPECT_EQ(p.layer.y1 - p.layer.y0, p.world.y1 - p.world.y0);
        EXPECT_GE(p.layer.x0, 0);
        EXPECT_GE(p.layer.y0, 0);
        EXPECT_LE(p.layer.x1, res);
        EXPECT_LE(p.layer.y1, res);
        EXPECT_EQ(csm::floorMod(p.world.x0 - anchor, res), p.layer.x0);
        for (const Texel& t : texelsOf(p.layer)) layerTexels.insert(t);
      }
      bool overlap = false;
      EXPECT_EQ(unionOf(worlds, overlap), texelsOf(r));
      EXPECT_FALSE(overlap);
      // A rectangle no wider than the layer never lands on a layer texel twice.
      EXPECT_EQ(layerTexels.size(), r.area());
    }
  }
  csm::splitIntoLayer(0, 0, res, csm::TexelRect{3, 3, 3, 9}, parts);
  EXPECT_TRUE(parts.empty());
}

}  // namespace
