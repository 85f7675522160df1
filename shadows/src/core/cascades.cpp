#include "csm/cascades.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "csm/frustum.hpp"
#include "csm/ladder.hpp"
#include "csm/light_space.hpp"
#include "csm/receiver_bounds.hpp"

namespace csm {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Receiver-driven splits span at least this ratio of far to near.
constexpr double kMinSpanRatio = 1.1;
// The depth window's anchor grid (and its margin on each side) as a fraction of the depth
// range's far side: a power of two, so the step is exact on the ladder's rungs.
constexpr double kDepthStepFraction = 0.125;

std::array<glm::dvec3, 8> aabbCorners(const AabbWs& b) noexcept {
  std::array<glm::dvec3, 8> c{};
  for (int i = 0; i < 8; ++i) {
    c[i] = glm::dvec3((i & 1) ? b.maxWs.x : b.minWs.x, (i & 2) ? b.maxWs.y : b.minWs.y,
                      (i & 4) ? b.maxWs.z : b.minWs.z);
  }
  return c;
}

bool sphereTouchesAabb(const glm::dvec3& c, double r, const AabbWs& b) noexcept {
  const glm::dvec3 q = glm::clamp(c, b.minWs, b.maxWs);
  const glm::dvec3 d = c - q;
  return glm::dot(d, d) <= r * r;
}

// The light direction used for shadows: with settings.lightStepDeg > 0 and a history, the
// direction last used holds until the light has turned more than the step away from it.
glm::dvec3 heldLightDirection(const ShadowSettings& settings, const glm::dvec3& directionWs,
                              CascadeHistory* history, bool& stepped) noexcept {
  stepped = false;
  if (history == nullptr || !(settings.lightStepDeg > 0.0)) return directionWs;
  const glm::dvec3 held = history->heldLightDirectionWs;
  const bool haveHeld = glm::dot(held, held) > 0.5;
  const double cosStep = std::cos(glm::radians(settings.lightStepDeg));
  if (haveHeld && glm::dot(held, directionWs) >= cosStep) return held;
  if (haveHeld) {
    stepped = true;
    ++history->lightStepEvents;
  }
  history->heldLightDirectionWs = directionWs;
  return directionWs;
}

// The split placement's model of a slice's box (histogramSplits): the half side of the slice's
// minimal sphere, or of its light-space square where the tight box would take that.
struct SliceBoxModel {
  const Camera* camera = nullptr;
  glm::dmat3 basisT{1.0};
  bool tight = false;
};

double sliceBoxHalfExtent(const void* context, double nearM, double farM) noexcept {
  const SliceBoxModel& m = *static_cast<const SliceBoxModel*>(context);
  double half = minimalSliceSphere(m.camera->fovYRad, m.camera->aspect, nearM, farM).radiusM;
  if (m.tight) {
    glm::dvec2 lo(kInf), hi(-kInf);
    for (const glm::dvec3& p : sliceCornersCr(*m.camera, nearM, farM)) {
      const glm::dvec3 q = m.basisT * p;
      lo = glm::min(lo, glm::dvec2(q));
      hi = glm::max(hi, glm::dvec2(q));
    }
    half = std::min(half, 0.5 * std::max(hi.x - lo.x, hi.y - lo.y));
  }
  return half;
}

// Puts the interior splits on the ladder (nearest rung, with hysteresis). If two would meet
// (a span too short for the ladder's step), the splits stay as computed this frame.
void ladderSplits(SplitArray& splitsM, std::uint32_t count, double steps, double hysteresis,
                  CascadeHistory* history, std::array<int, kMaxCascades + 1>& rungs) noexcept {
  SplitArray laddered = splitsM;
  for (std::uint32_t i = 1; i < count; ++i) {
    const int prev = history != nullptr ? history->splitRung[i] : kNoRung;
    rungs[i] = ladderRungNearestHysteretic(splitsM[i], steps, prev, hysteresis);
    laddered[i] = ladderValue(rungs[i], steps);
  }
  for (std::uint32_t i = 1; i <= count; ++i) {
    if (!(laddered[i] > laddered[i - 1])) {
      rungs = detail::noRungs<kMaxCascades + 1>();
      break;
    }
  }
  if (rungs[1] != kNoRung || count == 1) splitsM = laddered;
  if (history != nullptr) {
    for (std::uint32_t i = 1; i < count; ++i) {
      const int prev = history->splitRung[i];
      if (prev != kNoRung && rungs[i] != kNoRung && prev != rungs[i]) {
        ++history->splitRungEvents[i - 1];
      }
      history->splitRung[i] = rungs[i];
    }
  }
}

// Steps a size up the ladder with hysteresis against the history's rung (when given one);
// counts the rung events.
int rungUp(double lengthM, double steps, double hysteresis, int* previous,
           std::uint32_t* events) noexcept {
  const int prev = previous != nullptr ? *previous : kNoRung;
  const int rung = ladderRungUpHysteretic(lengthM, steps, prev, hysteresis);
  if (previous != nullptr) {
    if (prev != kNoRung && prev != rung && events != nullptr) ++*events;
    *previous = rung;
  }
  return rung;
}

// What every step of one computeCascades call shares.
struct FrameInputs {
  const ShadowSettings& settings;
  const Camera& camera;
  CascadeHistory* history = nullptr;
  glm::dmat3 basis{1.0};
  glm::dmat3 basisT{1.0};
  // The ladder: every length that sets a size moves between its rungs only, with hysteresis.
  bool ladder = false;
  double steps = 0.0;
  double hysteresis = 0.0;
  double res = 0.0;
  // A box of whole texels whose half side leaves room for the half-texel snap:
  // h - texel / 2 >= e  <=>  h >= e * res / (res - 1).
  double snapMargin = 0.0;
  // The camera holds its position (see prepareHistory).
  bool cameraHeld = false;
  // The visible receivers' light-space bounds, when taken with this frame's splits and light
  // basis (receiverBoundsApply); else null.
  const ReceiverLightBounds* receiverBounds = nullptr;
};

// How far receivers reach along the view: the scene's depth interval (infinite without bounds).
struct SceneDepth {
  const AabbWs* bounds = nullptr;
  std::array<glm::dvec3, 8> corners{};
  double minM = -kInf;
  double maxM = kInf;
  // The farthest corner's distance from the camera: a bound on the scene's view depth that no
  // turn of the camera changes.
  double reachM = kInf;
  // Some of the scene lies beyond the camera's near plane.
  bool ahead = true;
};

// Resets what was quantised against a maximum or a cascade count that has changed (the rung
// event counters and the held light direction carry on), counts the frame and returns whether
// the camera holds its position.
bool prepareHistory(CascadeHistory* history, double maxFarM, std::uint32_t count,
                    const glm::dvec3& cameraWs) noexcept {
  if (history == nullptr) return false;
  if (history->shadowFarMaxM != maxFarM || history->cascadeCount != count) {
    if (history->cascadeCount != count) {
      history->sizeRung = detail::noRungs<kMaxCascades>();
      history->depthRung = detail::noRungs<kMaxCascades>();
      history->depthAnchorLs = {};
      history->depthAnchorStepLs = {};
      history->boxCenterLs = {};
      history->boxTexelLs = {};
      history->splitRung = detail::noRungs<kMaxCascades + 1>();
    }
    history->shadowFarM = 0.0;
    history->depthNearLs = {};
    history->shadowFarMaxM = maxFarM;
    history->cascadeCount = count;
  }
  ++history->frames;
  // The camera holds its position (a zoom, a resize, a turn; or the history's first frame): the
  // depth window and the box may hold their grid points (fitStableBox). When the camera moves,
  // every camera-relative position and the matrices change anyway, and the box takes the grid
  // point nearest the sphere's centre (most slack).
  const bool cameraHeld = history->frames == 1 || history->cameraPositionWs == cameraWs;
  history->cameraPositionWs = cameraWs;
  return cameraHeld;
}

SceneDepth sceneDepthInterval(const AabbWs* sceneBounds, const Camera& camera,
                              const glm::dvec3& forwardWs) noexcept {
  SceneDepth scene;
  scene.bounds = sceneBounds;
  if (sceneBounds != nullptr) {
    scene.corners = aabbCorners(*sceneBounds);
    scene.minM = kInf;
    scene.maxM = -kInf;
    scene.reachM = 0.0;
    for (const glm::dvec3& p : scene.corners) {
      const double d = glm::dot(p - camera.positionWs, forwardWs);
      scene.minM = std::min(scene.minM, d);
      scene.maxM = std::max(scene.maxM, d);
      scene.reachM = std::max(scene.reachM, glm::length(p - camera.positionWs));
    }
  }
  scene.ahead = scene.maxM > camera.nearM;
  return scene;
}

// Receiver-driven splits: start at the nearest visible receiver (widened, on the ladder, so the
// range moving a little moves nothing) and end at the farthest. Returns the splits' near end;
// sets receiverFarM (infinite without receivers).
double receiverSplitNear(const FrameInputs& in, const ReceiverDepthRange* receivers, double maxFarM,
                         double& receiverFarM) noexcept {
  const ShadowSettings& settings = in.settings;
  const Camera& camera = in.camera;
  CascadeHistory* history = in.history;
  double splitNearM = camera.nearM;
  receiverFarM = kInf;
  if (receivers == nullptr) {
    if (history != nullptr) history->receiverNearRung = kNoRung;
    return splitNearM;
  }
  const double margin = settings.receiverDepthMargin;
  const double wantNearM = receivers->minM * (1.0 - margin);
  receiverFarM = std::max(receivers->maxM * (1.0 + margin), 2.0 * camera.nearM);
  // (If that range is thinner than kMinSpanRatio, the splits keep the camera's near.)
  int rung = kNoRung;
  if (wantNearM > camera.nearM) {
    rung = ladderRungDownHysteretic(wantNearM, settings.ladderStepsPerOctave,
                                    history != nullptr ? history->receiverNearRung : kNoRung,
                                    settings.ladderHysteresisSteps);
    const double rungNearM =
        in.ladder ? ladderValue(rung, settings.ladderStepsPerOctave) : wantNearM;
    // Keep at least 10% of depth for the splits, and never before the camera's near.
    if (rungNearM > camera.nearM && rungNearM * kMinSpanRatio < std::min(receiverFarM, maxFarM)) {
      splitNearM = rungNearM;
    } else {
      rung = kNoRung;
    }
  }
  if (history != nullptr) history->receiverNearRung = rung;
  return splitNearM;
}

// The split distances from splitNearM to frame.shadowFarM: practical or explicit, histogram-driven
// interior splits where asked for, then on the ladder. Returns the splits' rungs.
std::array<int, kMaxCascades + 1> splitDistances(const FrameInputs& in,
                                                 const ReceiverDepthRange* receivers,
                                                 double splitNearM, CascadeFrame& frame) {
  const ShadowSettings& settings = in.settings;
  CascadeHistory* history = in.history;
  const std::uint32_t count = settings.cascadeCount;
  frame.splitsM = settings.explicitSplits()
                      ? explicitSplits(splitNearM, frame.shadowFarM, count, settings.splitPositions)
                      : practicalSplits(splitNearM, frame.shadowFarM, count, settings.splitLambda);
  // Histogram-driven interior splits (sample-distribution shadow maps): on the ladder's rungs
  // by construction, kept while last frame's are within one rung's ratio of the best cost
  // (times the hysteresis), so the rung hysteresis below is not applied on top.
  double splitHysteresis = in.hysteresis;
  if (receivers != nullptr && settings.receiverSplitScheme == ReceiverSplitScheme::kHistogram &&
      !settings.explicitSplits()) {
    const SliceBoxModel model{&in.camera, in.basisT,
                              settings.diagnostics.stabilize && settings.boxFit == BoxFit::kTight};
    SplitArray previous{};
    bool havePrevious = in.ladder && history != nullptr;
    for (std::uint32_t i = 1; havePrevious && i < count; ++i) {
      if (history->splitRung[i] == kNoRung) havePrevious = false;
      if (havePrevious) previous[i] = ladderValue(history->splitRung[i], in.steps);
    }
    if (histogramSplits(receivers->histogram, splitNearM, frame.shadowFarM, count, in.steps,
                        SliceHalfExtent{&sliceBoxHalfExtent, &model},
                        havePrevious ? &previous : nullptr,
                        in.hysteresis * (std::exp2(1.0 / in.steps) - 1.0), frame.splitsM)) {
      frame.histogramDriven = true;
      splitHysteresis = 0.0;
    }
  }
  std::array<int, kMaxCascades + 1> splitRungs = detail::noRungs<kMaxCascades + 1>();
  if (in.ladder) {
    ladderSplits(frame.splitsM, count, in.steps, splitHysteresis, history, splitRungs);
  }
  return splitRungs;
}

// The stable box's centre before snapping (light space about the world origin) and the half
// side it needs: the sphere's, or the slice's own extent where that is smaller (sets
// c.tightFit then), or the visible receivers' bounds where those are smaller still (sets
// c.receiverFit).
struct BoxNeed {
  glm::dvec3 centerLs{0.0};
  double half = 0.0;
  // What the box must cover about centerLs: the square half / snapMargin, or the receivers'
  // rectangle (c.receiverFit).
  glm::dvec2 coverHalf{0.0};
};

BoxNeed boxNeed(const FrameInputs& in, std::uint32_t i, Cascade& c) noexcept {
  BoxNeed need{in.basisT * c.sphereCenterWs, c.sphereRadiusM * in.snapMargin};
  if (in.settings.boxFit == BoxFit::kTight) {
    const auto corners = sliceCornersCr(in.camera, c.splitNearM, c.splitFarM);
    glm::dvec2 lo(kInf), hi(-kInf);
    for (const glm::dvec3& p : corners) {
      const glm::dvec3 q = in.basisT * p;
      lo = glm::min(lo, glm::dvec2(q));
      hi = glm::max(hi, glm::dvec2(q));
    }
    const double tightHalf = 0.5 * std::max(hi.x - lo.x, hi.y - lo.y) * in.snapMargin;
    if (tightHalf < need.half) {
      need.half = tightHalf;
      const glm::dvec3 cameraLs = in.basisT * in.camera.positionWs;
      need.centerLs.x = cameraLs.x + 0.5 * (lo.x + hi.x);
      need.centerLs.y = cameraLs.y + 0.5 * (lo.y + hi.y);
      c.tightFit = true;
    }
  }
  need.coverHalf = glm::dvec2(need.half / in.snapMargin);
  // Receiver-driven: the visible receivers' rectangle, never larger than the above.
  if (in.receiverBounds != nullptr) {
    const auto fit = fitBoxToReceivers(*in.receiverBounds, i, in.basis, in.camera, c.splitNearM,
                                       c.splitFarM, glm::dvec2(need.centerLs), need.coverHalf.x,
                                       in.settings.receiverBoundsMargin);
    if (fit) {
      const double fitHalf = std::max(fit->coverHalfLs.x, fit->coverHalfLs.y) * in.snapMargin;
      if (fitHalf < need.half) {
        need.half = fitHalf;
        need.centerLs.x = fit->centerLs.x;
        need.centerLs.y = fit->centerLs.y;
        need.coverHalf = fit->coverHalfLs;
        c.receiverFit = true;
      }
    }
  }
  return need;
}

// The box's half side and depth reach: on the ladder's rungs (with hysteresis), or the needed
// lengths quantised up. Sets c's rungs and c.depthFarLs; returns the half side.
double boxHalfSide(const FrameInputs& in, std::uint32_t i, double neededHalf, Cascade& c) {
  CascadeHistory* history = in.history;
  if (!in.ladder) {
    c.depthFarLs = c.sphereRadiusM;
    return quantizeLengthUp(neededHalf);
  }
  const int prev = history != nullptr ? history->sizeRung[i] : kNoRung;
  c.sizeRung = rungUp(neededHalf, in.steps, in.hysteresis,
                      history != nullptr ? &history->sizeRung[i] : nullptr,
                      history != nullptr ? &history->sizeRungEvents[i] : nullptr);
  c.sizeRungChanged = prev != kNoRung && prev != c.sizeRung;
  const double half = ladderValue(c.sizeRung, in.steps);
  c.depthRung = rungUp(c.sphereRadiusM, in.steps, in.hysteresis,
                       history != nullptr ? &history->depthRung[i] : nullptr, nullptr);
  c.depthFarLs = ladderValue(c.depthRung, in.steps);
  return half;
}

// The depth window is world-anchored too: its origin (the box centre's light-space z) sits on a
// grid of depthStep = depthFarLs / 8 about the world origin, in double, and holds while the
// sphere stays inside the window (which gets one step of margin on each side); it moves to the
// nearest grid point when the sphere leaves it or at a depth rung event. So between events no
// stored or receiver depth is re-rounded (a depth origin that follows the sphere continuously
// moves every depth by a fraction of a quantum each frame, and receivers on a depth tie, e.g.
// ground at a caster's foot, flip).
// (Held while the camera holds its position, with the ladder; a moving camera changes every
// camera-relative position anyway, and the window follows the sphere's centre.)
// Returns the window's origin; widens c.depthFarLs by the margin when anchored.
double depthWindowOrigin(const FrameInputs& in, std::uint32_t i, double centerZ, Cascade& c) {
  CascadeHistory* history = in.history;
  double anchorZ = centerZ;
  c.depthAnchored = in.ladder && in.cameraHeld;
  if (c.depthAnchored) {
    const double depthStep = c.depthFarLs * kDepthStepFraction;
    anchorZ = std::round(centerZ / depthStep) * depthStep;
    if (history->depthRung[i] == c.depthRung && history->depthAnchorStepLs[i] == depthStep &&
        std::abs(centerZ - history->depthAnchorLs[i]) <= depthStep) {
      anchorZ = history->depthAnchorLs[i];
    }
    c.depthAnchorMoved =
        history->depthAnchorLs[i] != anchorZ || history->depthAnchorStepLs[i] != depthStep;
    history->depthAnchorLs[i] = anchorZ;
    history->depthAnchorStepLs[i] = depthStep;
    c.depthFarLs += depthStep;
  } else if (history != nullptr) {
    history->depthAnchorStepLs[i] = 0.0;
  }
  return anchorZ;
}

// Snaps the centre on the light-space grid anchored at the world origin, in double. With the
// ladder, the box holds last frame's grid point while the texel size is the same and what it
// must cover (the sphere's disk, or the tight square) is still inside and the camera has not
// moved: a snap moves the map by whole texels, but the casters are rasterised anew at the
// shifted offset and every stored depth is re-rounded (a receiver on a depth tie, e.g. ground
// at a caster's foot, flips). Between events the box then does not move at all.
glm::dvec2 snappedBoxCenter(const FrameInputs& in, std::uint32_t i, const BoxNeed& need,
                            double half, double texel) noexcept {
  CascadeHistory* history = in.history;
  const glm::dvec3& centerLs = need.centerLs;
  glm::dvec2 gridLs(std::round(centerLs.x / texel) * texel, std::round(centerLs.y / texel) * texel);
  if (in.ladder && history != nullptr && history->boxTexelLs[i] == texel && in.cameraHeld) {
    const glm::dvec2 heldLs = history->boxCenterLs[i];
    if (std::abs(centerLs.x - heldLs.x) + need.coverHalf.x <= half &&
        std::abs(centerLs.y - heldLs.y) + need.coverHalf.y <= half) {
      gridLs = heldLs;
    }
  }
  if (history != nullptr) {
    history->boxCenterLs[i] = gridLs;
    history->boxTexelLs[i] = texel;
  }
  return gridLs;
}

// The stabilised box: needed size -> rung -> depth window -> snap. Returns the depth range's
// near side (before the extension toward the light).
double fitStableBox(const FrameInputs& in, std::uint32_t i, Cascade& c) {
  const BoxNeed need = boxNeed(in, i, c);
  c.neededHalfExtentM = need.half;
  const double half = boxHalfSide(in, i, need.half, c);
  const double texel = 2.0 * half / in.res;
  c.halfExtentLs = glm::dvec2(half);
  c.texelSizeLs = glm::dvec2(texel);
  const double anchorZ = depthWindowOrigin(in, i, need.centerLs.z, c);
  const glm::dvec2 gridLs = snappedBoxCenter(in, i, need, half, texel);
  const glm::dvec3 snappedLs(gridLs.x, gridLs.y, anchorZ);
  c.boxCenterWs = in.basis * snappedLs;
  // Make the box centre's depth exactly the anchored one.
  c.boxCenterWs += in.basis[2] * (anchorZ - glm::dot(in.basis[2], c.boxCenterWs));
  c.depthOriginLs = anchorZ;
  return -c.depthFarLs;
}

// Tight fit to the slice's light-space bounds; no snapping (the comparison mode). Returns the
// depth range's near side (before the extension toward the light).
double fitUnstableBox(const FrameInputs& in, Cascade& c) noexcept {
  const auto corners = sliceCornersCr(in.camera, c.splitNearM, c.splitFarM);
  glm::dvec3 lo(kInf), hi(-kInf);
  for (const glm::dvec3& p : corners) {
    const glm::dvec3 q = in.basisT * p;
    lo = glm::min(lo, q);
    hi = glm::max(hi, q);
  }
  const glm::dvec3 centerLs = 0.5 * (lo + hi);
  c.boxCenterWs = in.camera.positionWs + in.basis * centerLs;
  c.depthOriginLs = glm::dot(in.basis[2], c.boxCenterWs);
  c.halfExtentLs = glm::max(glm::dvec2(0.5 * (hi - lo)), glm::dvec2(1e-9));
  c.texelSizeLs = 2.0 * c.halfExtentLs / in.res;
  c.depthFarLs = std::max(0.5 * (hi.z - lo.z), 1e-9);
  c.neededHalfExtentM = std::max(c.halfExtentLs.x, c.halfExtentLs.y);
  return -c.depthFarLs;
}

// Extends the depth range toward the light over the scene's casters, in steps of a quarter of
// the box's depth, keeping last frame's extension while it still covers (hysteresis). Returns
// the depth range's near side.
double extendedDepthNear(const FrameInputs& in, const SceneDepth& scene, std::uint32_t i,
                         const Cascade& c, double depthNearLs) noexcept {
  if (scene.bounds == nullptr) return depthNearLs;
  const glm::dvec3 lightZ = in.basis[2];
  double sceneNearLs = kInf;
  for (const glm::dvec3& p : scene.corners) {
    sceneNearLs = std::min(sceneNearLs, c.depthAnchored ? glm::dot(lightZ, p) - c.depthOriginLs
                                                        : glm::dot(lightZ, p - c.boxCenterWs));
  }
  if (sceneNearLs < depthNearLs) {
    // (Steps of the depth range's own rung: the anchor's margin does not coarsen them.)
    const double step =
        0.5 * (c.depthAnchored ? c.depthFarLs / (1.0 + kDepthStepFraction) : c.depthFarLs);
    const double needed = -std::ceil(-sceneNearLs / step) * step;
    depthNearLs = needed;
    if (in.history != nullptr) {
      const double previous = in.history->depthNearLs[i];
      if (previous <= sceneNearLs && previous >= needed - 2.0 * step) depthNearLs = previous;
    }
  }
  return depthNearLs;
}

// One cascade: its slice's sphere, the box (stable or tight), the depth range, whether it has
// receivers, and its matrix.
void fitCascade(const FrameInputs& in, const SceneDepth& scene, const CascadeFrame& frame,
                std::uint32_t i, int splitFarRung, Cascade& c) {
  const Camera& camera = in.camera;
  c.splitNearM = frame.splitsM[i];
  c.splitFarM = frame.splitsM[i + 1];
  c.splitFarRung = splitFarRung;

  const SliceSphere sphere =
      minimalSliceSphere(camera.fovYRad, camera.aspect, c.splitNearM, c.splitFarM);
  c.sphereRadiusM = quantizeLengthUp(sphere.radiusM);
  c.sphereCenterWs = camera.positionWs + frame.cameraForwardWs * sphere.centerDepthM;

  double depthNearLs =
      in.settings.diagnostics.stabilize ? fitStableBox(in, i, c) : fitUnstableBox(in, c);
  depthNearLs = extendedDepthNear(in, scene, i, c, depthNearLs);
  if (in.history != nullptr) in.history->depthNearLs[i] = depthNearLs;
  c.depthNearLs = depthNearLs;

  // Empty: no receiver of the scene lies in this slice.
  c.empty = !scene.ahead;
  if (scene.bounds != nullptr && !c.empty) {
    c.empty = !(c.splitFarM > scene.minM && c.splitNearM < scene.maxM) ||
              !sphereTouchesAabb(c.sphereCenterWs, c.sphereRadiusM, *scene.bounds);
  }
  c.viewProjCr = cameraRelativeViewProj(in.basis, camera.positionWs, c);
}

// A stabilised box snaps to the world-anchored texel grid in double: its centre, in texels
// from the origin, must leave bits below a texel (kMaxGridTexels), or snapping stops being exact
// and the map shimmers. Within the domain (types.hpp) only texels far smaller than usual reach
// this; the refusal names the camera's distance and the smallest texel it allows.
std::optional<ValidationError> gridPrecision(const CascadeFrame& frame, const Camera& camera) {
  const glm::dmat3 basisT = glm::transpose(frame.lightBasisWs);
  for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
    const Cascade& c = frame.cascades[i];
    if (c.empty) continue;
    const glm::dvec3 centerLs = basisT * c.boxCenterWs;
    const double reach = std::max(std::abs(centerLs.x), std::abs(centerLs.y));
    const double texel = c.texelSizeM();
    if (!(reach <= texel * kMaxGridTexels)) {
      const double distance = glm::length(camera.positionWs);
      char allowed[256];
      std::snprintf(allowed, sizeof allowed,
                    "a position within %.3g m of the origin for cascade %u's texels of %.3g m "
                    "(2^44 texels: snapping stays exact); or larger texels (a longer shadow "
                    "distance, a lower resolution, a wider field of view)",
                    texel * kMaxGridTexels, i, texel);
      return ValidationError{"camera.positionWs (distance from the origin)", distance, allowed};
    }
  }
  return std::nullopt;
}

}  // namespace

