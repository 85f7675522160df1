// The cache's per-frame decisions (csm/cache_plan.hpp): when a cascade keeps its window, which
// cascades a texel budget refreshes, and the whole frame's plan (planCacheFrame): windows, stale
// texels, boxes and wrap offsets, deferral, invalidation between planning and recording.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include <csm/cache_plan.hpp>
#include <csm/core.hpp>
#include <csm/gpu_layout.hpp>

namespace {

const glm::dvec3 kSun{0.3, -0.9, 0.1};

TEST(CachePlan, BoxStartIsTheRoundedCentreLessHalfTheLayer) {
  EXPECT_EQ(csm::cacheBoxStart(10.0, 0.5, 2048), 20 - 1024);
  EXPECT_EQ(csm::cacheBoxStart(-10.26, 0.5, 2048), -21 - 1024);
  // 10^7 m from the origin at 2 cm texels: exact in integers.
  EXPECT_EQ(csm::cacheBoxStart(1.0e7 + 0.011, 0.02, 4096), 500000001 - 2048);
}

TEST(CachePlan, AWindowStaysWhileItHoldsTheNeededDepthsAndOpensAnewOtherwise) {
  csm::CacheWindowPlacement w;
  // The first frame opens one: anchored at the box, depths rounded out to quarters of the
  // needed range (10 m: 2.5 m steps) plus a quarter each side.
  EXPECT_TRUE(csm::placeCacheWindow(w, 0.5, kSun, -1000, 37, 101.0, 111.0));
  EXPECT_TRUE(w.valid);
  EXPECT_EQ(w.anchorX, -1000);
  EXPECT_EQ(w.anchorY, 37);
  EXPECT_DOUBLE_EQ(w.zNear, 100.0 - 2.5);
  EXPECT_DOUBLE_EQ(w.zFar, 112.5 + 2.5);
  const csm::CacheWindowPlacement first = w;
  // Needed depths inside it, but 6 m of 17.5: more than 2.5 times the range, a new window.
  csm::CacheWindowPlacement tighter = w;
  EXPECT_TRUE(csm::placeCacheWindow(tighter, 0.5, kSun, -1000, 37, 104.0, 110.0));
  EXPECT_DOUBLE_EQ(tighter.zNear, 103.5 - 1.5);
  EXPECT_DOUBLE_EQ(tighter.zFar, 111.0 + 1.5);
  // The box moves (the anchor stays: the layer is toroidal) and its depths drift within the
  // window: kept, unchanged.
  EXPECT_FALSE(csm::placeCacheWindow(w, 0.5, kSun, -990, 40, 98.0, 108.0));
  EXPECT_EQ(w.anchorX, first.anchorX);
  EXPECT_DOUBLE_EQ(w.zNear, first.zNear);
  EXPECT_DOUBLE_EQ(w.zFar, first.zFar);
  // Depths past the window's end, a new texel size, a new light: a new window each time.
  EXPECT_TRUE(csm::placeCacheWindow(w, 0.5, kSun, -990, 40, 106.0, 116.0));
  EXPECT_EQ(w.anchorX, -990);
  EXPECT_TRUE(csm::placeCacheWindow(w, 1.0, kSun, -990, 40, 106.0, 116.0));
  EXPECT_TRUE(
      csm::placeCacheWindow(w, 1.0, kSun + glm::dvec3(0.0, 0.0, 1e-9), -990, 40, 106.0, 116.0));
  // A needed range that shrank to under 1/2.5 of the window: a new, tighter window.
  EXPECT_FALSE(csm::placeCacheWindow(w, 1.0, kSun + glm::dvec3(0.0, 0.0, 1e-9), -990, 40, 105.0,
                                     113.0));  // 17.5 m of window for 8 m: kept
  EXPECT_TRUE(
      csm::placeCacheWindow(w, 1.0, kSun + glm::dvec3(0.0, 0.0, 1e-9), -990, 40, 107.0, 109.0));
  EXPECT_LE(w.zFar - w.zNear, 2.5 * 2.0 + 1e-9);
  EXPECT_LE(w.zNear, 107.0);
  EXPECT_GE(w.zFar, 109.0);
}

TEST(CachePlan, WithoutABudgetEveryActiveCascadeIsRefreshed) {
  std::vector<csm::CacheRefreshCandidate> c(4, {true, true, 3, false, 1u << 20});
  c[2].active = false;
  EXPECT_EQ(csm::scheduleCacheRefresh(c, 0, 1), 0b1011u);
}

TEST(CachePlan, TheBudgetRefreshesTheExactAndNeverShownThenTheMostStaleThatFit) {
  // Cascade 0 exact (over budget on its own), 1 never shown, 2 and 3 shown.
  std::vector<csm::CacheRefreshCandidate> c{{true, true, 0, true, 5000},
                                            {true, false, 0, true, 5000},
                                            {true, true, 1, true, 100},
                                            {true, true, 4, true, 100}};
  EXPECT_EQ(csm::scheduleCacheRefresh(c, 100, 1), 0b1011u);  // 3 lags longer than 2
  EXPECT_EQ(csm::scheduleCacheRefresh(c, 200, 1), 0b1111u);
  // A cascade whose view is no longer covered gains a frame of lag, and wins a tie.
  c[3].lagFrames = 1;
  c[2].covered = false;
  EXPECT_EQ(csm::scheduleCacheRefresh(c, 100, 1), 0b0111u);
  c[2].lagFrames = 0;  // staleness 1 each: the uncovered one first, the farther one too
  EXPECT_EQ(csm::scheduleCacheRefresh(c, 100, 1), 0b0111u);
  c[2].covered = true;
  c[2].lagFrames = 1;
  c[3].covered = false;
  c[3].lagFrames = 0;
  EXPECT_EQ(csm::scheduleCacheRefresh(c, 100, 1), 0b1011u);
  c[3].covered = true;
  c[2].lagFrames = 0;  // a tie of equals: the nearer
  EXPECT_EQ(csm::scheduleCacheRefresh(c, 100, 1), 0b0111u);
  // A stale cascade that does not fit is passed over for a cheaper one that does.
  c[2] = {true, true, 9, true, 150};
  c[3] = {true, true, 0, true, 80};
  EXPECT_EQ(csm::scheduleCacheRefresh(c, 100, 1), 0b1011u);
  // Every cascade exact: all, whatever the budget.
  EXPECT_EQ(csm::scheduleCacheRefresh(c, 1, 4), 0b1111u);
  // Inactive cascades are never refreshed.
  c[1].active = false;
  EXPECT_EQ(csm::scheduleCacheRefresh(c, 1, 4), 0b1101u);
}

// ---------------------------------------------------------------------------------------------
// The frame's plan

constexpr std::uint32_t kRes = 512;

csm::ShadowSettings planSettings() {
  csm::ShadowSettings s;
  s.resolution = kRes;
  s.cascadeCount = 4;
  s.shadowDistanceM = 200.0;
  return s;
}

csm::CascadeFrame frameAt(const glm::dvec3& positionWs, const glm::dvec3& sun = kSun) {
  csm::Camera camera;
  camera.positionWs = positionWs;
  camera.farM = 1000.0;
  auto frame = csm::computeCascades(planSettings(), camera, csm::DirectionalLight{sun});
  EXPECT_TRUE(frame.ok());
  return frame.value();
}

// The first texel of cascade i's box on its world grid, as the plan must place it.
std::int64_t boxStartX(const csm::CascadeFrame& f, std::uint32_t i) {
  const glm::dvec3 ls = glm::transpose(f.lightBasisWs) * f.cascades[i].boxCenterWs;
  return csm::cacheBoxStart(ls.x, f.cascades[i].texelSizeLs.x, kRes);
}
std::int64_t boxStartY(const csm::CascadeFrame& f, std::uint32_t i) {
  const glm::dvec3 ls = glm::transpose(f.lightBasisWs) * f.cascades[i].boxCenterWs;
  return csm::cacheBoxStart(ls.y, f.cascades[i].texelSizeLs.y, kRes);
}

TEST(CachePlan, TheFirstFrameOpensAWindowPerCascadeAndRendersItWhole) {
  csm::CacheState state;
  csm::CascadeFrame frame = frameAt({10.0, 2.0, -3.0});
  const csm::CascadeFrame computed = frame;
  const csm::CachePlan plan = csm::planCacheFrame(frame, state, kRes, 0, 1);
  ASSERT_EQ(plan.cascadeCount, 4u);
  EXPECT_EQ(plan.refreshedMask, 0b1111u);
  const glm::dmat3 basisT = glm::transpose(frame.lightBasisWs);
  for (std::uint32_t i = 0; i < 4; ++i) {
    const csm::CacheCascadePlan& p = plan.cascades[i];
    SCOPED_TRACE(i);
    EXPECT_TRUE(p.active && p.refreshed && p.newWindow && p.full);
    EXPECT_EQ(p.staleTexels, std::uint64_t(kRes) * kRes);
    ASSERT_EQ(p.stale.size(), 1u);
    EXPECT_EQ(p.stale[0], p.box);
    EXPECT_EQ(p.box.x0, boxStartX(computed, i));
    EXPECT_EQ(p.box.y0, boxStartY(computed, i));
    EXPECT_EQ(p.box.x1 - p.box.x0, std::int64_t(kRes));
    EXPECT_EQ(p.wrapX, 0);  // the window is anchored at the box
    EXPECT_EQ(p.wrapY, 0);
    EXPECT_EQ(p.basis, frame.lightBasisWs);
    // The frame's depth range is the window's, which holds the computed one.
    const csm::CacheLayerState& w = state.layers[i];
    const double z = (basisT * frame.cascades[i].boxCenterWs).z;
    EXPECT_DOUBLE_EQ(frame.cascades[i].depthNearLs, w.zNear - z);
    EXPECT_DOUBLE_EQ(frame.cascades[i].depthFarLs, w.zFar - z);
    EXPECT_LE(frame.cascades[i].depthNearLs, computed.cascades[i].depthNearLs);
    EXPECT_GE(frame.cascades[i].depthFarLs, computed.cascades[i].depthFarLs);
    EXPECT_TRUE(state.shown[i].valid);
  }
  // Nothing is held until the plan is recorded.
  EXPECT_FALSE(state.layers[0].staticValid);
  csm::markCacheRecorded(plan, state);
  EXPECT_TRUE(state.layers[0].staticValid);
  EXPECT_EQ(state.layers[0].boxX, plan.cascades[0].box.x0);
}

TEST(CachePlan, AMovedCameraRendersOnlyTheExposedRowsAndColumnsAtTheirWrapOffset) {
  csm::CacheState state;
  csm::CascadeFrame first = frameAt({10.0, 2.0, -3.0});
  const csm::CachePlan p0 = csm::planCacheFrame(first, state, kRes, 0, 1);
  csm::markCacheRecorded(p0, state);
  csm::CascadeFrame moved = frameAt({13.7, 2.0, -1.2});
  const csm::CascadeFrame computed = moved;
  const csm::CachePlan p1 = csm::planCacheFrame(moved, state, kRes, 0, 1);
  bool anyMoved = false;
  for (std::uint32_t i = 0; i < 4; ++i) {
    SCOPED_TRACE(i);
    const csm::CacheCascadePlan& p = p1.cascades[i];
    const std::int64_t dx = boxStartX(computed, i) - p0.cascades[i].box.x0;
    const std::int64_t dy = boxStartY(computed, i) - p0.cascades[i].box.y0;
    anyMoved = anyMoved || dx != 0 || dy != 0;
    EXPECT_TRUE(p.refreshed);
    EXPECT_FALSE(p.newWindow);
    EXPECT_FALSE(p.full);
    EXPECT_EQ(p.box.x0, p0.cascades[i].box.x0 + dx);
    EXPECT_EQ(p.wrapX, csm::floorMod(dx, kRes));
    EXPECT_EQ(p.wrapY, csm::floorMod(dy, kRes));
    // The newly exposed columns and rows: |dx| R + |dy| R - |dx dy|.
    const std::uint64_t ax = std::uint64_t(std::llabs(dx)), ay = std::uint64_t(std::llabs(dy));
    EXPECT_EQ(p.staleTexels, ax * kRes + ay * kRes - ax * ay);
  }
  EXPECT_TRUE(anyMoved);  // the move crosses texels in cascade 0 at least
}

TEST(CachePlan, ABoxInvalidatedAfterPlanningIsDrawnThatFrameAndNeverLost) {
  csm::CacheState state;
  csm::CascadeFrame f0 = frameAt({0.0, 2.0, 0.0});
  csm::markCacheRecorded(csm::planCacheFrame(f0, state, kRes, 0, 1), state);
  const csm::AabbWs box{{4.0, 0.0, -6.0}, {6.0, 3.0, -4.0}};

  // Invalidated between planning and recording: updateCacheStale adds it to this frame.
  csm::CascadeFrame f1 = frameAt({0.0, 2.0, 0.0});
  csm::CachePlan plan = csm::planCacheFrame(f1, state, kRes, 0, 1);
  EXPECT_EQ(plan.cascades[0].staleTexels, 0u);  // the camera held still
  csm::invalidateCache(state, box);
  csm::updateCacheStale(plan, state);
  EXPECT_GT(plan.cascades[0].staleTexels, 0u);
  EXPECT_LT(plan.cascades[0].staleTexels, std::uint64_t(kRes) * kRes / 16);
  csm::markCacheRecorded(plan, state);
  EXPECT_TRUE(state.layers[0].pending.empty());

  // Invalidated after planning but recorded without updating: the box stays pending for the
  // next frame rather than being dropped.
  csm::CascadeFrame f2 = frameAt({0.0, 2.0, 0.0});
  plan = csm::planCacheFrame(f2, state, kRes, 0, 1);
  csm::invalidateCache(state, box);
  csm::markCacheRecorded(plan, state);
  ASSERT_EQ(state.layers[0].pending.size(), 1u);
  csm::CascadeFrame f3 = frameAt({0.0, 2.0, 0.0});
  plan = csm::planCacheFrame(f3, state, kRes, 0, 1);
  EXPECT_GT(plan.cascades[0].staleTexels, 0u);

  // Invalidated whole after planning: the layer stays invalid after recording.
  csm::invalidateCacheAll(state);
  csm::markCacheRecorded(plan, state);
  EXPECT_FALSE(state.layers[0].staticValid);
  csm::CascadeFrame f4 = frameAt({0.0, 2.0, 0.0});
  plan = csm::planCacheFrame(f4, state, kRes, 0, 1);
  EXPECT_TRUE(plan.cascades[0].full);
}

TEST(CachePlan, ADeferredCascadeShowsItsLastRefreshInItsOwnLightBasis) {
  csm::CacheState state;
  csm::CascadeFrame f0 = frameAt({0.0, 2.0, 0.0});
  const csm::CachePlan p0 = csm::planCacheFrame(f0, state, kRes, 1, 1);
  csm::markCacheRecorded(p0, state);
  // The light turns: every window opens anew; a budget of one texel refreshes only cascade 0
  // (exact), the others keep what they showed, drawn and addressed in the old basis.
  const glm::dvec3 sun2 = kSun + glm::dvec3(0.02, 0.0, 0.0);
  csm::CascadeFrame f1 = frameAt({1.0, 2.0, 0.5}, sun2);
  const csm::CachePlan p1 = csm::planCacheFrame(f1, state, kRes, 1, 1);
  EXPECT_EQ(p1.refreshedMask, 0b0001u);
  EXPECT_NE(f1.lightBasisWs, f0.lightBasisWs);
  EXPECT_EQ(p1.cascades[0].basis, f1.lightBasisWs);
  const csm::ShadowSettings s = planSettings();
  const csm::CsmUniforms u = csm::packCachedUniforms(f1, s, {}, p1);
  const csm::CsmUniforms u0 = csm::packCachedUniforms(f0, s, {}, p0);
  EXPECT_EQ(u.wrappedLayers, 1u);
  for (std::uint32_t i = 1; i < 4; ++i) {
    SCOPED_TRACE(i);
    const csm::CacheCascadePlan& p = p1.cascades[i];
    EXPECT_FALSE(p.refreshed);
    EXPECT_EQ(p.lagFrames, 1u);
    EXPECT_TRUE(p.stale.empty());
    EXPECT_EQ(p.basis, f0.lightBasisWs);
    EXPECT_EQ(p.box, p0.cascades[i].box);  // what it shows, where it was
    EXPECT_EQ(f1.cascades[i].boxCenterWs, f0.cascades[i].boxCenterWs);
    // Its matrix is formed for this frame's camera, in the old basis.
    EXPECT_EQ(f1.cascades[i].viewProjCr,
              csm::cameraRelativeViewProj(f0.lightBasisWs, f1.cameraPositionWs, f1.cascades[i]));
    // Addressed as it was drawn: the old grid origin, the old wrap.
    EXPECT_EQ(u.cascades[i].worldTexelOrigin, u0.cascades[i].worldTexelOrigin);
    EXPECT_EQ(u.cascades[i].wrapOffset, u0.cascades[i].wrapOffset);
  }
  // A frame of another resolution is left alone: an empty plan.
  csm::CascadeFrame other = f1;
  other.resolution = kRes * 2;
  const csm::CascadeFrame before = other;
  EXPECT_EQ(csm::planCacheFrame(other, state, kRes, 0, 1).cascadeCount, 0u);
  EXPECT_EQ(other.cascades[0].viewProjCr, before.cascades[0].viewProjCr);
}

}  // namespace
