// Per-frame cascade setup: splits, bounding spheres, stabilised light matrices, depth ranges.
#pragma once

#include <array>
#include <climits>
#include <cstdint>

#include "csm/splits.hpp"
#include "csm/types.hpp"

namespace csm {

/// One cascade of one frame. "Ls" quantities are in light space about `boxCenterWs`
/// (x = right, y = up, z = direction of travel of the light, metres).
struct Cascade {
  /// View-depth range this cascade covers (distance along the camera's forward axis).
  double splitNearM = 0.0;
  double splitFarM = 0.0;
  /// Bounding sphere of the slice (stabilised mode: minimal sphere, radius quantised).
  glm::dvec3 sphereCenterWs{0.0};
  double sphereRadiusM = 0.0;
  /// Centre of the orthographic light box; in stabilised mode snapped to whole texels of a
  /// world-anchored grid (its light-space x and y are integer multiples of texelSizeLs).
  glm::dvec3 boxCenterWs{0.0};
  /// Half side of the box in light-space x and y (equal when stabilised).
  glm::dvec2 halfExtentLs{0.0};
  /// World size of one shadow texel along light-space x and y (= 2 * halfExtent / resolution).
  glm::dvec2 texelSizeLs{0.0};
  /// Light-space depth range: near side (toward the light, negative, extended to the scene's
  /// casters) and far side (the sphere plus the depth anchor's margin, stabilised mode). Depth 0
  /// maps to depthNearLs, 1 to depthFarLs.
  double depthNearLs = 0.0;
  double depthFarLs = 0.0;
  /// Light-space z of boxCenterWs about the world origin (the depth window's origin). Stabilised:
  /// a world-anchored grid point that holds between events, so the depth row of viewProjCr is
  /// bit-identical while the camera holds its position (it is formed from this value, not from
  /// boxCenterWs, whose x and y snap).
  double depthOriginLs = 0.0;
  /// Camera-relative world position (posWs - cameraPositionWs, as float) -> shadow clip space:
  /// x, y in [-1, 1] across the box (uv = xy * 0.5 + 0.5), z in [0, 1].
  glm::mat4 viewProjCr{1.0f};
  /// True when no receiver of the scene lies in this cascade: neither rendered nor sampled.
  bool empty = false;

  // ---- The size ladder (set in stabilised mode with settings.diagnostics.sizeLadder; else
  // kNoRung) ----
  /// Rung of the box half side (halfExtentLs = ladderValue(sizeRung)), of the depth range's far
  /// side (depthFarLs = ladderValue(depthRung), x 9/8 with depthAnchored: the anchor's margin) and
  /// of this cascade's far split (kNoRung for the last cascade, which ends at the shadow far
  /// distance).
  int sizeRung = INT_MIN;
  int depthRung = INT_MIN;
  int splitFarRung = INT_MIN;
  /// The box this frame was sized by the slice's light-space extent (BoxFit::kTight won).
  bool tightFit = false;
  /// The box this frame was sized by the visible receivers' light-space bounds
  /// (ReceiverDepthRange::lightBounds applied and was smaller than the sphere's or tight box).
  bool receiverFit = false;
  /// Half side the box needed this frame before the ladder rounded it up (sphere or tight
  /// extent plus the half-texel snap margin); halfExtentLs.x / neededHalfExtentM is what the
  /// ladder and its hysteresis cost in length (its square in area).
  double neededHalfExtentM = 0.0;
  /// The texel size changed this frame (a rung event of the box size) against the history.
  bool sizeRungChanged = false;
  /// The depth window's world-anchored origin (the box centre's light-space z, stabilised mode)
  /// moved this frame against the history: the sphere left the window (or the depth rung
  /// changed). Between such moves and rung events the depth mapping is bit-identical.
  bool depthAnchorMoved = false;
  /// The depth window is held on its world-anchored grid this frame (ladder on, camera holding
  /// its position): depthFarLs carries the anchor's margin and viewProjCr's depth row is formed
  /// from depthOriginLs. Otherwise the window is centred on the sphere, as without the ladder.
  bool depthAnchored = false;

