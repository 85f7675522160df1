// The size ladder: under a zoom, an aspect change, a near-plane change, a lambda drag and a
// moving sun, every texel size changes only at counted rung events, never back and forth, and
// between events the texel grid stays fixed in the world; with the ladder off the same motions
// change the texel size on nearly every frame. Plus the tight box: containment and translation.
#include <gtest/gtest.h>

#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "test_util.hpp"

namespace csm {
namespace {

double fracDistance(double x) {
  return std::abs(x - std::round(x));
}

TEST(Ladder, RungsCoverExactlyAndAreDistinct) {
  for (double steps : {1.0, 4.0, 8.0, 16.0, 64.0}) {
    for (double x : {1e-3, 0.0173, 0.5, 1.0, 3.7, 255.0, 1e5, 1.23e7}) {
      const int k = ladderRungUp(x, steps);
      EXPECT_GE(ladderValue(k, steps), x) << steps << " " << x;
      EXPECT_LT(ladderValue(k - 1, steps), x) << steps << " " << x;
      EXPECT_LT(ladderValue(k - 1, steps), ladderValue(k, steps));
    }
  }
  // A rung's value is its own rung (no drift from exp2/log2 rounding).
  for (int k = -200; k <= 200; ++k) EXPECT_EQ(ladderRungUp(ladderValue(k, 8.0), 8.0), k);
  // 17 significant bits: a texel 2h/res of a power-of-two resolution is exact.
  const double h = ladderValue(37, 8.0);
  EXPECT_EQ(std::ldexp(std::ldexp(h, 1) / 2048.0 * 2048.0, -1), h);
}

TEST(Ladder, HysteresisHoldsARungAgainstOscillation) {
  const double steps = 8.0;
  const double base = ladderValue(40, steps);
  // Oscillating by +-3% (a third of a step) about a rung's value: one rung, no flip.
  int rungUp = kNoRung, rungNear = kNoRung, changesUp = 0, changesNear = 0;
  for (int f = 0; f < 500; ++f) {
    const double x = base * (1.0 + 0.03 * std::sin(0.37 * f));
    const int u = ladderRungUpHysteretic(x, steps, rungUp, 1.0);
    const int n = ladderRungNearestHysteretic(x, steps, rungNear, 1.0);
    ASSERT_GE(ladderValue(u, steps), x);  // always covers
    if (rungUp != kNoRung && u != rungUp) ++changesUp;
    if (rungNear != kNoRung && n != rungNear) ++changesNear;
    rungUp = u;
    rungNear = n;
  }
  EXPECT_LE(changesUp, 1);
  EXPECT_EQ(changesNear, 0);
  // Without hysteresis the same oscillation flips on many frames (the test can fail).
  int flips = 0, r = kNoRung;
  for (int f = 0; f < 500; ++f) {
    const int u = ladderRungUpHysteretic(base * (1.0 + 0.03 * std::sin(0.37 * f)), steps, r, 0.0);
    if (r != kNoRung && u != r) ++flips;
    r = u;
  }
  EXPECT_GT(flips, 50);
  // Growth is immediate; shrinking waits for more than 1 + h steps.
  EXPECT_EQ(ladderRungUpHysteretic(ladderValue(41, steps) * 0.999, steps, 40, 1.0), 41);
  EXPECT_EQ(ladderRungUpHysteretic(ladderValue(38, steps) * 1.001, steps, 40, 1.0), 40);
  EXPECT_EQ(ladderRungUpHysteretic(ladderValue(38, steps) * 0.999, steps, 40, 1.0), 38);
}

// A camera change over frames: the camera of frame f out of n (t = f / (n - 1)).
struct Motion {
  const char* name;
  int frames;
  std::function<void(Camera&, ShadowSettings&, DirectionalLight&, double t)> apply;
  /// Turns of direction of the driving quantity (0 for a monotonic change).
  int reversals;
  /// Most size rung events a cascade may see (octaves crossed x steps per octave + slack).
  std::uint32_t maxEventsPerCascade;
};

double lerp(double a, double b, double t) {
  return a + (b - a) * t;
}

std::vector<Motion> motions() {
  return {
      {"zoom 60->8 deg", 240,
       [](Camera& c, ShadowSettings&, DirectionalLight&, double t) {
         c.fovYRad = glm::radians(lerp(60.0, 8.0, t));
       },
       0, 24},
      {"aspect 16:9->4:3->21:9", 240,
       [](Camera& c, ShadowSettings&, DirectionalLight&, double t) {
         c.aspect = t < 0.5 ? lerp(16.0 / 9.0, 4.0 / 3.0, 2.0 * t)
                            : lerp(4.0 / 3.0, 21.0 / 9.0, 2.0 * t - 1.0);
       },
       1, 12},
      {"near 0.1->0.5 m", 120,
       [](Camera& c, ShadowSettings&, DirectionalLight&, double t) { c.nearM = lerp(0.1, 0.5, t); },
       0, 12},
      {"lambda 0.5->0.9", 120,
       [](Camera&, ShadowSettings& s, DirectionalLight&, double t) {
         s.splitLambda = lerp(0.5, 0.9, t);
       },
       0, 16},
  };
}

Camera baseCamera(const glm::dvec3& originWs) {
  Camera c;
  c.positionWs = originWs + glm::dvec3(0.0, 7.0, 28.0);
  c.orientationWs = test::lookAlong({0.0, -0.13, -1.0});
  c.fovYRad = glm::radians(60.0);
  c.aspect = 16.0 / 9.0;
  c.nearM = 0.1;
  c.farM = 1000.0;
  return c;
}

ShadowSettings baseSettings() {
  ShadowSettings s;
  s.cascadeCount = 4;
  s.resolution = 1024;
  s.shadowDistanceM = 120.0;
  s.splitLambda = 0.6;
  return s;
}

struct RunStats {
  std::array<std::uint32_t, kMaxCascades> texelChanges{};  // frames whose texel size changed
  std::array<std::uint32_t, kMaxCascades> reversals{};     // event direction turns
  std::array<std::uint32_t, kMaxCascades> quickReversals{};
  double worstGridFrac = 0.0;  // fractional texel motion of fixed points between events
};

// Runs a motion through one history and measures, per cascade, how often the texel size
// changes and how far fixed world points move on the texel grid on frames without an event.
RunStats runMotion(const Motion& m, const glm::dvec3& origin, bool ladderOn, bool boxFitTight,
                   CascadeHistory* historyOut = nullptr) {
  CascadeHistory history;
  RunStats st;
  CascadeFrame prev;
  std::array<int, kMaxCascades> lastDirection{};
  std::array<int, kMaxCascades> lastEventFrame{};
  lastEventFrame.fill(-1000);
  const DirectionalLight baseLight{{0.75, -0.6, 0.3}};
  // Fixed world points on the ground in front of the camera, 2 m .. 110 m away.
  std::vector<glm::dvec3> points;
  for (int k = 0; k < 48; ++k) {
    const double d = 2.0 * std::pow(55.0, k / 47.0);
    points.push_back(origin + glm::dvec3(0.37 * d * std::sin(1.7 * k), 0.0, 28.0 - d));
  }
  for (int f = 0; f < m.frames; ++f) {
    Camera cam = baseCamera(origin);
    ShadowSettings s = baseSettings();
    s.diagnostics.sizeLadder = ladderOn;
    if (boxFitTight) s.boxFit = BoxFit::kTight;
    DirectionalLight light = baseLight;
    m.apply(cam, s, light, double(f) / double(m.frames - 1));
    const CascadeFrame cur = test::computeOrDie(s, cam, light, nullptr, &history);
    if (f > 0) {
      for (std::uint32_t c = 0; c < cur.cascadeCount; ++c) {
        const double a = prev.cascades[c].texelSizeM(), b = cur.cascades[c].texelSizeM();
        if (a != b) {
          ++st.texelChanges[c];
          const int dir = b > a ? 1 : -1;
          if (lastDirection[c] != 0 && dir != lastDirection[c]) {
            ++st.reversals[c];
            if (f - lastEventFrame[c] <= 10) ++st.quickReversals[c];
          }
          lastDirection[c] = dir;
          lastEventFrame[c] = f;
          continue;
        }
        // No event: the grid must not have moved by a fraction of a texel.
        for (const glm::dvec3& p : points) {
          const glm::dvec3 ta = shadowTexelCoord(prev.cascades[c], prev, p);
          const glm::dvec3 tb = shadowTexelCoord(cur.cascades[c], cur, p);
          st.worstGridFrac =
              std::max({st.worstGridFrac, fracDistance(tb.x - ta.x), fracDistance(tb.y - ta.y)});
        }
      }
    }
    prev = cur;
  }
  if (historyOut != nullptr) *historyOut = history;
  return st;
}

class LadderMotionTest : public ::testing::TestWithParam<double> {};

TEST_P(LadderMotionTest, SizesChangeOnlyAtRareCountedRungEvents) {
  const glm::dvec3 origin = GetParam() * glm::dvec3(0.6, 0.0, -0.8);
  for (const Motion& m : motions()) {
    SCOPED_TRACE(m.name);
    CascadeHistory h;
    const RunStats on = runMotion(m, origin, true, false, &h);
    const RunStats off = runMotion(m, origin, false, false);
    std::uint32_t onTotal = 0, offTotal = 0;
    for (std::uint32_t c = 0; c < 4; ++c) {
      SCOPED_TRACE("cascade " + std::to_string(c));
      // Every texel-size change is a counted rung event, and there are few of them.
      EXPECT_EQ(on.texelChanges[c], h.sizeRungEvents[c]);
      EXPECT_LE(on.texelChanges[c], m.maxEventsPerCascade);
      // Never back and forth: direction turns only where the input turns, never within 10
      // frames of the previous event.
      EXPECT_LE(on.reversals[c], std::uint32_t(m.reversals));
      EXPECT_EQ(on.quickReversals[c], 0u);
      onTotal += on.texelChanges[c];
      offTotal += off.texelChanges[c];
    }
    // Between events the grid holds: fixed points move by whole texels only.
    EXPECT_LT(on.worstGridFrac, 1e-6);
    // Ladder off: the texel size crawls on nearly every frame (the count can see it).
    EXPECT_GT(offTotal, 4u * onTotal);
    EXPECT_GT(offTotal, std::uint32_t(m.frames));
    std::printf(
        "%-24s at %.0e m: size rung events per cascade %u %u %u %u (ladder off: texel "
        "changes %u %u %u %u over %d frames), split events %u %u %u\n",
        m.name, GetParam(), h.sizeRungEvents[0], h.sizeRungEvents[1], h.sizeRungEvents[2],
        h.sizeRungEvents[3], off.texelChanges[0], off.texelChanges[1], off.texelChanges[2],
        off.texelChanges[3], m.frames, h.splitRungEvents[0], h.splitRungEvents[1],
        h.splitRungEvents[2]);
  }
}

INSTANTIATE_TEST_SUITE_P(Origins, LadderMotionTest, ::testing::Values(0.0, 1e6, 1e7),
                         [](const auto& info) {
                           return info.index == 0 ? std::string("origin")
                                                  : "at1e" + std::to_string(info.index + 5);
                         });

// The depth window is world-anchored like the texel grid: under a zoom (the slice spheres'
// centres slide along the view axis every frame), between events of a cascade (size or depth
// rung, or its depth anchor moving because the sphere left the window) its depth origin,
// depthNearLs, depthFarLs and the depth row of viewProjCr are bit-identical, so no stored or
// receiver depth is re-rounded; the box's x, y hold as well while the sphere stays inside (the
// whole matrix is then bit-identical); and every slice corner stays inside the box.
TEST_P(LadderMotionTest, DepthWindowIsWorldAnchoredBetweenEvents) {
  const glm::dvec3 origin = GetParam() * glm::dvec3(0.6, 0.0, -0.8);
  const Motion zoom = motions()[0];
  // A scene (ground with casters up to 30 m), so the depth range extends toward the light.
  const AabbWs scene{origin + glm::dvec3(-100.0, -5.0, -100.0),
                     origin + glm::dvec3(100.0, 30.0, 100.0)};
  CascadeHistory h;
  CascadeFrame prev;
  std::uint32_t held = 0, anchorMoves = 0, otherEvents = 0, boxMoves = 0;
  for (int f = 0; f < zoom.frames; ++f) {
    Camera cam = baseCamera(origin);
    ShadowSettings s = baseSettings();
    DirectionalLight light{{0.75, -0.6, 0.3}};
    zoom.apply(cam, s, light, double(f) / double(zoom.frames - 1));
    const CascadeFrame cur = test::computeOrDie(s, cam, light, &scene, &h);
    for (std::uint32_t c = 0; c < cur.cascadeCount; ++c) {
      SCOPED_TRACE("frame " + std::to_string(f) + " cascade " + std::to_string(c));
      const Cascade& k = cur.cascades[c];
      // Every slice corner (and the sphere) lies inside the depth range.
      for (const glm::dvec3& pCr : sliceCornersCr(cam, k.splitNearM, k.splitFarM)) {
        const glm::dvec3 t = shadowTexelCoord(k, cur, cam.positionWs + pCr);
        ASSERT_GE(t.z, 0.0);
        ASSERT_LE(t.z, 1.0);
        // (and inside the box, which may hold its grid point while the sphere stays inside)
        ASSERT_GE(t.x, -1e-6);
        ASSERT_LE(t.x, s.resolution + 1e-6);
        ASSERT_GE(t.y, -1e-6);
        ASSERT_LE(t.y, s.resolution + 1e-6);
      }
      const double sphereZ = glm::dot(cur.lightBasisWs[2], k.sphereCenterWs) - k.depthOriginLs;
      ASSERT_GE(sphereZ - k.sphereRadiusM, k.depthNearLs);
      ASSERT_LE(sphereZ + k.sphereRadiusM, k.depthFarLs);
      // The camera holds its position: the window is anchored from the first frame on.
      ASSERT_TRUE(k.depthAnchored);
      if (f == 0) continue;
      const Cascade& p = prev.cascades[c];
      if (k.sizeRung != p.sizeRung || k.depthRung != p.depthRung || cur.lightStepped) {
        ++otherEvents;
        continue;
      }
      if (k.depthAnchorMoved) {
        ++anchorMoves;
        continue;
      }
      ++held;
      ASSERT_EQ(k.depthOriginLs, p.depthOriginLs);
      ASSERT_EQ(k.depthNearLs, p.depthNearLs);
      ASSERT_EQ(k.depthFarLs, p.depthFarLs);
      for (int col = 0; col < 4; ++col) ASSERT_EQ(k.viewProjCr[col][2], p.viewProjCr[col][2]);
      // The box holds its x, y too while the sphere stays inside: then the whole map is
      // rendered with a bit-identical matrix (the camera holds its position in a zoom).
      if (k.boxCenterWs != p.boxCenterWs) {
        ++boxMoves;
      } else {
        ASSERT_EQ(k.viewProjCr, p.viewProjCr);
      }
    }
    prev = cur;
  }
  // Most cascade-frames hold their depth window; the anchor moves rarely on its own (the sphere
  // left the window between rung events).
  EXPECT_GT(held, 4u * 170u);
  EXPECT_LE(anchorMoves, 4u);
  EXPECT_LE(boxMoves, 8u);
  std::printf(
      "zoom at %.0e m: depth window held on %u cascade-frames (box x, y moved on %u of them), "
      "anchor moves between rung events %u, cascade-frames with a rung event %u\n",
      GetParam(), held, boxMoves, anchorMoves, otherEvents);
}

TEST(Ladder, SunMovingTenDegreesStepsTheLightDirection) {
  // A sun moving 10 degrees over 600 frames with 0.5 degree steps: the direction used changes
  // on about 20 frames, never lags the real one by more than the step, and between steps the
  // cascades are bit-identical (the maps would not change at all).
  ShadowSettings s = baseSettings();
  s.lightStepDeg = 0.5;
  const Camera cam = baseCamera(glm::dvec3(1e6, 0.0, -2e6));
  CascadeHistory h;
  CascadeFrame prev;
  int changed = 0;
  for (int f = 0; f < 600; ++f) {
    const double a = glm::radians(35.0 + 10.0 * f / 599.0);
    const DirectionalLight light{{std::cos(a) * 0.8, -std::sin(a), std::cos(a) * 0.6}};
    const CascadeFrame cur = test::computeOrDie(s, cam, light, nullptr, &h);
    const double lagDeg = glm::degrees(std::acos(
        std::min(1.0, glm::dot(cur.lightDirectionWs, glm::normalize(light.directionWs)))));
    ASSERT_LE(lagDeg, 0.5 + 1e-9);
    if (f > 0) {
      const bool same = cur.lightDirectionWs == prev.lightDirectionWs;
      EXPECT_EQ(!same, cur.lightStepped);
      if (!same) ++changed;
      if (same) {
        for (std::uint32_t c = 0; c < 4; ++c) {
          ASSERT_EQ(cur.cascades[c].viewProjCr, prev.cascades[c].viewProjCr) << f;
        }
      }
    }
    prev = cur;
  }
  EXPECT_EQ(std::uint32_t(changed), h.lightStepEvents);
  EXPECT_GE(changed, 18);
  EXPECT_LE(changed, 21);
  // Without stepping every frame's light differs.
  s.lightStepDeg = 0.0;
  CascadeHistory h0;
  EXPECT_FALSE(
      test::computeOrDie(s, cam, DirectionalLight{{0.6, -0.7, 0.3}}, nullptr, &h0).lightStepped);
  EXPECT_EQ(h0.lightStepEvents, 0u);
}

TEST(Ladder, WastedResolutionIsBoundedByTheStepAndHysteresis) {
  // Over a zoom the ladder's box is never smaller than needed and never more than
  // 2^((1 + h) / steps) larger in length.
  ShadowSettings s = baseSettings();
  CascadeHistory h;
  double worst = 1.0;
  for (int f = 0; f < 240; ++f) {
    Camera cam = baseCamera(glm::dvec3(0.0));
    cam.fovYRad = glm::radians(lerp(60.0, 8.0, f / 239.0));
    const CascadeFrame cur =
        test::computeOrDie(s, cam, DirectionalLight{{0.75, -0.6, 0.3}}, nullptr, &h);
    for (std::uint32_t c = 0; c < 4; ++c) {
      const double ratio = cur.cascades[c].halfExtentLs.x / cur.cascades[c].neededHalfExtentM;
      ASSERT_GE(ratio, 1.0);
      worst = std::max(worst, ratio);
    }
  }
  EXPECT_LE(worst, std::exp2(2.0 / 8.0) * (1.0 + 1e-4));
}

TEST(TightBox, ContainsEverySliceCornerAndIgnoresTranslation) {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  int tightWins = 0;
  for (int i = 0; i < 4000; ++i) {
    ShadowSettings s;
    s.cascadeCount = 1 + std::uint32_t(u01(rng) * 7.99);
    s.resolution = 1024u << std::uint32_t(u01(rng) * 2.99);
    s.boxFit = BoxFit::kTight;
    s.shadowDistanceM = 20.0 + 2000.0 * u01(rng);
    Camera cam;
    cam.fovYRad = glm::radians(1.0 + 178.0 * u01(rng));
    cam.aspect = 0.3 + 3.0 * u01(rng);
    cam.nearM = 0.05 + 2.0 * u01(rng);
    cam.farM = 5000.0;
    cam.orientationWs = test::randomOrientation(rng);
    const double far = i % 3 == 0 ? 1e7 : (i % 3 == 1 ? 1e6 : 0.0);
    cam.positionWs = glm::dvec3(far * (u01(rng) - 0.3), 100.0 * u01(rng), far * (u01(rng) - 0.6));
    DirectionalLight light;
    // Half of the lights near the view direction, where the tight box wins.
    light.directionWs = i % 2 == 0 ? cam.forwardWs() + 0.2 * glm::dvec3(u01(rng), u01(rng), 0.0)
                                   : glm::dvec3(u01(rng) - 0.5, -u01(rng) - 0.05, u01(rng) - 0.5);
    const CascadeFrame f = test::computeOrDie(s, cam, light);
    for (std::uint32_t c = 0; c < f.cascadeCount; ++c) {
      const Cascade& k = f.cascades[c];
      if (k.tightFit) ++tightWins;
      for (const glm::dvec3& pCr : sliceCornersCr(cam, k.splitNearM, k.splitFarM)) {
        const glm::dvec3 t = shadowTexelCoord(k, f, cam.positionWs + pCr);
        const double res = f.resolution;
        ASSERT_GE(t.x, -1e-6 * res) << i << " " << c;
        ASSERT_LE(t.x, res * (1.0 + 1e-6)) << i << " " << c;
        ASSERT_GE(t.y, -1e-6 * res) << i << " " << c;
        ASSERT_LE(t.y, res * (1.0 + 1e-6)) << i << " " << c;
        ASSERT_GE(t.z, -1e-6) << i << " " << c;
        ASSERT_LE(t.z, 1.0 + 1e-6) << i << " " << c;
      }
    }
    // Translation never changes a size, bit for bit.
    Camera moved = cam;
    moved.positionWs += glm::dvec3(123.456 * (u01(rng) - 0.5), 7.89 * u01(rng), -31.4 * u01(rng));
    const CascadeFrame g = test::computeOrDie(s, moved, light);
    for (std::uint32_t c = 0; c < f.cascadeCount; ++c) {
      ASSERT_EQ(g.cascades[c].halfExtentLs, f.cascades[c].halfExtentLs) << i << " " << c;
      ASSERT_EQ(g.cascades[c].texelSizeLs, f.cascades[c].texelSizeLs) << i << " " << c;
      ASSERT_EQ(g.cascades[c].depthFarLs, f.cascades[c].depthFarLs) << i << " " << c;
    }
  }
  // The tight fit does win often enough to be tested.
  EXPECT_GT(tightWins, 2000);
}

TEST(TightBox, SmallerThanTheSphereWhenTheLightIsAlongTheViewAtNarrowFov) {
  ShadowSettings s = baseSettings();
  s.shadowDistanceM = 1500.0;
  Camera cam = baseCamera(glm::dvec3(0.0));
  cam.fovYRad = glm::radians(8.0);
  cam.farM = 5000.0;
  const DirectionalLight light{cam.forwardWs() + glm::dvec3(0.0, -0.3, 0.0)};
  const CascadeFrame sphere = test::computeOrDie(s, cam, light);
  s.boxFit = BoxFit::kTight;
  const CascadeFrame tight = test::computeOrDie(s, cam, light);
  for (std::uint32_t c = 0; c < 4; ++c) {
    EXPECT_TRUE(tight.cascades[c].tightFit) << c;
    EXPECT_LE(tight.cascades[c].texelSizeM(), 0.5 * sphere.cascades[c].texelSizeM()) << c;
  }
}

TEST(TightBox, RotationChangesTheSizeOnlyAtRungEvents) {
  ShadowSettings s = baseSettings();
  s.boxFit = BoxFit::kTight;
  CascadeHistory h;
  CascadeFrame prev;
  std::uint32_t changes = 0;
  for (int f = 0; f < 720; ++f) {
    Camera cam = baseCamera(glm::dvec3(1e7, 0.0, 0.0));
    cam.fovYRad = glm::radians(20.0);
    cam.orientationWs = glm::angleAxis(glm::radians(0.5 * f), glm::dvec3(0, 1, 0)) *
                        test::lookAlong({0.0, -0.2, -1.0});
    const CascadeFrame cur =
        test::computeOrDie(s, cam, DirectionalLight{{0.7, -0.5, 0.1}}, nullptr, &h);
    if (f > 0) {
      for (std::uint32_t c = 0; c < 4; ++c) {
        const bool changed = cur.cascades[c].texelSizeLs != prev.cascades[c].texelSizeLs;
        EXPECT_EQ(changed, cur.cascades[c].sizeRungChanged) << f << " " << c;
        changes += changed ? 1u : 0u;
      }
    }
    prev = cur;
  }
  std::uint32_t events = 0;
  for (std::uint32_t c = 0; c < 4; ++c) events += h.sizeRungEvents[c];
  EXPECT_EQ(changes, events);
  // A full turn: each cascade's extent rises and falls twice, a few rungs each way.
  EXPECT_GT(events, 0u);
  EXPECT_LT(events, 4u * 40u);
}

}  // namespace
}  // namespace csm

