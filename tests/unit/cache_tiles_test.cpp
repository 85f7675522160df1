// Receiver-marked tiles in the cache's plan (planCacheFrame with CacheTileInputs): the marks
// carried onto a cascade's grid (the same world tiles; across a light step and a camera move, a
// superset holding every receiver), which cascades may be partial (their slice inside the last
// cascade's box, the fallback), what a partial cascade draws (only the stale texels of marked
// tiles, and marked tiles it does not hold) and holds, the way back to whole, and the uniform
// block's tile fields.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <csm/cache_plan.hpp>
#include <csm/cascades.hpp>
#include <csm/gpu_layout.hpp>
#include <csm/receiver_tiles.hpp>
#include <csm/selection.hpp>

namespace {

struct View {
  csm::Camera camera;
  csm::DirectionalLight light{glm::dvec3(0.3, -0.8, 0.52)};
};

View viewAt(const glm::dvec3& at, double fovDeg = 60.0) {
  View v;
  v.camera.positionWs = at;
  v.camera.orientationWs = glm::angleAxis(glm::radians(-12.0), glm::dvec3(1, 0, 0));
  v.camera.fovYRad = glm::radians(fovDeg);
  v.camera.nearM = 0.5;
  v.camera.farM = 2000.0;
  return v;
}

csm::ShadowSettings tileSettings() {
  csm::ShadowSettings s;
  s.resolution = 1024;
  s.cascadeCount = 4;
  s.shadowDistanceM = 300.0;
  return s;
}

csm::CascadeFrame frameOf(const csm::ShadowSettings& s, const View& v) {
  auto f = csm::computeCascades(s, v.camera, v.light);
  EXPECT_TRUE(f.ok());
  return f.value();
}

/// Receivers on the ground plane y = 0 that the camera sees (within its frustum and the shadow
/// distance), on a grid of `stepM`.
std::vector<glm::dvec3> groundReceivers(const View& v, double farM, double stepM) {
  std::vector<glm::dvec3> out;
  const glm::dvec3 fwd = v.camera.forwardWs();
  const glm::dvec3 right = v.camera.rightWs();
  const glm::dvec3 up = v.camera.upWs();
  const double tanY = std::tan(0.5 * v.camera.fovYRad);
  const double tanX = tanY * v.camera.aspect;
  const glm::dvec3 c = v.camera.positionWs;
  for (double x = c.x - farM; x <= c.x + farM; x += stepM) {
    for (double z = c.z - farM; z <= c.z + farM; z += stepM) {
      const glm::dvec3 p(x, 0.0, z);
      const glm::dvec3 d = p - c;
      const double depth = glm::dot(d, fwd);
      if (depth < v.camera.nearM || depth > farM) continue;
      if (std::abs(glm::dot(d, right)) > depth * tanX || std::abs(glm::dot(d, up)) > depth * tanY) {
        continue;
      }
      out.push_back(p);
    }
  }
  return out;
}

/// The marks those receivers make in `frame`.
csm::ReceiverTileMarks marksOf(const csm::ShadowSettings& s, const csm::CascadeFrame& frame,
                               const View& v, const std::vector<glm::dvec3>& receivers) {
  csm::ReceiverTileMarks m = csm::emptyReceiverTileMarks(s, frame);
  for (const glm::dvec3& p : receivers) {
    csm::markReceiverTiles(m, p, glm::dot(p - v.camera.positionWs, v.camera.forwardWs()));
  }
  return m;
}

/// The world tile (tiles of `tile` texels of `texel` metres) of light-space x, y of `p`.
glm::i64vec2 worldTile(const glm::dvec3& p, const glm::dmat3& basis, double texel,
                       std::int64_t tile) {
  const glm::dvec3 q = glm::transpose(basis) * p;
  return {csm::floorDiv(std::int64_t(std::floor(q.x / texel)), tile),
          csm::floorDiv(std::int64_t(std::floor(q.y / texel)), tile)};
}

csm::CacheTileInputs tileInputs(const csm::ShadowSettings& s, const csm::CascadeFrame& f,
                                const csm::ReceiverTileMarks* marks) {
  csm::CacheTileInputs in;
  in.marks = marks;
  for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
    in.reachTexels[i] = csm::receiverSampleReachTexels(s, f, i);
  }
  return in;
}

/// The cache's state just before a camera cut: one frame shown far away (the view's first frame,
/// drawn whole), with marks until then. The next frame opens a new window in every cascade.
csm::CacheState stateBeforeCut(const csm::ShadowSettings& s) {
  csm::CacheState state;
  csm::CascadeFrame f = frameOf(s, viewAt(glm::dvec3(5000.0, 2.0, -5000.0)));
  const csm::CacheTileInputs in = tileInputs(s, f, nullptr);
  csm::markCacheRecorded(csm::planCacheFrame(f, state, s.resolution, 0, 1, &in), state);
  state.unmarkedFrames = 0;
  return state;
}

/// The tiles of row y that a partial cascade draws whole: those marked and not held (in its
/// box), and the gaps of at most kTileGapFill tiles between two of them.
template <class Held, class InBox>
std::array<bool, csm::kTileGridSide> wholeRow(const csm::TileMask& marked, Held held, InBox inBox,
                                              std::int64_t y) {
  std::array<bool, csm::kTileGridSide> whole{};
  std::int64_t last = -1;
  for (std::int64_t x = 0; x < csm::kTileGridSide; ++x) {
    if (!inBox(x, y) || !marked.test(x, y) || held(x, y)) continue;
    if (last >= 0 && x - last - 1 <= csm::kTileGapFill) {
      for (std::int64_t g = last + 1; g < x; ++g) whole[std::size_t(g)] = true;
    }
    whole[std::size_t(x)] = true;
    last = x;
  }
  return whole;
}

std::uint64_t areaIn(const std::vector<csm::TexelRect>& rects, const csm::TexelRect& r) {
  std::uint64_t a = 0;
  for (const csm::TexelRect& q : rects) a += q.intersect(r).area();
  return a;
}

