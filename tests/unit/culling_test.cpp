// Culling drops only what cannot cast into a cascade, and the hierarchy agrees with brute force.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>

#include "test_util.hpp"

namespace csm {
namespace {

CascadeFrame makeFrame(const glm::dvec3& camPos, const glm::dvec3& lightDir,
                       std::uint32_t count = 4) {
  ShadowSettings s;
  s.cascadeCount = count;
  s.resolution = 1024;
  s.shadowDistanceM = 300.0;
  Camera cam;
  cam.positionWs = camPos;
  cam.orientationWs = test::lookAlong({0.3, -0.2, -1});
  return test::computeOrDie(s, cam, DirectionalLight{lightDir});
}

// Independent test of "point inside the extruded light box of cascade c".
bool pointInExtrudedBox(const CascadeFrame& f, std::uint32_t c, const glm::dvec3& p) {
  const Cascade& k = f.cascades[c];
  const glm::dvec3 ls = toLightSpace(f.lightBasisWs, k.boxCenterWs, p);
  return std::abs(ls.x) <= k.halfExtentLs.x && std::abs(ls.y) <= k.halfExtentLs.y &&
         ls.z <= k.depthFarLs;
}

void fillRandomScene(CasterSet& set, std::mt19937_64& rng, const glm::dvec3& around, double extent,
                     int n) {
  std::uniform_real_distribution<double> pos(-extent, extent), size(0.05, 20.0);
  for (int i = 0; i < n; ++i) {
    const glm::dvec3 c = around + glm::dvec3(pos(rng), pos(rng) * 0.2, pos(rng));
    if (i % 2 == 0) {
      ASSERT_TRUE(set.addSphere(c, size(rng)).ok());
    } else {
      const glm::dvec3 h(size(rng), size(rng), size(rng));
      ASSERT_TRUE(set.addBox(c - h, c + h).ok());
    }
  }
}

TEST(Culling, HierarchyMatchesBruteForceAndDropsNothingThatIntersects) {
  std::mt19937_64 rng(5);
  for (const glm::dvec3& origin : {glm::dvec3(0, 20, 0), glm::dvec3(1e7, 20, -1e7)}) {
    for (const glm::dvec3& light :
         {glm::dvec3(0.3, -1, 0.2), glm::dvec3(0, -1, 0), glm::dvec3(0.3, -0.2, -1)}) {
      CasterSet set;
      fillRandomScene(set, rng, origin, 600.0, 4000);
      set.build();
      const CascadeFrame f = makeFrame(origin, light);
      CullResult tree, brute;
      cullCasters(set, f, 0.0f, tree);
      cullCastersBruteForce(set, f, 0.0f, brute);
      std::size_t total = 0;
      for (std::uint32_t c = 0; c < f.cascadeCount; ++c) {
        ASSERT_EQ(tree.visible[c], brute.visible[c]) << "cascade " << c;
        total += tree.visible[c].size();
        // Independent check: every caster with a sample point inside the extruded box is kept.
        std::vector<bool> kept(set.size(), false);
        for (auto i : tree.visible[c]) kept[i] = true;
        for (std::uint32_t i = 0; i < set.size(); ++i) {
          const AabbWs b = set.bounds(i);
          const glm::dvec3 center = 0.5 * (b.minWs + b.maxWs), half = 0.5 * (b.maxWs - b.minWs);
          bool inside = false;
          for (int sx = -2; sx <= 2 && !inside; ++sx)
            for (int sy = -2; sy <= 2 && !inside; ++sy)
              for (int sz = -2; sz <= 2 && !inside; ++sz) {
                glm::dvec3 d(sx / 2.0, sy / 2.0, sz / 2.0);
                if (set.isSphere(i)) {
                  if (glm::length(d) > 1.0) continue;
                }
                inside = pointInExtrudedBox(f, c, center + d * half);
              }
          if (inside) {
            EXPECT_TRUE(kept[i]) << "caster " << i << " dropped from cascade " << c;
          }
        }
      }
      EXPECT_GT(total, 0u);
      // The hierarchy visits far fewer casters than brute force does.
      EXPECT_LT(tree.castersTested, brute.castersTested);
    }
  }
}

// Each cascade culled in its own light basis (a cached cascade deferred across a change of
// light is drawn in the basis it shows): one cull gives, per cascade, what a cull of the whole
// frame in that cascade's basis gives, the hierarchy as brute force does.
TEST(Culling, PerCascadeBasesCullEachCascadeInItsOwnBasis) {
  std::mt19937_64 rng(11);
  const glm::dvec3 origin(0, 20, 0);
  CasterSet set;
  fillRandomScene(set, rng, origin, 600.0, 4000);
  set.build();
  const CascadeFrame f = makeFrame(origin, {0.3, -1, 0.2});
  CascadeFrame turned = f;
  turned.lightBasisWs = makeFrame(origin, {0.8, -0.6, -0.3}).lightBasisWs;
  std::array<glm::dmat3, kMaxCascades> bases;
  bases.fill(turned.lightBasisWs);
  bases[0] = f.lightBasisWs;
  CullResult mixed, mixedBrute, own, other;
  cullCasters(set, f, 0.0f, mixed, std::span(bases.data(), f.cascadeCount));
  cullCastersBruteForce(set, f, 0.0f, mixedBrute, std::span(bases.data(), f.cascadeCount));
  cullCasters(set, f, 0.0f, own);
  cullCasters(set, turned, 0.0f, other);
  bool differs = false;
  for (std::uint32_t c = 0; c < f.cascadeCount; ++c) {
    SCOPED_TRACE(c);
    EXPECT_EQ(mixed.visible[c], mixedBrute.visible[c]);
    EXPECT_EQ(mixed.visible[c], c == 0 ? own.visible[c] : other.visible[c]);
    differs = differs || (c > 0 && own.visible[c] != other.visible[c]);
  }
  EXPECT_TRUE(differs);  // the two bases keep different casters
}

// Moving casters cost what changed: after every kind of change (bounds moved within and far
// out of their leaf, a sphere turned box, removals, revivals, casters added after the build) the
// refitted hierarchy gives the answer of brute force over the same casters and of a hierarchy
// built afresh, and a removed caster is in no list.
TEST(Culling, MovedRemovedAndAddedCastersMatchAFreshBuild) {
  std::mt19937_64 rng(11);
  for (const glm::dvec3& origin : {glm::dvec3(0, 20, 0), glm::dvec3(1e7, 20, -1e7)}) {
    CasterSet set;
    fillRandomScene(set, rng, origin, 600.0, 3000);
    set.build();
    const CascadeFrame f = makeFrame(origin, {0.3, -1, 0.2});
    std::uniform_int_distribution<std::uint32_t> pick(0, 2999);
    std::uniform_real_distribution<double> step(-3.0, 3.0), jump(-900.0, 900.0), size(0.05, 20.0);
    std::vector<bool> gone(3000, false);
    for (int frame = 0; frame < 40; ++frame) {
      // 50 small moves, 5 far jumps, 3 removals, 2 revivals and an addition a frame.
      for (int k = 0; k < 60; ++k) {
        const std::uint32_t i = pick(rng);
        const AabbWs b = set.bounds(i);
        const glm::dvec3 d = k < 50 ? glm::dvec3(step(rng), step(rng), step(rng))
                                    : glm::dvec3(jump(rng), 0.0, jump(rng));
        if (k < 55) {
          if (k % 2 == 0) {
            ASSERT_TRUE(set.setBox(i, b.minWs + d, b.maxWs + d).ok());
          } else {
            ASSERT_TRUE(set.setSphere(i, 0.5 * (b.minWs + b.maxWs) + d, size(rng)).ok());
          }
          gone[i] = false;
        } else if (k < 58) {
          ASSERT_TRUE(set.remove(i).ok());
          EXPECT_TRUE(set.removed(i));
          gone[i] = true;
        } else {
          ASSERT_TRUE(set.setBox(i, b.minWs, b.maxWs).ok());  // back, where it was
          EXPECT_FALSE(set.removed(i));
          gone[i] = false;
        }
      }
      const glm::dvec3 c = origin + glm::dvec3(jump(rng) * 0.3, 0.0, jump(rng) * 0.3);
      ASSERT_TRUE(set.addBox(c - glm::dvec3(4.0), c + glm::dvec3(4.0)).ok());
      gone.push_back(false);
      EXPECT_TRUE(set.built());
      EXPECT_EQ(set.unindexedCount(), std::size_t(frame + 1));

      CasterSet fresh;
      for (std::uint32_t i = 0; i < set.size(); ++i) {
        const AabbWs b = set.bounds(i);
        if (set.isSphere(i)) {
          ASSERT_TRUE(
              fresh.addSphere(0.5 * (b.minWs + b.maxWs), 0.5 * (b.maxWs.x - b.minWs.x)).ok());
        } else {
          ASSERT_TRUE(fresh.addBox(b.minWs, b.maxWs).ok());
        }
        if (gone[i]) {
          ASSERT_TRUE(fresh.remove(i).ok());
        }
      }
      fresh.build();
      CullResult tree, brute, rebuilt;
      cullCasters(set, f, 0.0f, tree);
      cullCastersBruteForce(set, f, 0.0f, brute);
      cullCasters(fresh, f, 0.0f, rebuilt);
      std::size_t total = 0;
      for (std::uint32_t c = 0; c < f.cascadeCount; ++c) {
        ASSERT_EQ(tree.visible[c], brute.visible[c]) << "frame " << frame << " cascade " << c;
        ASSERT_EQ(tree.visible[c], rebuilt.visible[c]) << "frame " << frame << " cascade " << c;
        for (auto i : tree.visible[c]) ASSERT_FALSE(gone[i]) << "removed caster " << i;
        total += tree.visible[c].size();
      }
      EXPECT_GT(total, 0u);
    }
    // A rebuild takes the added casters into the hierarchy.
    set.build();
    EXPECT_EQ(set.unindexedCount(), 0u);
  }
}

TEST(Culling, UpdatesOfUnknownCastersOrBadBoundsAreRefusedByName) {
  CasterSet set;
  ASSERT_TRUE(set.addBox(glm::dvec3(0.0), glm::dvec3(1.0)).ok());
  set.build();
  auto outOfRange = set.setBox(1, glm::dvec3(0.0), glm::dvec3(1.0));
  ASSERT_FALSE(outOfRange.ok());
  EXPECT_NE(outOfRange.error().message().find("caster index"), std::string::npos);
  EXPECT_FALSE(set.remove(7).ok());
  EXPECT_FALSE(set.setSphere(3, glm::dvec3(0.0), 1.0).ok());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto bad = set.setBox(0, glm::dvec3(0.0, nan, 0.0), glm::dvec3(1.0));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message().find("caster.minWs[1]"), std::string::npos);
  auto inverted = set.setBox(0, glm::dvec3(2.0), glm::dvec3(1.0));
  ASSERT_FALSE(inverted.ok());
  EXPECT_NE(inverted.error().message().find("caster.maxWs[0]"), std::string::npos);
  EXPECT_FALSE(set.setSphere(0, glm::dvec3(0.0), -1.0).ok());
  // Refused changes change nothing.
  EXPECT_EQ(set.bounds(0).minWs, glm::dvec3(0.0));
  EXPECT_EQ(set.bounds(0).maxWs, glm::dvec3(1.0));
  EXPECT_FALSE(set.removed(0));
}

TEST(Culling, BehindAndBesideAreDroppedTowardTheLightIsKept) {
  // Oblique lights too: there the light's axes are not world axes, and rounding in the
  // separating-axis projections once kept boxes that lie beside the volume.
  for (const glm::dvec3& light :
       {glm::dvec3(0.0, -1.0, 0.0), glm::dvec3(0.3, -1.0, 0.2), glm::dvec3(0.3, -0.2, -1.0)}) {
    const CascadeFrame f = makeFrame({0, 10, 0}, light, 1);
    const Cascade& k = f.cascades[0];
    const glm::dmat3& b = f.lightBasisWs;
    const double h = k.halfExtentLs.x;
    CasterSet set;
    const double r = 1.0;
    // A box whose light-space bounds are [centre +- r] along each light axis is an oriented
    // box; its world AABB is larger by at most sqrt(3), so place the boxes 2 r clear of that.
    const glm::dvec3 e = glm::dvec3(r);
    const double clear = 2.5 * r;
    // 0: inside; 1: behind the box (beyond its far side); 2: beside it; 3: far toward the
    // light (a mountain top high above the cascade); 4: beside and toward the light (box);
    // 5: beside on the other axis (box); 6: straddling the side (box).
    ASSERT_TRUE(set.addSphere(k.boxCenterWs, r).ok());
    ASSERT_TRUE(set.addSphere(k.boxCenterWs + b[2] * (k.depthFarLs + 2 * r), r).ok());
    ASSERT_TRUE(set.addSphere(k.boxCenterWs + b[0] * (h + 2 * r), r).ok());
    ASSERT_TRUE(set.addSphere(k.boxCenterWs - b[2] * 5000.0, r).ok());
    const glm::dvec3 p4 = k.boxCenterWs + b[1] * (h + clear * 2) - b[2] * 100.0;
    ASSERT_TRUE(set.addBox(p4 - e, p4 + e).ok());
    const glm::dvec3 p5 = k.boxCenterWs - b[0] * (h + clear * 2) - b[2] * 10.0;
    ASSERT_TRUE(set.addBox(p5 - e, p5 + e).ok());
    const glm::dvec3 p6 = k.boxCenterWs + b[0] * h - b[2] * 30.0;
    ASSERT_TRUE(set.addBox(p6 - e, p6 + e).ok());
    // 7: just beside the side along light x (0.3 m clear of it, exactly computed).
    const double rx = glm::dot(e, glm::abs(b[0]));
    const glm::dvec3 p7 = k.boxCenterWs + b[0] * (h + rx + 0.3) - b[2] * 30.0;
    ASSERT_TRUE(set.addBox(p7 - e, p7 + e).ok());
    set.build();
    CullResult out, brute;
    cullCasters(set, f, 0.0f, out);
    cullCastersBruteForce(set, f, 0.0f, brute);
    EXPECT_EQ(out.visible[0], (std::vector<std::uint32_t>{0, 3, 6})) << light.x;
    EXPECT_EQ(brute.visible[0], out.visible[0]);
  }
}

TEST(Culling, CastersSmallerThanTheThresholdAreDroppedPerCascade) {
  const CascadeFrame f = makeFrame({0, 10, 0}, {0.2, -1, 0.1}, 4);
  // A small sphere in the overlap of cascade 0's and cascade 3's boxes.
  const glm::dvec3 p = f.cascades[0].sphereCenterWs;
  ASSERT_TRUE(pointInExtrudedBox(f, 3, p));
  const double texel3 = f.cascades[3].texelSizeM();
  const double texel0 = f.cascades[0].texelSizeM();
  ASSERT_LT(texel0 * 8, texel3);
  CasterSet set;
  ASSERT_TRUE(set.addSphere(p, 0.5 * texel3).ok());  // one texel of cascade 3, many of cascade 0
  set.build();
  CullResult out;
  cullCasters(set, f, 2.0f, out);
  EXPECT_EQ(out.visible[0].size(), 1u);
  EXPECT_EQ(out.visible[3].size(), 0u);
  cullCasters(set, f, 0.0f, out);  // off
  EXPECT_EQ(out.visible[3].size(), 1u);
}

TEST(Culling, EmptyCascadesAndEmptySets) {
  CasterSet set;
  set.build();
  const CascadeFrame f = makeFrame({0, 10, 0}, {0, -1, 0});
  CullResult out;
  cullCasters(set, f, 0.0f, out);
  for (auto& v : out.visible) EXPECT_TRUE(v.empty());
  ASSERT_TRUE(set.addSphere({0, 0, 0}, 1.0).ok());
  EXPECT_EQ(set.unindexedCount(), 1u);  // added after the build: tested one by one
  cullCasters(set, f, 0.0f, out);
  EXPECT_EQ(out.visible[0].size(), 1u);
}

}  // namespace
}  // namespace csm

