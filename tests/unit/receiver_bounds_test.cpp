// Receiver-driven light-space box bounds (ReceiverDepthRange::lightBounds): containment of every
// receiver of the frame the bounds came from, sizes held under small translation, fallbacks to
// the box without bounds, extremes.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "csm/core.hpp"
#include "test_util.hpp"

namespace csm {
namespace {

// The visible receivers of a camera over the ground plane y = groundY: one per pixel of a
// w x h grid whose ray hits the ground within `maxDepthM` of view depth (the rest is sky).
std::vector<glm::dvec3> groundReceivers(const Camera& cam, double groundY, double maxDepthM,
                                        int w = 160, int h = 90) {
  std::vector<glm::dvec3> pts;
  const double ty = std::tan(0.5 * cam.fovYRad);
  const glm::dvec3 fwd = cam.forwardWs(), up = cam.upWs(), right = cam.rightWs();
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double sx = ((x + 0.5) / w * 2.0 - 1.0) * ty * cam.aspect;
      const double sy = (1.0 - (y + 0.5) / h * 2.0) * ty;
      const glm::dvec3 dir = fwd + sx * right + sy * up;
      if (!(dir.y < 0.0)) continue;
      const double t = (groundY - cam.positionWs.y) / dir.y;
      if (!(t > 0.0)) continue;
      const glm::dvec3 p = cam.positionWs + t * dir;
      const double depth = glm::dot(p - cam.positionWs, fwd);
      if (depth < cam.nearM || depth > maxDepthM) continue;
      pts.push_back(p);
    }
  }
  return pts;
}

ReceiverDepthRange rangeOf(const Camera& cam, const std::vector<glm::dvec3>& pts) {
  ReceiverDepthRange r{1e300, 0.0};
  for (const glm::dvec3& p : pts) {
    const double d = glm::dot(p - cam.positionWs, cam.forwardWs());
    r.minM = std::min(r.minM, d);
    r.maxM = std::max(r.maxM, d);
  }
  return r;
}

ShadowSettings zoomSettings() {
  ShadowSettings s;
  s.cascadeCount = 4;
  s.resolution = 2048;
  s.shadowDistanceM = 1500.0;
  s.splitLambda = 0.8;
  return s;
}

Camera zoomCamera(glm::dvec3 origin, double fovDeg, glm::dvec3 forward = {0.0, -0.06, -1.0}) {
  Camera c;
  c.positionWs = origin + glm::dvec3(0.0, 40.0, 0.0);
  c.orientationWs = test::lookAlong(forward);
  c.fovYRad = glm::radians(fovDeg);
  c.aspect = 16.0 / 9.0;
  c.nearM = 0.5;
  c.farM = 5000.0;
  return c;
}

// Light-space x, y of p about the cascade's box centre (in double).
glm::dvec2 inBox(const CascadeFrame& f, const Cascade& c, const glm::dvec3& p) {
  return glm::dvec2(toLightSpace(f.lightBasisWs, c.boxCenterWs, p));
}

int cascadeOf(const CascadeFrame& f, const glm::dvec3& camWs, const glm::dvec3& p) {
  const double d = glm::dot(p - camWs, f.cameraForwardWs);
  for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
    if (d >= f.splitsM[i] && d < f.splitsM[i + 1]) return static_cast<int>(i);
  }
  return -1;
}

struct Fitted {
  CascadeFrame before;  // the frame the bounds were taken from (receiver splits, no bounds)
  CascadeFrame after;   // the same inputs with the bounds
  ReceiverDepthRange range;
};

Fitted fitFrame(const ShadowSettings& s, const Camera& cam, const DirectionalLight& light,
                const std::vector<glm::dvec3>& pts) {
  Fitted r;
  r.range = rangeOf(cam, pts);
  auto f0 = computeCascades(s, cam, light, nullptr, nullptr, &r.range);
  EXPECT_TRUE(f0.ok());
  r.before = f0.value();
  r.range.lightBounds = receiverLightBounds(r.before, cam, pts);
  auto f1 = computeCascades(s, cam, light, nullptr, nullptr, &r.range);
  EXPECT_TRUE(f1.ok());
  r.after = f1.value();
  return r;
}