TEST(CacheTiles, CarriedMarksAreTheSameWorldTilesInTheSameBasis) {
  const csm::ShadowSettings s = tileSettings();
  for (const glm::dvec3 at : {glm::dvec3(3.0, 2.0, 7.0), glm::dvec3(-1e7, 2.0, 1e7)}) {
    const View v = viewAt(at);
    const csm::CascadeFrame f = frameOf(s, v);
    const csm::ReceiverTileMarks m = marksOf(s, f, v, groundReceivers(v, 300.0, 2.0));
    for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
      ASSERT_GT(m.markedCount(i), 0u) << i;
      csm::TileMask mask;
      mask.origin = m.gridOrigin[i] + glm::i64vec2(3, -2);
      csm::carryTileMarks(m, i, f.lightBasisWs, m.texelM[i], m.tileTexels, 0.0, 0.0, mask);
      std::uint32_t inGrid = 0;
      for (std::int64_t y = 0; y < csm::kTileGridSide; ++y) {
        for (std::int64_t x = 0; x < csm::kTileGridSide; ++x) {
          const bool marked = m.marked(std::uint32_t(i), std::uint32_t(x), std::uint32_t(y));
          const glm::i64vec2 w = m.gridOrigin[i] + glm::i64vec2(x, y);
          EXPECT_EQ(mask.testWorld(w.x, w.y),
                    marked && w.x >= mask.origin.x && w.y <= mask.origin.y + 16)
              << "cascade " << i << " tile " << x << ", " << y;
          inGrid += marked && mask.testWorld(w.x, w.y) ? 1u : 0u;
        }
      }
      EXPECT_EQ(mask.count(), inGrid);
    }
  }
}

TEST(CacheTiles, CarriedMarksHoldEveryReceiverAcrossALightStepAndACameraMove) {
  const csm::ShadowSettings s = tileSettings();
  const View before = viewAt(glm::dvec3(10.0, 2.0, -40.0));
  const csm::CascadeFrame f0 = frameOf(s, before);
  const std::vector<glm::dvec3> receivers = groundReceivers(before, 300.0, 1.5);
  const csm::ReceiverTileMarks m = marksOf(s, f0, before, receivers);
  // Three frames later: the sun stepped by 0.6 degrees, the camera moved 4 m.
  View after = before;
  after.camera.positionWs += glm::dvec3(2.5, 0.0, -3.1);
  after.light.directionWs =
      glm::angleAxis(glm::radians(0.6), glm::dvec3(0, 1, 0)) * before.light.directionWs;
  const csm::CascadeFrame f1 = frameOf(s, after);
  ASSERT_NE(f1.lightBasisWs, f0.lightBasisWs);
  const glm::dvec3 moved = after.camera.positionWs - before.camera.positionWs;
  const std::int64_t tile = s.resolution / csm::kTilesPerSide;
  std::uint32_t checked = 0;
  for (std::uint32_t i = 0; i < f1.cascadeCount; ++i) {
    const csm::Cascade& c = f1.cascades[i];
    const double texel = c.texelSizeLs.x;
    const glm::dvec3 centerLs = glm::transpose(f1.lightBasisWs) * c.boxCenterWs;
    csm::TileMask still, ahead;
    still.origin = {csm::floorDiv(csm::cacheBoxStart(centerLs.x, texel, s.resolution), tile),
                    csm::floorDiv(csm::cacheBoxStart(centerLs.y, texel, s.resolution), tile)};
    ahead.origin = still.origin;
    const double z = (glm::transpose(m.lightBasisWs) * c.sphereCenterWs).z;
    const double r = 1.25 * c.sphereRadiusM;
    csm::carryTileMarks(m, i, f1.lightBasisWs, texel, tile, z - r, z + r, still);
    csm::carryTileMarks(m, i, f1.lightBasisWs, texel, tile, z - r, z + r, ahead, moved);
    // Every receiver the marks hold in cascade i (shaded there before) is in the carried tiles
    // where it lies now, and moved by the camera's move in the moved ones.
    for (const glm::dvec3& p : receivers) {
      const double depth = glm::dot(p - before.camera.positionWs, before.camera.forwardWs());
      const auto [a, b] = csm::shadingCascades(m, depth);
      if (a != int(i) && b != int(i)) continue;
      for (const auto& [q, mask] : {std::pair{p, &still}, std::pair{p + moved, &ahead}}) {
        const glm::i64vec2 w = worldTile(q, f1.lightBasisWs, texel, tile);
        const glm::i64vec2 g = w - mask->origin;
        if (g.x < 0 || g.y < 0 || g.x >= csm::kTileGridSide || g.y >= csm::kTileGridSide) {
          continue;  // outside this frame's grid: nothing to draw there
        }
        ++checked;
        EXPECT_TRUE(mask->test(g.x, g.y)) << "cascade " << i << " receiver " << q.x << ", " << q.z;
      }
    }
  }
  EXPECT_GT(checked, 1000u);
}

/// The tiles of cascade i (on the grid of box `box`) that the view of `f` can sample at view
/// depths [nearM, splitsM[i + 1]].
csm::TileMask frustumTiles(const csm::ShadowSettings& s, const csm::CascadeFrame& f,
                           const csm::TexelRect& box, std::uint32_t i, double nearM) {
  const std::int64_t tile = s.resolution / csm::kTilesPerSide;
  csm::TileMask m;
  m.origin = {csm::floorDiv(box.x0, tile), csm::floorDiv(box.y0, tile)};
  const double texel = f.cascades[i].texelSizeLs.x;
  EXPECT_TRUE(csm::markFrustumTiles(f, nearM, f.splitsM[i + 1], f.lightBasisWs, texel, tile,
                                    csm::receiverSampleReachTexels(s, f, i) * texel, m));
  return m;
}

/// Tiles of a grid on `box` that hold some of it.
std::uint32_t tilesInBox(const csm::TexelRect& box, std::int64_t res) {
  const std::int64_t tile = res / csm::kTilesPerSide;
  const std::int64_t x0 = csm::floorDiv(box.x0, tile), y0 = csm::floorDiv(box.y0, tile);
  const std::int64_t x1 = csm::floorDiv(box.x1 - 1, tile), y1 = csm::floorDiv(box.y1 - 1, tile);
  return std::uint32_t((x1 - x0 + 1) * (y1 - y0 + 1));
}

