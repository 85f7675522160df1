// The cache's per-frame decisions (csm/cache_plan.hpp): when a cascade keeps its window, and
// which cascades a texel budget refreshes.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include <csm/cache_plan.hpp>

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

}  // namespace