// Every receiver lies inside its cascade's box, with at least `slackM` to spare where the box is
// smaller than the one without bounds; returns how many receivers were checked.
std::size_t expectContained(const Fitted& r, const std::vector<glm::dvec3>& pts,
                            const glm::dvec3& camWs) {
  std::size_t n = 0;
  for (const glm::dvec3& p : pts) {
    const int i = cascadeOf(r.after, camWs, p);
    if (i < 0) continue;
    const Cascade& c = r.after.cascades[i];
    const glm::dvec2 q = inBox(r.after, c, p);
    // Inside by at least half a texel's rounding: the box covers it.
    EXPECT_LE(std::abs(q.x), c.halfExtentLs.x) << "cascade " << i;
    EXPECT_LE(std::abs(q.y), c.halfExtentLs.y) << "cascade " << i;
    ++n;
  }
  return n;
}

// The frame with bounds is the frame without them, cascade for cascade, bit for bit.
void expectSameBoxes(const CascadeFrame& a, const CascadeFrame& b, std::uint32_t skip = 99) {
  for (std::uint32_t i = 0; i < a.cascadeCount; ++i) {
    if (i == skip) continue;
    EXPECT_FALSE(b.cascades[i].receiverFit);
    EXPECT_EQ(a.cascades[i].halfExtentLs, b.cascades[i].halfExtentLs) << i;
    EXPECT_EQ(a.cascades[i].boxCenterWs, b.cascades[i].boxCenterWs) << i;
    EXPECT_EQ(a.cascades[i].viewProjCr, b.cascades[i].viewProjCr) << i;
  }
}

TEST(ReceiverBounds, BoxContainsEveryReceiverOfItsFrameAndIsNeverLarger) {
  const ShadowSettings s = zoomSettings();
  int fitted = 0;
  for (double fov : {8.0, 30.0, 60.0}) {
    for (const glm::dvec3& dir : {glm::dvec3(0.45, -0.8, -0.35), glm::dvec3(0.0, -1.0, 0.0),
                                  glm::dvec3(0.0, -0.06, -1.0), glm::dvec3(-0.9, -0.2, 0.3)}) {
      const Camera cam = zoomCamera(glm::dvec3(0.0), fov);
      const DirectionalLight light{dir};
      const auto pts = groundReceivers(cam, 0.0, s.shadowDistanceM);
      const Fitted r = fitFrame(s, cam, light, pts);
      EXPECT_GT(expectContained(r, pts, cam.positionWs), 1000u);
      for (std::uint32_t i = 0; i < s.cascadeCount; ++i) {
        EXPECT_LE(r.after.cascades[i].halfExtentLs.x, r.before.cascades[i].halfExtentLs.x);
        EXPECT_EQ(r.after.splitsM[i + 1], r.before.splitsM[i + 1]);
        fitted += r.after.cascades[i].receiverFit ? 1 : 0;
      }
    }
  }
  EXPECT_GT(fitted, 12);
}

TEST(ReceiverBounds, NarrowZoomShrinksTheLastCascadeBelowTheFarCap) {
  // At 8 degrees the top of the view is sky: the last cascade need not cover the far cap.
  const ShadowSettings s = zoomSettings();
  const Camera cam = zoomCamera(glm::dvec3(0.0), 8.0);
  const DirectionalLight light{glm::dvec3(0.45, -0.8, -0.35)};
  const auto pts = groundReceivers(cam, 0.0, s.shadowDistanceM);
  const Fitted r = fitFrame(s, cam, light, pts);
  const std::uint32_t last = s.cascadeCount - 1;
  EXPECT_TRUE(r.after.cascades[last].receiverFit);
  EXPECT_LT(r.after.cascades[last].texelSizeM(), 0.8 * r.before.cascades[last].texelSizeM());
}

TEST(ReceiverBounds, CameraMotionSinceTheBoundsIsCovered) {
  // Bounds from a camera 3 frames back; the camera flew 6 m (along and across): the receivers it
  // sees now (the same ground, shifted) are all inside the boxes.
  const ShadowSettings s = zoomSettings();
  const DirectionalLight light{glm::dvec3(0.45, -0.8, -0.35)};
  for (const glm::dvec3& move :
       {glm::dvec3(0.0, 0.0, -6.0), glm::dvec3(6.0, 0.0, 0.0), glm::dvec3(-4.0, 0.0, 4.0)}) {
    const Camera cam0 = zoomCamera(glm::dvec3(0.0), 8.0);
    Camera cam1 = cam0;
    cam1.positionWs += move;
    const auto pts0 = groundReceivers(cam0, 0.0, s.shadowDistanceM);
    const auto pts1 = groundReceivers(cam1, 0.0, s.shadowDistanceM);
    Fitted r = fitFrame(s, cam0, light, pts0);
    auto f = computeCascades(s, cam1, light, nullptr, nullptr, &r.range);
    ASSERT_TRUE(f.ok());
    r.after = f.value();
    ASSERT_EQ(r.after.splitsM, r.before.splitsM);
    EXPECT_TRUE(r.after.cascades[3].receiverFit);
    EXPECT_GT(expectContained(r, pts1, cam1.positionWs), 1000u);
  }
}