TEST(CacheTiles, FrustumTilesHoldEveryReceiverTheViewCanSee) {
  // Receivers anywhere in the view's frustum (not only on the ground), marked as the GPU marks
  // them: each lies in the frustum tiles of the cascades it is shaded with, for views near the
  // origin and 10^7 m from it, wide and narrow, looking level, down and straight down, under a
  // sun at 45 degrees, overhead, grazing and along the view.
  csm::ShadowSettings s = tileSettings();
  const std::int64_t tile = s.resolution / csm::kTilesPerSide;
  std::uint64_t checked = 0;
  std::uint32_t narrower = 0;
  std::uint32_t seed = 12345;
  auto uniform = [&seed](double a, double b) {
    seed = seed * 1664525u + 1013904223u;
    return a + (b - a) * double(seed >> 8) / double(1u << 24);
  };
  for (const glm::dvec3 at : {glm::dvec3(3.0, 2.0, 7.0), glm::dvec3(1e7, 40.0, -1e7)}) {
    for (const double pitchDeg : {-12.0, -60.0, -90.0}) {
      for (const double fovDeg : {60.0, 8.0}) {
        View v = viewAt(at, fovDeg);
        v.camera.orientationWs = glm::angleAxis(glm::radians(35.0), glm::dvec3(0, 1, 0)) *
                                 glm::angleAxis(glm::radians(pitchDeg), glm::dvec3(1, 0, 0));
        const glm::dvec3 fwd = v.camera.forwardWs();
        for (const glm::dvec3 sun : {glm::dvec3(0.5, -0.707, 0.5), glm::dvec3(0.0, -1.0, 0.0),
                                     glm::dvec3(0.7, -0.035, -0.7), fwd}) {
          v.light.directionWs = sun;
          const csm::CascadeFrame f = frameOf(s, v);
          const csm::ReceiverTileMarks empty = csm::emptyReceiverTileMarks(s, f);
          std::array<csm::TileMask, csm::kMaxCascades> own{}, all{};
          for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
            if (f.cascades[i].empty) continue;
            for (auto [mask, nearM] : {std::pair{&own[i], csm::cascadeReadFromM(f, i, f.blendBand)},
                                       std::pair{&all[i], f.splitsM[0]}}) {
              mask->origin = empty.gridOrigin[i];
              ASSERT_TRUE(csm::markFrustumTiles(f, nearM, f.splitsM[i + 1], f.lightBasisWs,
                                                empty.texelM[i], tile, empty.reachM[i], *mask));
            }
            EXPECT_LE(own[i].count(), all[i].count());
            narrower += own[i].count() < all[i].count() ? 1u : 0u;
          }
          const glm::dvec3 right = v.camera.rightWs(), up = v.camera.upWs();
          const double tanY = std::tan(0.5 * v.camera.fovYRad);
          const double tanX = tanY * v.camera.aspect;
          for (int k = 0; k < 400; ++k) {
            // Half of them on the frustum's edges, where only the reach's widening holds them.
            const double d = uniform(f.splitsM[0], f.splitsM[f.cascadeCount]);
            const bool edge = k % 2 == 0;
            const double sx = edge ? (uniform(0.0, 1.0) < 0.5 ? -1.0 : 1.0) : uniform(-1.0, 1.0);
            const double sy = edge ? (uniform(0.0, 1.0) < 0.5 ? -1.0 : 1.0) : uniform(-1.0, 1.0);
            const glm::dvec3 q = fwd * d + right * (sx * tanX * d) + up * (sy * tanY * d);
            csm::ReceiverTileMarks m = empty;
            csm::markReceiverTiles(m, at + q, glm::dot(q, fwd));
            for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
              for (std::uint32_t y = 0; y < csm::kTileGridSide; ++y) {
                for (std::uint32_t x = 0; x < csm::kTileGridSide; ++x) {
                  if (!m.marked(i, x, y)) continue;
                  ++checked;
                  ASSERT_TRUE(own[i].test(x, y) && all[i].test(x, y))
                      << "cascade " << i << " tile " << x << ", " << y << " at depth " << d
                      << ", pitch " << pitchDeg << ", fov " << fovDeg << ", sun " << sun.x << ", "
                      << sun.y << ", " << sun.z;
                }
              }
            }
          }
        }
      }
    }
  }
  EXPECT_GT(checked, 10000u);
  EXPECT_GT(narrower, 0u) << "a cascade's own depths sample less of it than every depth";
  // A frame without its camera's frustum (built by hand) marks nothing.
  csm::CascadeFrame f = frameOf(s, viewAt(glm::dvec3(0.0)));
  f.cameraTanHalfFovY = 0.0;
  csm::TileMask m;
  m.bits.fill(~0u);
  EXPECT_FALSE(csm::markFrustumTiles(f, 0.0, 100.0, f.lightBasisWs, 0.1, tile, 0.3, m));
  EXPECT_EQ(m.count(), 0u);
}

