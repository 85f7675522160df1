// Histogram-driven (sample-distribution) split placement: analytic histograms give known splits,
// empty and degenerate histograms fall back to the range scheme, the splits sit on the ladder
// with hysteresis, and extremes (near 1e-3 m, far 1e5 m, 10^7 m from the origin) stay finite.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "test_util.hpp"

namespace csm {
namespace {

constexpr double kSteps = 8.0;

// A histogram over [nearM, farM) with `count` receivers at each of the given view depths.
ReceiverDepthHistogram clusters(double nearM, double farM, std::initializer_list<double> depthsM,
                                std::uint32_t count = 1000) {
  ReceiverDepthHistogram h;
  h.nearM = nearM;
  h.farM = farM;
  for (double d : depthsM)
    h.counts[depthHistogramBin(nearM, farM, kDepthHistogramBins, d)] += count;
  return h;
}

double binCentre(const ReceiverDepthHistogram& h, double depthM) {
  const std::uint32_t b = depthHistogramBin(h.nearM, h.farM, kDepthHistogramBins, depthM);
  return h.nearM * std::exp((b + 0.5) * std::log(h.farM / h.nearM) / kDepthHistogramBins);
}

// The model "half extent = slice length" (a long thin slice's sphere): simple to reason about.
double lengthModel(const void*, double a, double b) noexcept {
  return b - a;
}
constexpr SliceHalfExtent kLength{&lengthModel, nullptr};

struct SphereModelCtx {
  double fov, aspect;
};
double sphereModel(const void* ctx, double a, double b) noexcept {
  const auto* c = static_cast<const SphereModelCtx*>(ctx);
  return minimalSliceSphere(c->fov, c->aspect, a, b).radiusM;
}

bool onRung(double x) {
  return ladderValue(ladderRungUp(x, kSteps), kSteps) == x;
}

int rungBelow(double x) {  // largest rung < x
  int k = ladderRungUp(x, kSteps);
  while (!(ladderValue(k, kSteps) < x)) --k;
  return k;
}

int rungAbove(double x) {  // smallest rung > x
  int k = ladderRungUp(x, kSteps);
  while (!(ladderValue(k, kSteps) > x)) ++k;
  return k;
}

TEST(HistogramSplits, BinFormulaClampsAndIsLogSpaced) {
  const double n = 0.5, f = 5000.0;
  EXPECT_EQ(depthHistogramBin(n, f, 256, 0.5), 0u);
  EXPECT_EQ(depthHistogramBin(n, f, 256, 0.1), 0u);
  EXPECT_EQ(depthHistogramBin(n, f, 256, 0.0), 0u);
  EXPECT_EQ(depthHistogramBin(n, f, 256, std::nan("")), 0u);
  EXPECT_EQ(depthHistogramBin(n, f, 256, 5000.0), 255u);
  EXPECT_EQ(depthHistogramBin(n, f, 256, 1e9), 255u);
  // The geometric middle of the range is the middle bin's lower edge.
  EXPECT_EQ(depthHistogramBin(n, f, 256, std::sqrt(n * f) * 1.0001), 128u);
  EXPECT_EQ(depthHistogramBin(n, f, 256, std::sqrt(n * f) * 0.9999), 127u);
}

TEST(HistogramSplits, TwoClustersAndAGapGiveKnownSplits) {
  // Receivers at 10 m and 1000 m, nothing between; 3 cascades over [1, 1100] m with
  // cost = length x receivers / depth: the first cascade ends at the first rung past the near
  // cluster, the gap gets a cascade of its own (no receivers: no cost) and the last starts at the
  // last rung before the far cluster.
  const ReceiverDepthHistogram h = clusters(0.5, 5000.0, {10.0, 1000.0});
  SplitArray s{};
  ASSERT_TRUE(histogramSplits(h, 1.0, 1100.0, 3, kSteps, kLength, nullptr, 0.0, s));
  EXPECT_EQ(s[0], 1.0);
  EXPECT_EQ(s[1], ladderValue(rungAbove(binCentre(h, 10.0)), kSteps));
  EXPECT_EQ(s[2], ladderValue(rungBelow(binCentre(h, 1000.0)), kSteps));
  EXPECT_EQ(s[3], 1100.0);
  // Up to 2000 m, the far cluster is cheaper in the middle cascade (up to the first rung past
  // it: 1024 - 11 m long) than in the last (2000 - 939 m): the last cascade is left empty.
  ASSERT_TRUE(histogramSplits(h, 1.0, 2000.0, 3, kSteps, kLength, nullptr, 0.0, s));
  EXPECT_EQ(s[1], ladderValue(rungAbove(binCentre(h, 10.0)), kSteps));
  EXPECT_EQ(s[2], ladderValue(rungAbove(binCentre(h, 1000.0)), kSteps));
  // Two cascades: one split, right after the near cluster (its receivers weigh 100x more).
  ASSERT_TRUE(histogramSplits(h, 1.0, 2000.0, 2, kSteps, kLength, nullptr, 0.0, s));
  EXPECT_EQ(s[1], ladderValue(rungAbove(binCentre(h, 10.0)), kSteps));
  // One cluster alone: it gets the tightest cascade the rungs allow around it.
  const ReceiverDepthHistogram town = clusters(0.5, 5000.0, {950.0});
  ASSERT_TRUE(histogramSplits(town, 1.0, 2000.0, 4, kSteps, kLength, nullptr, 0.0, s));
  const double c = binCentre(town, 950.0);
  bool tight = false;
  for (int i = 0; i < 4; ++i) {
    if (s[i] < c && c < s[i + 1]) {
      tight = s[i] == ladderValue(rungBelow(c), kSteps) &&
              s[i + 1] == ladderValue(rungAbove(c), kSteps);
    }
  }
  EXPECT_TRUE(tight) << s[1] << " " << s[2] << " " << s[3];
}

TEST(HistogramSplits, ReceiversEvenInLogDepthGiveLogarithmicSplits) {
  // Receivers spread evenly over log depth (a pixel count per bin), cost = length x receivers /
  // depth: the length-over-depth of each cascade is balanced, so the splits are (on the rungs
  // nearest) the logarithmic ones: 1, 10, 100, 1000 m for 3 cascades over [1, 1000] m.
  ReceiverDepthHistogram h;
  h.nearM = 1.0;
  h.farM = 1000.0;
  h.counts.fill(100);
  SplitArray s{};
  ASSERT_TRUE(histogramSplits(h, 1.0, 1000.0, 3, kSteps, kLength, nullptr, 0.0, s));
  EXPECT_NEAR(std::log2(s[1]), std::log2(10.0), 1.5 / kSteps) << s[1];
  EXPECT_NEAR(std::log2(s[2]), std::log2(100.0), 1.5 / kSteps) << s[2];
  EXPECT_TRUE(onRung(s[1]) && onRung(s[2]));
}

TEST(HistogramSplits, EmptyAndDegenerateHistogramsFallBack) {
  SplitArray s{};
  s[1] = 42.0;
  ReceiverDepthHistogram none;  // no histogram
  EXPECT_FALSE(histogramSplits(none, 1.0, 100.0, 4, kSteps, kLength, nullptr, 0.0, s));
  ReceiverDepthHistogram empty;  // a histogram with no receiver
  empty.nearM = 0.5;
  empty.farM = 5000.0;
  EXPECT_FALSE(histogramSplits(empty, 1.0, 100.0, 4, kSteps, kLength, nullptr, 0.0, s));
  const ReceiverDepthHistogram one = clusters(0.5, 5000.0, {30.0}, 1);
  EXPECT_FALSE(histogramSplits(one, 1.0, 100.0, 1, kSteps, kLength, nullptr, 0.0, s));  // 1
  EXPECT_FALSE(histogramSplits(one, 100.0, 1.0, 4, kSteps, kLength, nullptr, 0.0, s));  // inverted
  EXPECT_FALSE(histogramSplits(one, std::nan(""), 100.0, 4, kSteps, kLength, nullptr, 0.0, s));
  EXPECT_FALSE(histogramSplits(one, 1.0, std::numeric_limits<double>::infinity(), 4, kSteps,
                               kLength, nullptr, 0.0, s));
  // Fewer rungs than interior splits (a range of 10%).
  EXPECT_FALSE(histogramSplits(one, 30.0, 33.0, 8, kSteps, kLength, nullptr, 0.0, s));
  EXPECT_EQ(s[1], 42.0);  // untouched by every refusal
  // One receiver is enough to place splits.
  EXPECT_TRUE(histogramSplits(one, 1.0, 100.0, 4, kSteps, kLength, nullptr, 0.0, s));
}

TEST(HistogramSplits, HysteresisKeepsNearlyAsGoodSplits) {
  const SphereModelCtx ctx{glm::radians(8.0), 16.0 / 9.0};
  const SliceHalfExtent sphere{&sphereModel, &ctx};
  const ReceiverDepthHistogram h = clusters(0.5, 5000.0, {300.0, 600.0, 950.0, 1050.0, 1400.0});
  SplitArray best{};
  ASSERT_TRUE(histogramSplits(h, 250.0, 1500.0, 4, kSteps, sphere, nullptr, 0.0, best));
  for (int i = 1; i < 4; ++i) EXPECT_TRUE(onRung(best[i])) << i;
  // Last frame's splits one rung off: kept with 10% hysteresis when they cost little more...
  SplitArray previous = best;
  previous[2] = ladderValue(ladderRungUp(best[2], kSteps) + 1, kSteps);
  SplitArray s{};
  ASSERT_TRUE(histogramSplits(h, 250.0, 1500.0, 4, kSteps, sphere, &previous, 10.0, s));
  EXPECT_EQ(s[2], previous[2]);
  // ...and dropped without hysteresis (the test can fail).
  ASSERT_TRUE(histogramSplits(h, 250.0, 1500.0, 4, kSteps, sphere, &previous, 0.0, s));
  EXPECT_EQ(s[2], best[2]);
  // Unusable previous splits (outside the range, not increasing) are ignored.
  previous[1] = 5000.0;
  ASSERT_TRUE(histogramSplits(h, 250.0, 1500.0, 4, kSteps, sphere, &previous, 10.0, s));
  EXPECT_EQ(s, best);
}

// The zoom at 8 degrees through computeCascades: a town at 900-1100 m seen over foreground
// terrain from 300 m. Histogram splits give the town's cascade smaller texels than the range
// scheme's lambda splits; an empty histogram gives the range scheme's frame exactly.
ShadowSettings zoomSettings() {
  ShadowSettings s;
  s.cascadeCount = 4;
  s.resolution = 2048;
  s.shadowDistanceM = 1500.0;
  s.splitLambda = 0.8;
  return s;
}

Camera zoomCamera(const glm::dvec3& origin) {
  Camera c;
  c.positionWs = origin + glm::dvec3(0.0, 60.0, 0.0);
  c.orientationWs = test::lookAlong({0.0, -0.06, -1.0});
  c.fovYRad = glm::radians(8.0);
  c.aspect = 16.0 / 9.0;
  c.nearM = 0.5;
  c.farM = 5000.0;
  return c;
}

ReceiverDepthRange townRange() {
  ReceiverDepthRange r{300.0, 1450.0};
  r.histogram.nearM = 0.5;
  r.histogram.farM = 1500.0;
  // Terrain thinly from 300 m, the town densely at 900-1100 m, hills to 1450 m.
  for (double d = 300.0; d < 1450.0; d *= 1.01) {
    const bool town = d > 900.0 && d < 1100.0;
    r.histogram.counts[depthHistogramBin(0.5, 1500.0, kDepthHistogramBins, d)] += town ? 2000 : 100;
  }
  return r;
}

double texelAt(const CascadeFrame& f, double d) {
  for (std::uint32_t c = 0; c < f.cascadeCount; ++c) {
    if (d >= f.splitsM[c] && d < f.splitsM[c + 1]) return f.cascades[c].texelSizeM();
  }
  return 0.0;
}

TEST(HistogramSplits, TownCascadeIsTighterThanWithTheRangeScheme) {
  for (const glm::dvec3 origin : {glm::dvec3(0.0), glm::dvec3(1e7, 0.0, -1e7)}) {
    const DirectionalLight light{{0.45, -0.8, -0.35}};
    ShadowSettings s = zoomSettings();
    EXPECT_EQ(s.receiverSplitScheme, ReceiverSplitScheme::kHistogram);  // the default
    s.receiverSplitScheme = ReceiverSplitScheme::kRange;
    const ReceiverDepthRange town = townRange();
    const auto range = computeCascades(s, zoomCamera(origin), light, nullptr, nullptr, &town);
    s.receiverSplitScheme = ReceiverSplitScheme::kHistogram;
    const auto hist = computeCascades(s, zoomCamera(origin), light, nullptr, nullptr, &town);
    ASSERT_TRUE(range.ok() && hist.ok());
    EXPECT_FALSE(range.value().histogramDriven);
    EXPECT_TRUE(hist.value().histogramDriven);
    EXPECT_EQ(hist.value().splitsM[0], range.value().splitsM[0]);  // same ends
    EXPECT_EQ(hist.value().splitsM[4], range.value().splitsM[4]);
    for (int i = 1; i < 4; ++i) {
      EXPECT_TRUE(onRung(hist.value().splitsM[i])) << i;
      EXPECT_GT(hist.value().splitsM[i], hist.value().splitsM[i - 1]);
    }
    const double before = texelAt(range.value(), 1000.0);
    const double after = texelAt(hist.value(), 1000.0);
    std::printf("range splits %.1f %.1f %.1f %.1f %.1f texel at 1000 m %.4f; histogram %.1f "
                "%.1f %.1f %.1f %.1f texel %.4f\n",
                range.value().splitsM[0], range.value().splitsM[1], range.value().splitsM[2],
                range.value().splitsM[3], range.value().splitsM[4], before, hist.value().splitsM[0],
                hist.value().splitsM[1], hist.value().splitsM[2], hist.value().splitsM[3],
                hist.value().splitsM[4], after);
    EXPECT_LT(after, 0.9 * before);
    // Mean texel over the receivers, weighted as the placement weighs them, is smaller too.
    auto meanTexelOverDepth = [&](const CascadeFrame& f) {
      double sum = 0.0, n = 0.0;
      for (std::uint32_t b = 0; b < kDepthHistogramBins; ++b) {
        if (town.histogram.counts[b] == 0) continue;
        const double d = 0.5 * std::exp((b + 0.5) * std::log(1500.0 / 0.5) / kDepthHistogramBins);
        sum += town.histogram.counts[b] * texelAt(f, d) / d;
        n += town.histogram.counts[b];
      }
      return sum / n;
    };
    EXPECT_LT(meanTexelOverDepth(hist.value()), meanTexelOverDepth(range.value()));
    // An empty histogram (or none) is the range scheme, bit for bit.
    ReceiverDepthRange empty = town;
    empty.histogram.counts.fill(0);
    const auto fb = computeCascades(s, zoomCamera(origin), light, nullptr, nullptr, &empty);
    ASSERT_TRUE(fb.ok());
    EXPECT_FALSE(fb.value().histogramDriven);
    EXPECT_EQ(fb.value().splitsM, range.value().splitsM);
    ReceiverDepthRange plain{town.minM, town.maxM};
    const auto fp = computeCascades(s, zoomCamera(origin), light, nullptr, nullptr, &plain);
    ASSERT_TRUE(fp.ok());
    EXPECT_EQ(fp.value().splitsM, range.value().splitsM);
  }
}

TEST(HistogramSplits, JitteredHistogramMovesNoSplitAndCutFallsBack) {
  const DirectionalLight light{{0.45, -0.8, -0.35}};
  ShadowSettings s = zoomSettings();
  s.receiverSplitScheme = ReceiverSplitScheme::kHistogram;
  const Camera cam = zoomCamera(glm::dvec3(0.0));
  CascadeHistory h;
  const ReceiverDepthRange town = townRange();
  const auto first = computeCascades(s, cam, light, nullptr, &h, &town);
  ASSERT_TRUE(first.ok());
  // Counts jittered by up to 5% per bin and the range by 2%, for 60 frames: no split moves.
  for (int k = 0; k < 60; ++k) {
    ReceiverDepthRange j = town;
    j.minM *= 1.0 + 0.02 * std::sin(k);
    j.maxM *= 1.0 + 0.02 * std::cos(k);
    for (std::uint32_t b = 0; b < kDepthHistogramBins; ++b) {
      j.histogram.counts[b] =
          std::uint32_t(j.histogram.counts[b] * (1.0 + 0.05 * std::sin(0.7 * k + b)));
    }
    const auto f = computeCascades(s, cam, light, nullptr, &h, &j);
    ASSERT_TRUE(f.ok());
    EXPECT_EQ(f.value().splitsM, first.value().splitsM) << k;
  }
  for (std::uint32_t i = 0; i < 3; ++i) EXPECT_EQ(h.splitRungEvents[i], 0u) << i;
  // The town moving from 900-1100 m to 450-550 m over 120 frames: splits follow in rung
  // events, never back and forth within 10 frames.
  std::array<int, 4> lastDir{}, lastEvent{};
  lastEvent.fill(-100);
  SplitArray prev = first.value().splitsM;
  int events = 0;
  for (int k = 0; k <= 120; ++k) {
    const double scale = std::exp2(-k / 120.0);
    ReceiverDepthRange m{300.0 * scale, 1450.0 * scale};
    m.histogram.nearM = 0.5;
    m.histogram.farM = 1500.0;
    for (double d = 300.0; d < 1450.0; d *= 1.01) {
      const bool townBin = d > 900.0 && d < 1100.0;
      m.histogram.counts[depthHistogramBin(0.5, 1500.0, kDepthHistogramBins, d * scale)] +=
          townBin ? 2000 : 100;
    }
    const auto f = computeCascades(s, cam, light, nullptr, &h, &m);
    ASSERT_TRUE(f.ok());
    for (int i = 1; i < 4; ++i) {
      const double now = f.value().splitsM[i];
      ASSERT_TRUE(onRung(now)) << k;
      if (now != prev[i]) {
        ++events;
        const int dir = now > prev[i] ? 1 : -1;
        EXPECT_FALSE(lastDir[i] == -dir && k - lastEvent[i] < 10)
            << "split " << i << " frame " << k;
        lastDir[i] = dir;
        lastEvent[i] = k;
      }
    }
    prev = f.value().splitsM;
  }
  EXPECT_GT(events, 0);
  EXPECT_LE(events, 3 * 16);
  // A camera cut (no range): the full range at once.
  const auto cut = computeCascades(s, cam, light, nullptr, &h, nullptr);
  ASSERT_TRUE(cut.ok());
  EXPECT_EQ(cut.value().splitsM[0], cam.nearM);
  EXPECT_FALSE(cut.value().histogramDriven);
}

TEST(HistogramSplits, ExtremesStayFiniteAndOnTheLadder) {
  const DirectionalLight light{{0.0, -1.0, 0.0}};  // straight down
  for (const glm::dvec3 origin : {glm::dvec3(0.0), glm::dvec3(1e7, 1e3, 1e7)}) {
    ShadowSettings s;
    s.cascadeCount = 8;
    s.shadowDistanceM = 1e5;
    s.receiverSplitScheme = ReceiverSplitScheme::kHistogram;
    Camera c;
    c.positionWs = origin;
    c.orientationWs = test::lookAlong({0.3, -0.2, -1.0});
    c.nearM = 1e-3;
    c.farM = 1e5;
    ReceiverDepthRange r{1e-3, 9e4};
    r.histogram.nearM = 1e-3;
    r.histogram.farM = 1e5;
    for (double d = 1e-3; d < 9e4; d *= 1.3) {
      r.histogram.counts[depthHistogramBin(1e-3, 1e5, kDepthHistogramBins, d)] += 10;
    }
    r.histogram.counts[kDepthHistogramBins - 1] = 4000000000u;  // near-overflowing counts
    for (bool tight : {false, true}) {
      s.boxFit = tight ? BoxFit::kTight : BoxFit::kSphere;
      CascadeHistory h;
      for (int frame = 0; frame < 3; ++frame) {
        const auto f = computeCascades(s, c, light, nullptr, &h, &r);
        ASSERT_TRUE(f.ok());
        EXPECT_TRUE(f.value().histogramDriven);
        for (std::uint32_t i = 0; i < 8; ++i) {
          const Cascade& k = f.value().cascades[i];
          EXPECT_LT(k.splitNearM, k.splitFarM) << i;
          EXPECT_TRUE(std::isfinite(k.texelSizeM()) && k.texelSizeM() > 0.0) << i;
          EXPECT_TRUE(test::allFinite(k.viewProjCr)) << i;
          if (i > 0) {
            EXPECT_TRUE(onRung(k.splitNearM)) << i;
          }
        }
      }
    }
  }
}

TEST(HistogramSplits, BadHistogramsAndSchemesAreRefusedByName) {
  const ShadowSettings s;
  const Camera cam;
  const DirectionalLight light;
  ReceiverDepthRange r{1.0, 10.0};
  r.histogram.nearM = -1.0;
  auto e = computeCascades(s, cam, light, nullptr, nullptr, &r);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().field, "receivers.histogram.nearM");
  r.histogram.nearM = 1.0;
  r.histogram.farM = 1.0;
  e = computeCascades(s, cam, light, nullptr, nullptr, &r);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().field, "receivers.histogram.farM");
  r.histogram.farM = std::nan("");
  e = computeCascades(s, cam, light, nullptr, nullptr, &r);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().field, "receivers.histogram.farM");
  ShadowSettings m;
  m.receiverSplitScheme = static_cast<ReceiverSplitScheme>(5);
  ASSERT_TRUE(validate(m).has_value());
  EXPECT_EQ(validate(m)->field, "settings.receiverSplitScheme");
}

}  // namespace
}  // namespace csm