Result<CascadeFrame> computeCascades(const ShadowSettings& settings, const Camera& camera,
                                     const DirectionalLight& light, const AabbWs* sceneBounds,
                                     CascadeHistory* history, const ReceiverDepthRange* receivers) {
  if (auto e = validate(settings, camera, light)) return *e;
  if (receivers != nullptr) {
    if (auto e = validate(*receivers)) return *e;
  }
  if (sceneBounds != nullptr) {
    if (auto e = validate(*sceneBounds, "sceneBounds")) return *e;
  }

  // Restored when the frame is refused after the history was advanced (gridPrecision).
  const CascadeHistory before = history != nullptr ? *history : CascadeHistory{};
  CascadeFrame frame;
  const std::uint32_t count = settings.cascadeCount;
  frame.cascadeCount = count;
  frame.resolution = settings.resolution;
  frame.blendBand = settings.blendBand;
  frame.normalOffsetTexels = settings.normalOffsetTexels;
  frame.lightDirectionWs =
      heldLightDirection(settings, glm::normalize(light.directionWs), history, frame.lightStepped);
  frame.lightBasisWs = lightBasisWs(frame.lightDirectionWs);
  frame.cameraPositionWs = camera.positionWs;
  const glm::dquat orientation = glm::normalize(camera.orientationWs);
  frame.cameraForwardWs = orientation * glm::dvec3(0.0, 0.0, -1.0);
  frame.cameraUpWs = orientation * glm::dvec3(0.0, 1.0, 0.0);
  frame.cameraTanHalfFovY = std::tan(0.5 * camera.fovYRad);
  frame.cameraAspect = camera.aspect;

  FrameInputs in{settings, camera, history};
  in.basis = frame.lightBasisWs;
  in.basisT = glm::transpose(in.basis);
  in.ladder = settings.diagnostics.stabilize && settings.diagnostics.sizeLadder;
  in.steps = settings.ladderStepsPerOctave;
  in.hysteresis = settings.ladderHysteresisSteps;
  in.res = static_cast<double>(settings.resolution);
  in.snapMargin = in.res / (in.res - 1.0);

  // The farthest shadows may reach is the host's setting, exact: where shadows end is not a
  // size (the last cascade's box is on the ladder), so dragging it moves no texel.
  const double maxFarM = std::min(settings.shadowDistanceM, camera.farM);
  in.cameraHeld = prepareHistory(history, maxFarM, count, camera.positionWs);

  const SceneDepth scene = sceneDepthInterval(sceneBounds, camera, frame.cameraForwardWs);
  double receiverFarM = kInf;
  const double splitNearM = receiverSplitNear(in, receivers, maxFarM, receiverFarM);
  frame.receiverDriven = receivers != nullptr;
  // Splits end at the scene's (or the visible receivers') far end, in quantised steps; never
  // closer than 2 x their near end. Stabilised, the scene's end is its farthest corner's
  // distance, not its depth along the view: turning the camera in place then moves no split
  // and re-sizes no box (the depth along the view would step the last cascade's texel).
  const double minFarM =
      std::min(maxFarM, (splitNearM > camera.nearM ? kMinSpanRatio : 2.0) * splitNearM);
  const double sceneFarM = settings.diagnostics.stabilize ? scene.reachM : scene.maxM;
  const double neededFarM =
      std::min(scene.ahead ? std::min(maxFarM, sceneFarM) : maxFarM, receiverFarM);
  frame.shadowFarM = quantizedShadowFar(neededFarM, maxFarM, minFarM,
                                        history != nullptr ? history->shadowFarM : 0.0);
  if (history != nullptr) history->shadowFarM = frame.shadowFarM;
  frame.fadeEndM = settings.shadowDistanceM;
  frame.fadeLengthM = settings.shadowDistanceM * settings.fadeFraction;
  const std::array<int, kMaxCascades + 1> splitRungs =
      splitDistances(in, receivers, splitNearM, frame);

  // Receiver-driven boxes: the visible receivers' light-space bounds, when taken with this
  // frame's splits and light basis.
  if (receivers != nullptr && settings.diagnostics.stabilize &&
      receiverBoundsApply(receivers->lightBounds, count, in.basis)) {
    in.receiverBounds = &receivers->lightBounds;
  }
  for (std::uint32_t i = 0; i < count; ++i) {
    fitCascade(in, scene, frame, i, i + 1 < count ? splitRungs[i + 1] : kNoRung, frame.cascades[i]);
  }
  if (settings.diagnostics.stabilize) {
    if (auto e = gridPrecision(frame, camera)) {
      if (history != nullptr) *history = before;
      return *e;
    }
  }
  return frame;
}