TEST(CacheTiles, TheViewsFirstFrameWithoutMarksDrawsEveryCascadeWhole) {
  // Nothing shown yet and no marks (the start, or a new image): every cascade whole, as the
  // cache alone draws it, so no pixel falls back; the next frame without marks draws only the
  // stale texels of what the view can sample, which the first frame holds already.
  const csm::ShadowSettings s = tileSettings();
  const View v = viewAt(glm::dvec3(-1e7, 2.0, 1e7));
  csm::CacheState state;
  csm::CascadeFrame f = frameOf(s, v);
  csm::CacheTileInputs in = tileInputs(s, f, nullptr);
  csm::CachePlan p = csm::planCacheFrame(f, state, s.resolution, 0, 1, &in);
  const std::uint64_t layer = std::uint64_t(s.resolution) * s.resolution;
  for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
    const csm::CacheCascadePlan& c = p.cascades[i];
    EXPECT_FALSE(c.partial) << i;
    EXPECT_TRUE(c.full) << i;
    EXPECT_EQ(c.staleTexels, layer) << i;
    EXPECT_EQ(c.tilesDrawn, 0u) << i;
  }
  EXPECT_EQ(csm::packCachedUniforms(f, s, {}, p).tilePartialMask, 0u);
  csm::markCacheRecorded(p, state);
  EXPECT_EQ(state.unmarkedFrames, 1u);
  // The same view again, still without marks: partial cascades now, each holding every tile
  // the first frame drew, so nothing is drawn.
  f = frameOf(s, v);
  in = tileInputs(s, f, nullptr);
  p = csm::planCacheFrame(f, state, s.resolution, 0, 1, &in);
  std::uint32_t partial = 0;
  for (std::uint32_t i = 0; i + 1 < f.cascadeCount; ++i) {
    const csm::CacheCascadePlan& c = p.cascades[i];
    if (!c.partial) continue;
    ++partial;
    EXPECT_GT(c.marked.count(), 0u) << i << ": what the view can sample";
    EXPECT_TRUE(c.stale.empty()) << i;
    EXPECT_EQ(c.tilesDrawn, 0u) << i;
    // Every tile of the box is held: the first frame drew them all.
    const std::int64_t t = s.resolution / csm::kTilesPerSide;
    for (std::int64_t y = 0; y < csm::kTileGridSide; ++y) {
      for (std::int64_t x = 0; x < csm::kTileGridSide; ++x) {
        const glm::i64vec2 w = c.tiles.origin + glm::i64vec2(x, y);
        const csm::TexelRect r{w.x * t, w.y * t, (w.x + 1) * t, (w.y + 1) * t};
        if (!r.intersect(c.box).empty()) {
          EXPECT_TRUE(c.tiles.test(x, y)) << i;
        }
      }
    }
  }
  EXPECT_GT(partial, 0u);
  // With marks at the first frame (a host that had them), the first frame is partial already.
  csm::CacheState marked;
  f = frameOf(s, v);
  const csm::ReceiverTileMarks marks = marksOf(s, f, v, groundReceivers(v, 300.0, 2.0));
  in = tileInputs(s, f, &marks);
  p = csm::planCacheFrame(f, marked, s.resolution, 0, 1, &in);
  EXPECT_TRUE(p.cascades[0].partial);
}

TEST(CacheTiles, OnlyTheFirstFrameWithoutMarksFallsBack) {
  // A cut: the partial cascades of the first frame without marks draw nothing (their pixels
  // fall back to the last cascade); the next frames without marks draw every tile the view can
  // sample in them; the first marks then only add what the view can sample.
  const csm::ShadowSettings s = tileSettings();
  const std::int64_t res = s.resolution;
  View v = viewAt(glm::dvec3(0.0, 2.0, 0.0));
  csm::CacheState state;
  csm::CascadeFrame f = frameOf(s, v);
  csm::ReceiverTileMarks marks = marksOf(s, f, v, groundReceivers(v, 300.0, 2.0));
  csm::CacheTileInputs in = tileInputs(s, f, &marks);
  csm::CachePlan p = csm::planCacheFrame(f, state, s.resolution, 0, 1, &in);
  csm::markCacheRecorded(p, state);
  EXPECT_EQ(state.unmarkedFrames, 0u);
  v = viewAt(glm::dvec3(900.0, 2.0, -700.0));
  const std::uint32_t last = f.cascadeCount - 1;
  for (int frame = 0; frame < 3; ++frame) {
    f = frameOf(s, v);
    in = tileInputs(s, f, nullptr);
    p = csm::planCacheFrame(f, state, s.resolution, 0, 1, &in);
    EXPECT_EQ(state.unmarkedFrames, std::uint32_t(frame + 1));
    std::uint32_t partial = 0;
    for (std::uint32_t i = 0; i < last; ++i) {
      const csm::CacheCascadePlan& c = p.cascades[i];
      if (!c.partial) continue;
      ++partial;
      if (frame == 0) {
        EXPECT_EQ(c.marked.count(), 0u) << i;
        EXPECT_TRUE(c.stale.empty()) << i;
        continue;
      }
      const csm::TileMask view =
          frustumTiles(s, f, c.box, i, csm::cascadeReadFromM(f, i, f.blendBand));
      EXPECT_EQ(c.marked, view) << i;
      for (std::int64_t y = 0; y < csm::kTileGridSide; ++y) {
        for (std::int64_t x = 0; x < csm::kTileGridSide; ++x) {
          const glm::i64vec2 w = view.origin + glm::i64vec2(x, y);
          const std::int64_t t = res / csm::kTilesPerSide;
          const bool inBox = !csm::TexelRect{w.x * t, w.y * t, (w.x + 1) * t, (w.y + 1) * t}
                                  .intersect(c.box)
                                  .empty();
          if (view.test(x, y) && inBox) {
            EXPECT_TRUE(c.tiles.test(x, y)) << i << ": " << x << ", " << y;
          }
        }
      }
      if (frame == 2) {
        EXPECT_EQ(c.tilesDrawn, 0u) << i << ": the same view holds them already";
      }
    }
    EXPECT_GT(partial, 0u);
    csm::markCacheRecorded(p, state);
  }
  marks = marksOf(s, f, v, groundReceivers(v, 300.0, 2.0));
  f = frameOf(s, v);
  in = tileInputs(s, f, &marks);
  p = csm::planCacheFrame(f, state, s.resolution, 0, 1, &in);
  EXPECT_EQ(state.unmarkedFrames, 0u);
  for (std::uint32_t i = 0; i < last; ++i) {
    const csm::CacheCascadePlan& c = p.cascades[i];
    if (!c.partial) continue;
    EXPECT_EQ(c.tilesDrawn, 0u) << i << ": the view's tiles are held already";
    EXPECT_LE(c.marked.count(),
              frustumTiles(s, f, c.box, i, csm::cascadeReadFromM(f, i, f.blendBand)).count())
        << i;
  }
}