  /// Largest texel side in metres (both sides are equal when stabilised).
  [[nodiscard]] double texelSizeM() const noexcept {
    return glm::max(texelSizeLs.x, texelSizeLs.y);
  }
};

/// Everything the renderer and the lighting shader need for one view in one frame.
struct CascadeFrame {
  std::uint32_t cascadeCount = 0;
  std::uint32_t resolution = 0;
  std::array<Cascade, kMaxCascades> cascades{};
  /// The split distances actually used (count + 1 of them).
  SplitArray splitsM{};
  /// Where the splits end: shadow distance clamped to camera far and scene extent, quantised.
  double shadowFarM = 0.0;
  /// The fade to lit at the end of the shadows (view depth, m): it ends at fadeEndM, the host's
  /// shadow distance (ShadowSettings::shadowDistanceM; where shadowFarM ends earlier, at the
  /// scene's or the visible receivers' far end, nothing lies beyond it to show a cut), and is
  /// fadeLengthM = fadeEndM x ShadowSettings::fadeFraction long; fadeLengthM = 0: no fade (a
  /// hard cut). shadowFade() gives the fade's weight at a depth.
  double fadeEndM = 0.0;
  double fadeLengthM = 0.0;
  /// Light basis (columns right, up, forward) and normalised light direction.
  glm::dmat3 lightBasisWs{1.0};
  glm::dvec3 lightDirectionWs{0.0, -1.0, 0.0};
  /// The camera this frame was computed for (the origin of camera-relative space).
  glm::dvec3 cameraPositionWs{0.0};
  glm::dvec3 cameraForwardWs{0.0, 0.0, -1.0};
  /// What the recording and the shader take from the settings the frame was computed with (the
  /// renderer refuses a frame whose values differ from those given to its update()).
  double blendBand = 0.0;
  float normalOffsetTexels = 0.0f;
  /// The splits were fitted to a receiver depth range (computeCascades got one).
  bool receiverDriven = false;
  /// The interior splits were placed from the receivers' depth histogram
  /// (ReceiverSplitScheme::kHistogram with a usable histogram; histogramSplits()).
  bool histogramDriven = false;
  /// The light direction used this frame was advanced (settings.lightStepDeg > 0 with a history).
  bool lightStepped = false;
  /// The camera's frustum about cameraPositionWs and cameraForwardWs: its up axis, the tangent
  /// of half its vertical field of view and its aspect (computeCascades fills them in; 0 in a
  /// frame built by hand: not known). Every visible receiver lies inside it, so the texels a
  /// cascade can be sampled at are known in the same frame (csm::markFrustumTiles).
  glm::dvec3 cameraUpWs{0.0, 1.0, 0.0};
  double cameraTanHalfFovY = 0.0;
  double cameraAspect = 0.0;
};

namespace detail {
template <std::size_t N>
constexpr std::array<int, N> noRungs() noexcept {
  std::array<int, N> a{};
  a.fill(INT_MIN);
  return a;
}
}  // namespace detail

/// What carries over between frames so that sizes change only in quantised steps with
/// hysteresis (shadow far distance, depth extension toward the light). Keep one per view;
/// a default-constructed history is a valid start.
struct CascadeHistory {
  double shadowFarM = 0.0;
  double shadowFarMaxM = 0.0;
  std::array<double, kMaxCascades> depthNearLs{};
  std::uint32_t cascadeCount = 0;

  // The ladder's state (settings.diagnostics.sizeLadder): last frame's rungs, kNoRung before the
  // first.
  std::array<int, kMaxCascades> sizeRung = detail::noRungs<kMaxCascades>();
  std::array<int, kMaxCascades> depthRung = detail::noRungs<kMaxCascades>();
  std::array<int, kMaxCascades + 1> splitRung = detail::noRungs<kMaxCascades + 1>();
  /// The depth window's anchor (light-space z about the world origin of each box centre) and its
  /// grid step; step 0 before the first frame.
  std::array<double, kMaxCascades> depthAnchorLs{};
  std::array<double, kMaxCascades> depthAnchorStepLs{};
  /// Each box centre's light-space x, y (a point of the world-anchored texel grid) and the texel
  /// size it was snapped with; texel 0 before the first frame. The box holds it while the size
  /// is the same, the camera holds its position and the sphere (or tight square) stays inside.
  std::array<glm::dvec2, kMaxCascades> boxCenterLs{};
  std::array<double, kMaxCascades> boxTexelLs{};
  /// Last frame's camera position (the box holds its x, y only while the camera does).
  glm::dvec3 cameraPositionWs{0.0};
  /// Rung of the receiver-driven near end of the splits (kNoRung without a receiver range).
  int receiverNearRung = INT_MIN;
  /// Rung events counted since the history started (never reset): changes of each cascade's
  /// box size (texel size) and of each interior split (splitRungEvents[i] counts split i + 1).
  std::array<std::uint32_t, kMaxCascades> sizeRungEvents{};
  std::array<std::uint32_t, kMaxCascades> splitRungEvents{};
  /// The light direction used for shadows (settings.lightStepDeg > 0); zero before the first.
  glm::dvec3 heldLightDirectionWs{0.0};
  std::uint32_t lightStepEvents = 0;
  /// Frames computed through this history.
  std::uint64_t frames = 0;
};

/// Computes the cascades of one frame. Validates every input first and returns the first
/// invalid field instead of computing. `sceneBounds` (optional) bounds every receiver and
/// caster: splits end at its farthest point, cascades that contain none of it are marked empty,
/// and depth ranges extend toward the light to cover it. `history` (optional, updated in place)
/// makes size changes quantised and hysteretic across frames. `receivers` (optional): the view
/// depths of the visible receivers; the splits then span only that range (widened by
/// settings.receiverDepthMargin, its near end on the ladder with hysteresis), as in
/// sample-distribution shadow maps; pass nothing when no range is known (first frames, after a
/// camera cut) and the splits span the full range. Allocates nothing.
[[nodiscard]] Result<CascadeFrame> computeCascades(const ShadowSettings& settings,
                                                   const Camera& camera,
                                                   const DirectionalLight& light,
                                                   const AabbWs* sceneBounds = nullptr,
                                                   CascadeHistory* history = nullptr,
                                                   const ReceiverDepthRange* receivers = nullptr);

/// Camera-relative world position -> the cascade's shadow clip space (Cascade::viewProjCr) for
/// a camera at `cameraWs`, formed in double from the cascade's box, depth range and (when
/// anchored) depth origin. computeCascades fills viewProjCr with it; a renderer that moves a
/// cascade's window (the cache) recomputes it with the same function.
[[nodiscard]] glm::mat4 cameraRelativeViewProj(const glm::dmat3& basisWs,
                                               const glm::dvec3& cameraWs,
                                               const Cascade& cascade) noexcept;

/// Shadow-map coordinates of a world point in one cascade, in double precision:
/// x, y in texels (0 .. resolution across the box), z the depth in [0, 1].
[[nodiscard]] glm::dvec3 shadowTexelCoord(const Cascade& cascade, const CascadeFrame& frame,
                                          const glm::dvec3& posWs) noexcept;

}  // namespace csm