// p_Ls = B^T (p_Cr + camera - boxCenter); the translation is formed in double from two nearby
// points, so it is exact far from the origin.
glm::mat4 cameraRelativeViewProj(const glm::dmat3& basis, const glm::dvec3& cameraWs,
                                 const Cascade& c) noexcept {
  glm::dvec3 t = glm::transpose(basis) * (cameraWs - c.boxCenterWs);
  // The depth origin from the box's anchored depth, independent of its x, y snap.
  if (c.depthAnchored) t.z = glm::dot(basis[2], cameraWs) - c.depthOriginLs;
  const double dz = c.depthFarLs - c.depthNearLs;
  const glm::dvec3 scale(1.0 / c.halfExtentLs.x, 1.0 / c.halfExtentLs.y, 1.0 / dz);
  const glm::dvec3 offset(t.x * scale.x, t.y * scale.y, (t.z - c.depthNearLs) * scale.z);
  glm::mat4 m(0.0f);
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) {
      m[col][row] = static_cast<float>(basis[row][col] * scale[row]);
    }
    m[3][row] = static_cast<float>(offset[row]);
  }
  m[3][3] = 1.0f;
  return m;
}

glm::dvec3 shadowTexelCoord(const Cascade& cascade, const CascadeFrame& frame,
                            const glm::dvec3& posWs) noexcept {
  const glm::dvec3 p = toLightSpace(frame.lightBasisWs, cascade.boxCenterWs, posWs);
  const double res = static_cast<double>(frame.resolution);
  return {(p.x / cascade.halfExtentLs.x * 0.5 + 0.5) * res,
          (p.y / cascade.halfExtentLs.y * 0.5 + 0.5) * res,
          (p.z - cascade.depthNearLs) / (cascade.depthFarLs - cascade.depthNearLs)};
}

}  // namespace csm