TEST(CacheTiles, PartialCascadesDrawOnlyMarkedTilesAndTheLastWhatTheViewSamples) {
  const csm::ShadowSettings s = tileSettings();
  const std::int64_t res = s.resolution, tile = res / csm::kTilesPerSide;
  View v = viewAt(glm::dvec3(0.0, 2.0, 0.0));
  csm::CacheState state = stateBeforeCut(s);
  // A cut's first frame, no marks yet: the partial cascades draw nothing, the last one every tile
  // the view can sample in it (every depth of the shadows: the others fall back to it), and no
  // more.
  csm::CascadeFrame f = frameOf(s, v);
  csm::CacheTileInputs in = tileInputs(s, f, nullptr);
  csm::CachePlan p = csm::planCacheFrame(f, state, s.resolution, 0, 1, &in);
  const std::uint32_t last = f.cascadeCount - 1;
  ASSERT_TRUE(p.cascades[0].partial) << "a 60 degree view: cascade 0's slice lies in the last box";
  for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
    const csm::CacheCascadePlan& c = p.cascades[i];
    const double margin = (in.reachTexels[last] + 2.0) * f.cascades[last].texelSizeLs.x;
    EXPECT_EQ(c.partial, i == last || csm::cacheBoxHoldsSphere(
                                          p.cascades[last].box, f.cascades[last].texelSizeLs.x,
                                          f.lightBasisWs, state.layers[last].zNear,
                                          state.layers[last].zFar, margin, f.cascades[i]))
        << i;
    if (i == last) {
      const csm::TileMask view = frustumTiles(s, f, c.box, last, f.splitsM[0]);
      EXPECT_EQ(c.marked, view);
      EXPECT_GT(view.count(), 0u);
      EXPECT_LT(view.count(), tilesInBox(c.box, res))
          << "a 60 degree view at this sun samples only part of the last cascade's box";
      std::uint64_t viewArea = 0;
      for (std::int64_t y = 0; y < csm::kTileGridSide; ++y) {
        for (std::int64_t x = 0; x < csm::kTileGridSide; ++x) {
          const glm::i64vec2 w = view.origin + glm::i64vec2(x, y);
          const csm::TexelRect r =
              csm::TexelRect{w.x * tile, w.y * tile, (w.x + 1) * tile, (w.y + 1) * tile}.intersect(
                  c.box);
          // Every tile the view samples is drawn whole and held.
          if (view.test(x, y)) {
            EXPECT_EQ(areaIn(c.stale, r), r.area()) << x << ", " << y;
            EXPECT_TRUE(c.tiles.test(x, y) || r.empty()) << x << ", " << y;
          }
          viewArea += view.test(x, y) ? r.area() : 0u;
        }
      }
      EXPECT_LE(c.staleTexels, 2 * viewArea);
      EXPECT_LT(c.staleTexels, std::uint64_t(res * res));
    } else if (c.partial) {
      EXPECT_TRUE(c.stale.empty()) << i;
      EXPECT_EQ(c.tiles.count(), 0u) << i;
    } else {
      EXPECT_TRUE(c.full) << i;
    }
  }
  EXPECT_TRUE(p.refreshedMask >> last & 1u);
  csm::markCacheRecorded(p, state);

  // Frame 2, the same view with its marks: each partial cascade draws exactly its marked tiles
  // (within its box) and holds them.
  const csm::ReceiverTileMarks marks = marksOf(s, f, v, groundReceivers(v, 300.0, 1.0));
  f = frameOf(s, v);
  in = tileInputs(s, f, &marks);
  p = csm::planCacheFrame(f, state, s.resolution, 0, 1, &in);
  for (std::uint32_t i = 0; i < last; ++i) {
    const csm::CacheCascadePlan& c = p.cascades[i];
    if (!c.partial) continue;
    auto rectOf = [&](std::int64_t x, std::int64_t y) {
      const glm::i64vec2 w = c.tiles.origin + glm::i64vec2(x, y);
      return csm::TexelRect{w.x * tile, w.y * tile, (w.x + 1) * tile, (w.y + 1) * tile}.intersect(
          c.box);
    };
    auto inBox = [&](std::int64_t x, std::int64_t y) { return !rectOf(x, y).empty(); };
    auto none = [](std::int64_t, std::int64_t) { return false; };
    std::uint64_t wholeArea = 0;
    std::uint32_t gaps = 0;
    for (std::int64_t y = 0; y < csm::kTileGridSide; ++y) {
      const auto whole = wholeRow(c.marked, none, inBox, y);
      for (std::int64_t x = 0; x < csm::kTileGridSide; ++x) {
        const csm::TexelRect r = rectOf(x, y);
        const bool drawn = whole[std::size_t(x)];
        EXPECT_EQ(c.tiles.test(x, y), drawn) << i << ": " << x << ", " << y;
        EXPECT_EQ(areaIn(c.stale, r), drawn ? r.area() : 0u) << i << ": " << x << ", " << y;
        if (inBox(x, y) && c.marked.test(x, y)) {
          EXPECT_TRUE(drawn) << i << ": " << x << ", " << y;
        }
        wholeArea += drawn ? r.area() : 0u;
        gaps += drawn && !c.marked.test(x, y) ? 1u : 0u;
      }
    }
    EXPECT_GT(wholeArea, 0u) << i;
    EXPECT_EQ(c.staleTexels, wholeArea) << i;
    // The marks, only where this frame's view can sample the cascade.
    const csm::TileMask view =
        frustumTiles(s, f, c.box, i, csm::cascadeReadFromM(f, i, f.blendBand));
    for (std::uint32_t w = 0; w < csm::kTileWords; ++w) {
      EXPECT_EQ(c.marked.bits[w] & ~view.bits[w], 0u) << i << " word " << w;
    }
    EXPECT_LE(gaps, c.marked.count()) << i;
    EXPECT_EQ(c.tilesMarked, c.marked.count());
  }
  csm::markCacheRecorded(p, state);

  // Frame 3: the camera moves a few texels of cascade 0 sideways, a static caster changes on
  // the left, and only the receivers on the right are marked now. A partial cascade draws the
  // stale texels (newly exposed, invalidated) only where they lie in marked tiles and the marked
  // tiles it did not hold; a held tile with stale texels that is not marked is no longer held;
  // the others stay held without being drawn.
  std::vector<glm::dvec3> right;
  for (const glm::dvec3& q : groundReceivers(v, 300.0, 1.0)) {
    if (glm::dot(q - v.camera.positionWs, v.camera.rightWs()) > 0.0) right.push_back(q);
  }
  const glm::dvec3 leftAt =
      v.camera.positionWs + 12.0 * v.camera.forwardWs() - 6.0 * v.camera.rightWs();
  const csm::AabbWs changed{glm::dvec3(leftAt.x - 2.0, -1.0, leftAt.z - 2.0),
                            glm::dvec3(leftAt.x + 2.0, 3.0, leftAt.z + 2.0)};
  csm::invalidateCache(state, changed);
  v.camera.positionWs += v.camera.rightWs() * (7.5 * f.cascades[0].texelSizeLs.x);
  f = frameOf(s, v);
  const csm::ReceiverTileMarks rightMarks = marksOf(s, f, v, right);
  const csm::CacheState held = state;
  in = tileInputs(s, f, &rightMarks);
  p = csm::planCacheFrame(f, state, s.resolution, 0, 1, &in);
  std::uint32_t lost = 0, kept = 0;
  for (std::uint32_t i = 0; i < last; ++i) {
    const csm::CacheCascadePlan& c = p.cascades[i];
    if (!c.partial || c.newWindow) continue;
    const csm::CacheLayerState& layer = held.layers[i];
    // What the layer's box did not hold (newly exposed) and what lies under the changed box.
    const csm::TexelRect old{layer.boxX, layer.boxY, layer.boxX + res, layer.boxY + res};
    const csm::TexelRect inv =
        csm::boxTexels(changed, glm::transpose(f.lightBasisWs), f.cascades[i].texelSizeLs.x);
    auto rectOf = [&](std::int64_t x, std::int64_t y) {
      const glm::i64vec2 w = c.tiles.origin + glm::i64vec2(x, y);
      return csm::TexelRect{w.x * tile, w.y * tile, (w.x + 1) * tile, (w.y + 1) * tile}.intersect(
          c.box);
    };
    auto inBox = [&](std::int64_t x, std::int64_t y) { return !rectOf(x, y).empty(); };
    auto heldBefore = [&](std::int64_t x, std::int64_t y) {
      const glm::i64vec2 w = c.tiles.origin + glm::i64vec2(x, y);
      return layer.tiles.testWorld(w.x, w.y);
    };
    for (std::int64_t y = 0; y < csm::kTileGridSide; ++y) {
      const auto whole = wholeRow(c.marked, heldBefore, inBox, y);
      for (std::int64_t x = 0; x < csm::kTileGridSide; ++x) {
        const glm::i64vec2 w = c.tiles.origin + glm::i64vec2(x, y);
        const csm::TexelRect r = rectOf(x, y);
        if (r.empty()) continue;
        std::uint64_t stale = 0;
        for (std::int64_t ty = r.y0; ty < r.y1; ++ty) {
          for (std::int64_t tx = r.x0; tx < r.x1; ++tx) {
            const bool inOld = tx >= old.x0 && tx < old.x1 && ty >= old.y0 && ty < old.y1;
            const bool inInv = tx >= inv.x0 && tx < inv.x1 && ty >= inv.y0 && ty < inv.y1;
            stale += !inOld || inInv ? 1u : 0u;
          }
        }
        const bool wasHeld = layer.tiles.testWorld(w.x, w.y);
        const bool marked = c.marked.test(x, y);
        const bool drawnWhole = whole[std::size_t(x)];
        if (drawnWhole) {
          EXPECT_EQ(areaIn(c.stale, r), r.area()) << i << ": " << x << ", " << y;
        } else if (marked) {
          EXPECT_TRUE(wasHeld) << i << ": " << x << ", " << y;
          EXPECT_EQ(areaIn(c.stale, r), stale) << i << ": " << x << ", " << y;
        } else {
          EXPECT_EQ(areaIn(c.stale, r), 0u) << i << ": " << x << ", " << y;
        }
        EXPECT_EQ(c.tiles.test(x, y), drawnWhole || marked || (wasHeld && stale == 0))
            << i << ": " << x << ", " << y;
        lost += !drawnWhole && !marked && wasHeld && stale != 0 ? 1u : 0u;
        kept += wasHeld && !marked && c.tiles.test(x, y) ? 1u : 0u;
      }
    }
  }
  EXPECT_GT(kept, 0u) << "held tiles no longer marked stay held while nothing in them is stale";
  EXPECT_GT(lost, 0u) << "the changed box lies in held tiles no receiver marks now";
  csm::markCacheRecorded(p, state);

  // Tiles off, the same view: every cascade is whole again and draws exactly the tiles (within
  // its box) its layer did not hold.
  f = frameOf(s, v);
  const csm::CacheState partial = state;
  p = csm::planCacheFrame(f, state, s.resolution, 0, 1, nullptr);
  std::uint32_t completed = 0;
  for (std::uint32_t i = 0; i < last; ++i) {
    const csm::CacheCascadePlan& c = p.cascades[i];
    EXPECT_FALSE(c.partial);
    const csm::CacheLayerState& layer = partial.layers[i];
    if (!layer.partial || c.newWindow) continue;
    ++completed;
    std::uint64_t notHeld = 0;
    for (std::int64_t y = 0; y < csm::kTileGridSide; ++y) {
      for (std::int64_t x = 0; x < csm::kTileGridSide; ++x) {
        const glm::i64vec2 w = layer.tiles.origin + glm::i64vec2(x, y);
        const csm::TexelRect r =
            csm::TexelRect{w.x * tile, w.y * tile, (w.x + 1) * tile, (w.y + 1) * tile}.intersect(
                c.box);
        if (!layer.tiles.test(x, y)) notHeld += r.area();
      }
    }
    EXPECT_GT(notHeld, 0u) << i;
    EXPECT_EQ(c.staleTexels, notHeld) << i;
  }
  EXPECT_GT(completed, 0u);
  csm::markCacheRecorded(p, state);
  for (std::uint32_t i = 0; i < f.cascadeCount; ++i) EXPECT_FALSE(state.layers[i].partial);
}