namespace csm {
namespace {

TEST(ReceiverSplits, SplitsSpanTheVisibleRangeOnTheLadder) {
  ShadowSettings s = baseSettings();
  s.shadowDistanceM = 1500.0;
  Camera cam = baseCamera(glm::dvec3(1e7, 0.0, 0.0));
  cam.fovYRad = glm::radians(8.0);
  cam.farM = 5000.0;
  const DirectionalLight light{{0.75, -0.6, 0.3}};
  const CascadeFrame full = test::computeOrDie(s, cam, light);
  EXPECT_FALSE(full.receiverDriven);
  EXPECT_EQ(full.splitsM[0], cam.nearM);
  // A town between 900 and 1100 m: the splits cover it (with the margin) and nothing nearer.
  const ReceiverDepthRange town{900.0, 1100.0};
  CascadeHistory h;
  const auto r = computeCascades(s, cam, light, nullptr, &h, &town);
  ASSERT_TRUE(r.ok());
  const CascadeFrame& f = r.value();
  EXPECT_TRUE(f.receiverDriven);
  EXPECT_LE(f.splitsM[0], 900.0 * (1.0 - s.receiverDepthMargin));
  EXPECT_GT(f.splitsM[0], 900.0 * (1.0 - s.receiverDepthMargin) * std::exp2(-1.0 / 8.0));
  EXPECT_EQ(ladderValue(ladderRungUp(f.splitsM[0], 8.0), 8.0), f.splitsM[0]);  // a rung
  EXPECT_GE(f.splitsM[4], 1100.0 * (1.0 + s.receiverDepthMargin));
  EXPECT_LE(f.splitsM[4], 1100.0 * (1.0 + s.receiverDepthMargin) * std::exp2(1.0 / 16.0) + 1e-9);
  // The cascade holding the town has far smaller texels than with the full range.
  auto holding = [](const CascadeFrame& fr, double d) {
    for (std::uint32_t c = 0; c < fr.cascadeCount; ++c)
      if (d >= fr.splitsM[c] && d < fr.splitsM[c + 1]) return fr.cascades[c].texelSizeM();
    return 0.0;
  };
  EXPECT_LT(holding(f, 1000.0), holding(full, 1000.0) / 3.0);
  // The range moving by a few percent moves nothing (ladder + hysteresis).
  for (int k = 0; k < 50; ++k) {
    const ReceiverDepthRange jitter{900.0 * (1.0 + 0.02 * std::sin(k)),
                                    1100.0 * (1.0 + 0.02 * std::cos(k))};
    const auto g = computeCascades(s, cam, light, nullptr, &h, &jitter);
    ASSERT_TRUE(g.ok());
    for (std::uint32_t c = 0; c < 4; ++c) {
      EXPECT_EQ(g.value().cascades[c].texelSizeLs, f.cascades[c].texelSizeLs) << k;
    }
    EXPECT_EQ(g.value().splitsM[0], f.splitsM[0]) << k;
  }
  // No range (a camera cut, or no result yet): the full range again.
  const CascadeFrame cut = test::computeOrDie(s, cam, light, nullptr, &h);
  EXPECT_EQ(cut.splitsM[0], cam.nearM);
  EXPECT_EQ(cut.shadowFarM, full.shadowFarM);
  // A range nearer than the camera's near plane, or too thin: splits start at the near plane.
  const ReceiverDepthRange close{0.0, 0.05};
  const auto n = computeCascades(s, cam, light, nullptr, nullptr, &close);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(n.value().splitsM[0], cam.nearM);
  EXPECT_GT(n.value().shadowFarM, cam.nearM);
}

TEST(ReceiverSplits, BadRangesAreRefusedByName) {
  const ShadowSettings s;
  const Camera cam;
  const DirectionalLight light;
  const ReceiverDepthRange bad[] = {{-1.0, 5.0},
                                    {10.0, 5.0},
                                    {std::nan(""), 5.0},
                                    {1.0, std::numeric_limits<double>::infinity()}};
  const char* field[] = {"receivers.minM", "receivers.maxM", "receivers.minM", "receivers.maxM"};
  for (int i = 0; i < 4; ++i) {
    const auto r = computeCascades(s, cam, light, nullptr, nullptr, &bad[i]);
    ASSERT_FALSE(r.ok()) << i;
    EXPECT_EQ(r.error().field, field[i]);
  }
  ShadowSettings m;
  m.receiverDepthMargin = 1.5;
  EXPECT_EQ(validate(m)->field, "settings.receiverDepthMargin");
  m = ShadowSettings{};
  m.ladderStepsPerOctave = 0.5;
  EXPECT_EQ(validate(m)->field, "settings.ladderStepsPerOctave");
  m = ShadowSettings{};
  m.ladderHysteresisSteps = -1.0;
  EXPECT_EQ(validate(m)->field, "settings.ladderHysteresisSteps");
  m = ShadowSettings{};
  m.lightStepDeg = std::nan("");
  EXPECT_EQ(validate(m)->field, "settings.lightStepDeg");
  m = ShadowSettings{};
  m.boxFit = static_cast<BoxFit>(7);
  EXPECT_EQ(validate(m)->field, "settings.boxFit");
}

}  // namespace
}  // namespace csm