TEST(ReceiverBounds, ATurnOrAWiderViewFallsBackANarrowerOneFits) {
  // Bounds say nothing about receivers a turn uncovers (on grazing ground they may lie anywhere
  // along the slice), nor about the ground between the pixels they bounded that a narrower view
  // samples (89 m per pixel row at 1500 m here): any turn, roll included, or a changed field of
  // view falls back, and every receiver of the new view is inside the box it gets.
  const ShadowSettings s = zoomSettings();
  const DirectionalLight light{glm::dvec3(0.45, -0.8, -0.35)};
  const Camera cam0 = zoomCamera(glm::dvec3(0.0), 8.0);
  const auto pts0 = groundReceivers(cam0, 0.0, s.shadowDistanceM);
  const Fitted r = fitFrame(s, cam0, light, pts0);
  const CascadeFrame& plain = r.before;
  struct Turn {
    glm::dvec3 axis;
    double deg;
    double fovDeg;
    bool fits;
  };
  for (const Turn& t : {Turn{{0, 1, 0}, 0.01, 8.0, false}, Turn{{1, 0, 0}, -0.3, 8.0, false},
                        Turn{{0, 0, 1}, 1.0, 8.0, false}, Turn{{0, 1, 0}, 0.0, 8.2, false},
                        Turn{{0, 1, 0}, 0.0, 7.9, false}}) {
    Camera cam1 = cam0;
    cam1.orientationWs = glm::angleAxis(glm::radians(t.deg), t.axis) * cam0.orientationWs;
    cam1.fovYRad = glm::radians(t.fovDeg);
    const auto pts1 = groundReceivers(cam1, 0.0, s.shadowDistanceM);
    auto f = computeCascades(s, cam1, light, nullptr, nullptr, &r.range);
    ASSERT_TRUE(f.ok());
    Fitted now = r;
    now.after = f.value();
    bool anyFit = false;
    for (std::uint32_t i = 0; i < s.cascadeCount; ++i) {
      anyFit = anyFit || now.after.cascades[i].receiverFit;
    }
    EXPECT_EQ(anyFit, t.fits) << t.deg << " deg, fov " << t.fovDeg;
    if (!t.fits && t.fovDeg == 8.0 && t.deg == 0.01) {
      ReceiverDepthRange none = r.range;
      none.lightBounds = ReceiverLightBounds{};
      auto g = computeCascades(s, cam1, light, nullptr, nullptr, &none);
      ASSERT_TRUE(g.ok());
      expectSameBoxes(g.value(), now.after);
    }
    EXPECT_GT(expectContained(now, pts1, cam1.positionWs), 1000u);
  }
  (void)plain;
}

TEST(ReceiverBounds, SmallTranslationChangesNoSizeBetweenRungEvents) {
  // A camera gliding 0.25 m per frame for 200 frames, the bounds (and range) of each frame fed to
  // the frame after, as a reduction one frame late would: the boxes hold their rungs.
  ShadowSettings s = zoomSettings();
  const DirectionalLight light{glm::dvec3(0.45, -0.8, -0.35)};
  for (double originX : {0.0, 1e7}) {
    CascadeHistory h;
    Camera cam = zoomCamera(glm::dvec3(originX, 0.0, 0.0), 8.0);
    std::optional<ReceiverDepthRange> range;
    std::array<double, kMaxCascades> half{};
    int fittedFrames = 0;
    for (int frame = 0; frame < 200; ++frame) {
      auto f = computeCascades(s, cam, light, nullptr, &h, range ? &*range : nullptr);
      ASSERT_TRUE(f.ok());
      const CascadeFrame& fr = f.value();
      if (frame >= 3) {
        for (std::uint32_t i = 0; i < s.cascadeCount; ++i) {
          if (frame > 3) {
            EXPECT_EQ(fr.cascades[i].halfExtentLs.x, half[i]) << frame << " " << i;
          }
          half[i] = fr.cascades[i].halfExtentLs.x;
        }
        fittedFrames += fr.cascades[3].receiverFit ? 1 : 0;
      }
      const auto pts = groundReceivers(cam, 0.0, s.shadowDistanceM, 96, 54);
      range = rangeOf(cam, pts);
      range->lightBounds = receiverLightBounds(fr, cam, pts);
      cam.positionWs += glm::dvec3(0.05, 0.0, -0.25);
    }
    EXPECT_GE(fittedFrames, 190);
    // Events only in the first frames, while the range and then the bounds arrived.
    std::uint32_t events = 0;
    for (std::uint32_t i = 0; i < s.cascadeCount; ++i) events += h.sizeRungEvents[i];
    EXPECT_LE(events, 2u * s.cascadeCount);
  }
}