TEST(CacheTiles, ATileBudgetSpreadsTheMarkedTilesOverFramesFromTheCameraOut) {
  // The frame after a cut takes the cut's marks: every partial cascade needs its marked tiles
  // whole. With a budget of ten tiles' texels that spreads over frames: each frame draws at most
  // the budget (and, while tiles wait, more than the budget less a tile), cascade 0 first and
  // each from the camera out in square rings (no tile drawn lies in a ring farther out than
  // one left waiting; once a cascade leaves tiles waiting, no later one draws); what was held stays
  // held; the deferred tiles are counted; in the end every marked tile is held, as one frame
  // without a budget holds them. 10^7 m from the origin too.
  const csm::ShadowSettings s = tileSettings();
  const std::int64_t res = s.resolution, tile = res / csm::kTilesPerSide;
  const std::uint64_t tileArea = std::uint64_t(tile * tile);
  const std::uint64_t budget = 10 * tileArea;
  for (const glm::dvec3& at : {glm::dvec3(0.0, 2.0, 0.0), glm::dvec3(1e7, 2.0, -1e7)}) {
    SCOPED_TRACE(at.x);
    const View v = viewAt(at);
    csm::CacheState state = stateBeforeCut(s);
    csm::CascadeFrame f = frameOf(s, v);
    csm::CacheTileInputs in = tileInputs(s, f, nullptr);
    in.budgetTexels = budget;
    csm::markCacheRecorded(csm::planCacheFrame(f, state, s.resolution, 0, 1, &in), state);
    const csm::ReceiverTileMarks marks = marksOf(s, f, v, groundReceivers(v, 300.0, 1.0));
    const std::uint32_t last = f.cascadeCount - 1;
    // The same frame without a budget: what it would draw at once.
    csm::CacheState unbudgeted = state;
    f = frameOf(s, v);
    in = tileInputs(s, f, &marks);
    const csm::CachePlan all = csm::planCacheFrame(f, unbudgeted, s.resolution, 0, 1, &in);
    std::uint64_t allTexels = 0;
    for (std::uint32_t i = 0; i < last; ++i) {
      if (all.cascades[i].partial) allTexels += all.cascades[i].staleTexels;
      EXPECT_EQ(all.cascades[i].tilesDeferred, 0u) << i;
    }
    ASSERT_GT(allTexels, 4 * budget) << "the frame must need several budgets";
    int frames = 0;
    bool done = false;
    for (; frames < 200 && !done; ++frames) {
      f = frameOf(s, v);
      in = tileInputs(s, f, &marks);
      in.budgetTexels = budget;
      const csm::CacheState before = state;
      const csm::CachePlan p = csm::planCacheFrame(f, state, s.resolution, 0, 1, &in);
      EXPECT_EQ(p.tileBudgetTexels, budget);
      const glm::dmat3 basisT = glm::transpose(f.lightBasisWs);
      const glm::dvec3 cameraLs = basisT * v.camera.positionWs;
      std::uint64_t drawn = 0;
      std::uint32_t deferred = 0;
      bool waiting = false;
      for (std::uint32_t i = 0; i < last; ++i) {
        const csm::CacheCascadePlan& c = p.cascades[i];
        if (!c.partial) continue;
        drawn += c.staleTexels;
        deferred += c.tilesDeferred;
        if (waiting) {
          EXPECT_EQ(c.staleTexels, 0u) << i << ": a cascade before this one left tiles waiting";
        }
        const double texel = f.cascades[i].texelSizeLs.x;
        auto rectOf = [&](std::int64_t x, std::int64_t y) {
          const glm::i64vec2 w = c.tiles.origin + glm::i64vec2(x, y);
          return csm::TexelRect{w.x * tile, w.y * tile, (w.x + 1) * tile, (w.y + 1) * tile}
              .intersect(c.box);
        };
        // The square ring (in tiles) of a tile about the camera.
        auto ring = [&](std::int64_t x, std::int64_t y) {
          const glm::i64vec2 w = c.tiles.origin + glm::i64vec2(x, y);
          const double cx = (double(w.x) + 0.5) * double(tile) * texel - cameraLs.x;
          const double cy = (double(w.y) + 0.5) * double(tile) * texel - cameraLs.y;
          return std::max(std::abs(cx), std::abs(cy)) / (double(tile) * texel);
        };
        double nearestWaiting = INFINITY, farthestNewlyHeld = -1.0;
        std::uint32_t waitingTiles = 0, newlyHeld = 0;
        for (std::int64_t y = 0; y < csm::kTileGridSide; ++y) {
          for (std::int64_t x = 0; x < csm::kTileGridSide; ++x) {
            if (rectOf(x, y).empty()) continue;
            const glm::i64vec2 w = c.tiles.origin + glm::i64vec2(x, y);
            const bool wasHeld =
                before.layers[i].partial && before.layers[i].tiles.testWorld(w.x, w.y);
            if (wasHeld) {
              EXPECT_TRUE(c.tiles.test(x, y)) << i << ": " << x << ", " << y << " was held";
            }
            if (!c.marked.test(x, y) || wasHeld) continue;
            const double d = ring(x, y);
            if (c.tiles.test(x, y)) {
              ++newlyHeld;
              farthestNewlyHeld = std::max(farthestNewlyHeld, d);
            } else {
              ++waitingTiles;
              nearestWaiting = std::min(nearestWaiting, d);
            }
          }
        }
        EXPECT_EQ(c.tilesDeferred, waitingTiles) << i;
        // From the camera out: no tile drawn lies in a ring farther out than a tile left
        // waiting (one ring may be split between them).
        if (newlyHeld > 0 && waitingTiles > 0) {
          EXPECT_LE(farthestNewlyHeld, nearestWaiting + 1e-6)
              << i << ": a tile " << farthestNewlyHeld << " tiles out is drawn while one "
              << nearestWaiting << " tiles out waits";
        }
        waiting = waiting || waitingTiles > 0;
      }
      EXPECT_LE(drawn, budget) << "frame " << frames;
      if (deferred > 0) {
        EXPECT_GT(drawn + tileArea, budget) << "frame " << frames << ": tiles wait, budget unused";
      }
      // The last cascade, the fallback, is not counted: it draws what the view samples.
      EXPECT_EQ(p.cascades[last].tilesDeferred, 0u);
      done = deferred == 0;
      csm::markCacheRecorded(p, state);
    }
    ASSERT_TRUE(done) << "the marked tiles were never all held";
    EXPECT_GT(frames, 4);
    EXPECT_LE(std::uint64_t(frames), 2 * (allTexels / (budget - tileArea) + 1));
    for (std::uint32_t i = 0; i < last; ++i) {
      const csm::CacheCascadePlan& c = all.cascades[i];
      if (!c.partial) continue;
      for (std::int64_t y = 0; y < csm::kTileGridSide; ++y) {
        for (std::int64_t x = 0; x < csm::kTileGridSide; ++x) {
          const glm::i64vec2 w = c.tiles.origin + glm::i64vec2(x, y);
          if (c.marked.test(x, y) && c.tiles.test(x, y)) {
            EXPECT_TRUE(state.layers[i].tiles.testWorld(w.x, w.y)) << i << ": " << x << ", " << y;
          }
        }
      }
    }
    // Then nothing more: the same view holds its tiles.
    f = frameOf(s, v);
    in = tileInputs(s, f, &marks);
    in.budgetTexels = budget;
    const csm::CachePlan settled = csm::planCacheFrame(f, state, s.resolution, 0, 1, &in);
    for (std::uint32_t i = 0; i < last; ++i) {
      EXPECT_EQ(settled.cascades[i].staleTexels, 0u) << i;
      EXPECT_EQ(settled.cascades[i].tilesDeferred, 0u) << i;
    }
  }
}