namespace csm {
namespace {

// A caster widened in the depth pass (a thin caster's rim) reaches a cascade whose box, grown by
// its margin in that cascade's texels, its bounds meet: small boxes just outside a cascade's box
// are kept with a margin and dropped without, the hierarchy agrees with brute force, and bad
// margins are refused by name.
TEST(Culling, MarginsGrowTheBoxByTheCastersTexels) {
  for (const glm::dvec3& origin : {glm::dvec3(0, 20, 0), glm::dvec3(1e7, 20, -1e7)}) {
    const CascadeFrame f = makeFrame(origin, glm::dvec3(0.3, -1, 0.2));
    const Cascade& k = f.cascades[1];
    const double texel = k.texelSizeM();
    // A 1 cm box centred gap + 0.5 cm beyond the box's +x face, at the box centre's depth.
    const glm::dmat3& b = f.lightBasisWs;
    auto placed = [&](double gapTexels) {
      return k.boxCenterWs + b[0] * (k.halfExtentLs.x + gapTexels * texel + 0.005);
    };
    CasterSet set;
    for (double gap : {0.5, 1.5, 3.0}) {
      const glm::dvec3 c = placed(gap);
      ASSERT_TRUE(set.addBox(c - glm::dvec3(0.005), c + glm::dvec3(0.005)).ok());
    }
    for (std::uint32_t i = 0; i < 3; ++i) ASSERT_TRUE(set.setMarginTexels(i, 2.0f).ok());
    // The same three without a margin, for comparison.
    for (double gap : {0.5, 1.5, 3.0}) {
      const glm::dvec3 c = placed(gap);
      ASSERT_TRUE(set.addBox(c - glm::dvec3(0.005), c + glm::dvec3(0.005)).ok());
    }
    set.build();
    CullResult tree, brute;
    cullCasters(set, f, 0.0f, tree);
    cullCastersBruteForce(set, f, 0.0f, brute);
    EXPECT_EQ(tree.visible[1], brute.visible[1]);
    const auto& v = tree.visible[1];
    auto kept = [&](std::uint32_t i) { return std::find(v.begin(), v.end(), i) != v.end(); };
    EXPECT_TRUE(kept(0)) << "0.5 texels out, margin 2";
    EXPECT_TRUE(kept(1)) << "1.5 texels out, margin 2";
    EXPECT_FALSE(kept(2)) << "3 texels out, margin 2";
    EXPECT_FALSE(kept(3)) << "0.5 texels out, no margin";
    EXPECT_FALSE(kept(4));
    EXPECT_FALSE(kept(5));
    EXPECT_FLOAT_EQ(set.marginTexels(0), 2.0f);
    EXPECT_FLOAT_EQ(set.marginTexels(3), 0.0f);
  }
  CasterSet set;
  ASSERT_TRUE(set.addSphere(glm::dvec3(0.0), 1.0).ok());
  for (float bad : {-1.0f, 65.0f, std::numeric_limits<float>::quiet_NaN()}) {
    auto r = set.setMarginTexels(0, bad);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message().find("caster.marginTexels"), std::string::npos);
  }
  EXPECT_FALSE(set.setMarginTexels(1, 1.0f).ok()) << "index out of range";
}

}  // namespace
}  // namespace csm