TEST(ReceiverBounds, FallsBackToTheBoxWithoutBounds) {
  const ShadowSettings s = zoomSettings();
  const Camera cam = zoomCamera(glm::dvec3(0.0), 8.0);
  const DirectionalLight light{glm::dvec3(0.45, -0.8, -0.35)};
  const auto pts = groundReceivers(cam, 0.0, s.shadowDistanceM);
  const Fitted r = fitFrame(s, cam, light, pts);
  const CascadeFrame& plain = r.before;
  auto with = [&](const ReceiverLightBounds& b, const Camera& c = Camera{}) {
    ReceiverDepthRange range = r.range;
    range.lightBounds = b;
    const Camera& use = c.fovYRad == Camera{}.fovYRad ? cam : c;
    auto f = computeCascades(s, use, light, nullptr, nullptr, &range);
    EXPECT_TRUE(f.ok());
    return f.value();
  };
  ASSERT_TRUE(r.after.cascades[3].receiverFit);
  // No bounds.
  expectSameBoxes(plain, with(ReceiverLightBounds{}));
  // A split that moved outward since the bounds were taken (a rung event): the cascade whose
  // slice grows falls back; the one whose slice shrank keeps a superset and still fits.
  ReceiverLightBounds b = r.range.lightBounds;
  b.splitsM[3] = std::nextafter(b.splitsM[3], 0.0);
  const CascadeFrame moved = with(b);
  EXPECT_TRUE(r.after.cascades[2].receiverFit);
  EXPECT_FALSE(moved.cascades[2].receiverFit);
  EXPECT_EQ(moved.cascades[2].halfExtentLs, plain.cascades[2].halfExtentLs);
  EXPECT_EQ(moved.cascades[2].viewProjCr, plain.cascades[2].viewProjCr);
  for (std::uint32_t i : {0u, 1u, 3u}) {
    EXPECT_EQ(moved.cascades[i].receiverFit, r.after.cascades[i].receiverFit) << i;
    EXPECT_EQ(moved.cascades[i].viewProjCr, r.after.cascades[i].viewProjCr) << i;
  }
  EXPECT_TRUE(moved.cascades[3].receiverFit);
  // Another cascade count.
  b = r.range.lightBounds;
  b.cascadeCount = 3;
  expectSameBoxes(plain, with(b));
  // A light basis that differs (a light step).
  b = r.range.lightBounds;
  b.lightBasisWs = lightBasisWs(glm::normalize(glm::dvec3(0.45, -0.8, -0.3501)));
  expectSameBoxes(plain, with(b));
  // One cascade with no receiver: only that one falls back.
  b = r.range.lightBounds;
  b.minLs[3] = glm::dvec2(1.0);
  b.maxLs[3] = glm::dvec2(-1.0);
  const CascadeFrame oneEmpty = with(b);
  EXPECT_FALSE(oneEmpty.cascades[3].receiverFit);
  EXPECT_EQ(oneEmpty.cascades[3].halfExtentLs, plain.cascades[3].halfExtentLs);
  // Receivers that lie outside the box without bounds.
  b = r.range.lightBounds;
  b.minLs[3] += glm::dvec2(1e5);
  b.maxLs[3] += glm::dvec2(1e5);
  EXPECT_FALSE(with(b).cascades[3].receiverFit);
  // A cut: the camera is 5 km from where the bounds were taken (same splits: no depth change).
  Camera far = cam;
  far.positionWs += glm::dvec3(5000.0, 0.0, 0.0);
  ReceiverDepthRange range = r.range;
  auto plainFar = computeCascades(s, far, light, nullptr, nullptr, &r.range);
  ASSERT_TRUE(plainFar.ok());
  range.lightBounds = ReceiverLightBounds{};
  auto noBoundsFar = computeCascades(s, far, light, nullptr, nullptr, &range);
  ASSERT_TRUE(noBoundsFar.ok());
  expectSameBoxes(noBoundsFar.value(), plainFar.value());
  // Unstabilised (the comparison mode) ignores them.
  ShadowSettings u = s;
  u.diagnostics.stabilize = false;
  auto ua = computeCascades(u, cam, light, nullptr, nullptr, &r.range);
  range = r.range;
  range.lightBounds = ReceiverLightBounds{};
  auto ub = computeCascades(u, cam, light, nullptr, nullptr, &range);
  ASSERT_TRUE(ua.ok() && ub.ok());
  expectSameBoxes(ub.value(), ua.value());
}