TEST(CacheTiles, ANarrowViewKeepsTheCascadesTheLastBoxDoesNotHoldWhole) {
  const csm::ShadowSettings s = tileSettings();
  const View v = viewAt(glm::dvec3(0.0, 25.0, 0.0), 8.0);
  csm::CacheState state = stateBeforeCut(s);
  csm::CascadeFrame f = frameOf(s, v);
  const csm::CacheTileInputs in = tileInputs(s, f, nullptr);
  const csm::CachePlan p = csm::planCacheFrame(f, state, s.resolution, 0, 1, &in);
  const std::uint32_t last = f.cascadeCount - 1;
  std::uint32_t whole = 0;
  for (std::uint32_t i = 0; i < last; ++i) {
    const double margin = (in.reachTexels[last] + 2.0) * f.cascades[last].texelSizeLs.x;
    const bool inside = csm::cacheBoxHoldsSphere(
        p.cascades[last].box, f.cascades[last].texelSizeLs.x, f.lightBasisWs,
        state.layers[last].zNear, state.layers[last].zFar, margin, f.cascades[i]);
    EXPECT_EQ(p.cascades[i].partial, inside) << i;
    whole += inside ? 0u : 1u;
    // A cascade drawn whole while its slice lies outside the last box.
    if (!inside) {
      EXPECT_TRUE(p.cascades[i].full) << i;
    }
  }
  EXPECT_GT(whole, 0u) << "at 8 degrees cascade 0 lies outside the last cascade's box";
}

TEST(CacheTiles, TheUniformBlockHoldsEachPartialCascadesTiles) {
  const csm::ShadowSettings s = tileSettings();
  const View v = viewAt(glm::dvec3(-1e7, 2.0, 1e7));
  csm::CacheState state = stateBeforeCut(s);
  csm::CascadeFrame f = frameOf(s, v);
  csm::CacheTileInputs in = tileInputs(s, f, nullptr);
  csm::CachePlan p = csm::planCacheFrame(f, state, s.resolution, 0, 1, &in);
  csm::markCacheRecorded(p, state);
  const csm::ReceiverTileMarks marks = marksOf(s, f, v, groundReceivers(v, 300.0, 2.0));
  f = frameOf(s, v);
  in = tileInputs(s, f, &marks);
  p = csm::planCacheFrame(f, state, s.resolution, 0, 1, &in);
  const csm::CsmUniforms u = csm::packCachedUniforms(f, s, {}, p);
  const std::int64_t tile = s.resolution / csm::kTilesPerSide;
  EXPECT_FLOAT_EQ(u.tileInvTexels, 1.0f / float(tile));
  std::uint32_t partial = 0;
  for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
    const csm::CacheCascadePlan& c = p.cascades[i];
    EXPECT_FLOAT_EQ(u.tileGrid[i].z, float(in.reachTexels[i])) << i;
    const bool last = i + 1 == f.cascadeCount;
    EXPECT_EQ((u.tilePartialMask >> i) & 1u, c.partial && !last ? 1u : 0u) << i;
    if (!c.partial || last) continue;
    ++partial;
    // The grid's first tile lies at most a tile before the box's first texel.
    EXPECT_EQ(double(u.tileGrid[i].x), double(c.box.x0 - c.tiles.origin.x * tile));
    EXPECT_GE(u.tileGrid[i].x, 0.0f);
    EXPECT_LT(u.tileGrid[i].x, float(tile));
    EXPECT_GE(u.tileGrid[i].y, 0.0f);
    EXPECT_LT(u.tileGrid[i].y, float(tile));
    for (std::uint32_t w = 0; w < csm::kTileWords; ++w) {
      EXPECT_EQ(u.tileBits[i * 3 + w / 4][int(w % 4)], c.tiles.bits[w]) << i << " word " << w;
    }
  }
  EXPECT_GT(partial, 0u);
}

}  // namespace