TEST(ReceiverBounds, ExtremesStayFiniteAndContained) {
  struct Case {
    glm::dvec3 origin;
    double nearM, farM, shadowM, fovDeg;
    glm::dvec3 light;
  };
  const glm::dvec3 view(0.0, -0.06, -1.0);
  const Case cases[] = {
      {glm::dvec3(1e7, 0.0, -1e7), 0.5, 5000.0, 1500.0, 8.0, glm::dvec3(0.45, -0.8, -0.35)},
      {glm::dvec3(1e7, 0.0, 1e7), 1e-3, 5000.0, 1500.0, 60.0, glm::dvec3(0.0, -1.0, 0.0)},
      {glm::dvec3(0.0), 0.5, 1e5, 1e5, 8.0, view},  // light along the view
      {glm::dvec3(-1e7, 0.0, 0.0), 1e-3, 1e5, 1e5, 30.0, glm::dvec3(0.0, -1.0, 0.0)},
  };
  for (const Case& k : cases) {
    ShadowSettings s = zoomSettings();
    s.shadowDistanceM = k.shadowM;
    Camera cam = zoomCamera(k.origin, k.fovDeg);
    cam.nearM = k.nearM;
    cam.farM = k.farM;
    const DirectionalLight light{k.light};
    const auto pts = groundReceivers(cam, k.origin.y, s.shadowDistanceM);
    ASSERT_FALSE(pts.empty());
    const Fitted r = fitFrame(s, cam, light, pts);
    EXPECT_GT(expectContained(r, pts, cam.positionWs), 500u);
    for (std::uint32_t i = 0; i < s.cascadeCount; ++i) {
      const Cascade& c = r.after.cascades[i];
      EXPECT_TRUE(std::isfinite(c.halfExtentLs.x) && c.halfExtentLs.x > 0.0);
      EXPECT_LE(c.halfExtentLs.x, r.before.cascades[i].halfExtentLs.x);
      for (int col = 0; col < 4; ++col) {
        for (int row = 0; row < 4; ++row) EXPECT_TRUE(std::isfinite(c.viewProjCr[col][row]));
      }
    }
  }
}

TEST(ReceiverBounds, BadBoundsAndMarginAreRefusedByName) {
  const ShadowSettings s = zoomSettings();
  const Camera cam = zoomCamera(glm::dvec3(0.0), 8.0);
  const DirectionalLight light{glm::dvec3(0.45, -0.8, -0.35)};
  ReceiverDepthRange range{100.0, 900.0};
  range.lightBounds.cascadeCount = 4;
  range.lightBounds.minLs[1].y = std::nan("");
  auto f = computeCascades(s, cam, light, nullptr, nullptr, &range);
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().field.find("receivers.lightBounds"), std::string::npos);
  range.lightBounds.minLs[1].y = 0.0;
  range.lightBounds.cascadeCount = kMaxCascades + 1;
  f = computeCascades(s, cam, light, nullptr, nullptr, &range);
  ASSERT_FALSE(f.ok());
  EXPECT_EQ(f.error().field, "receivers.lightBounds.cascadeCount");
  range.lightBounds.cascadeCount = 4;
  range.lightBounds.cameraPositionWs.z = INFINITY;
  f = computeCascades(s, cam, light, nullptr, nullptr, &range);
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().field.find("receivers.lightBounds.cameraPositionWs"), std::string::npos);
  ShadowSettings m = s;
  m.receiverBoundsMargin = 1.5;
  EXPECT_EQ(validate(m)->field, "settings.receiverBoundsMargin");
  m.receiverBoundsMargin = -0.1;
  EXPECT_EQ(validate(m)->field, "settings.receiverBoundsMargin");
}

}  // namespace
}  // namespace csm
