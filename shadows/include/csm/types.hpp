// Inputs of the cascade math: settings, camera, light and scene bounds, with their validation.
// World space is right-handed, +Y up, metres; world positions are double precision.
#pragma once

#include <glm/ext/vector_int2_sized.hpp>
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include <array>
#include <cstdint>
#include <optional>

#include "csm/error.hpp"
#include "csm/shared_constants.h"

namespace csm {

inline constexpr std::uint32_t kMaxCascades = CSM_MAX_CASCADES;
inline constexpr std::uint32_t kMinResolution = 256;
inline constexpr std::uint32_t kMaxResolution = 16384;
/// Bins of a receiver view-depth histogram (ReceiverDepthHistogram, the GPU reduction's).
inline constexpr std::uint32_t kDepthHistogramBins = CSM_DEPTH_HISTOGRAM_BINS;

// ---- The domain where results are exact (tested up to these limits, refused beyond them) ----
/// Every world coordinate the module is given (camera position, scene bounds, caster bounds and
/// translations) lies in [-kMaxWorldCoordinateM, kMaxWorldCoordinateM]: a million kilometres,
/// a hundred times the 10^7 m the stability tests fly at. World positions are double (a
/// coordinate of 1e9 m resolves to 1.2e-7 m) and the matrices the GPU reads are camera-relative,
/// so containment and whole-texel snapping stay exact to here (measured exact to 1e12 m; from
/// 1e13 m the double-precision boxes no longer hold the view's corners).
inline constexpr double kMaxWorldCoordinateM = 1e9;
/// The camera's near plane is at least this far (metres): a micrometre.
inline constexpr double kMinNearM = 1e-6;
/// The camera's far plane is at most this many times its near plane (1e-3 m to 1e7 m).
inline constexpr double kMaxFarOverNear = 1e10;
/// A stabilised cascade's box centre, in texels from the world origin, is at most this many
/// (2^44): its snap to the world-anchored texel grid then keeps 8 bits below a texel in double.
/// computeCascades refuses a frame whose texels are too small for the camera's distance from the
/// origin (camera.positionWs), naming the cascade and the texel size; within the limits above
/// only unusual settings reach it (texels under 57 micrometres at 1e9 m, 0.6 micrometres at
/// 1e7 m).
inline constexpr double kMaxGridTexels = 17592186044416.0;

/// How a stabilised cascade's box is sized.
enum class BoxFit : std::uint8_t {
  /// Around the slice's minimal bounding sphere: independent of the camera's orientation.
  kSphere = 0,
  /// The smaller of the sphere's box and the slice's light-space extent (square): tighter when
  /// the light is near the view axis or the field of view is narrow; rotation changes the size,
  /// but only at rung events of the ladder.
  kTight = 1,
};

/// How receiver-driven splits (computeCascades given a ReceiverDepthRange) place the interior
/// split distances between the range's ends.
enum class ReceiverSplitScheme : std::uint8_t {
  /// The practical (lambda) scheme between the visible range's near and far ends.
  kRange = 0,
  /// Sample-distribution shadow maps' second half: from the range's histogram of receiver view
  /// depth, the splits (on the ladder's rungs) that minimise the receivers' mean texel size in
  /// pixels (texel / view depth), so cascades go where the receivers are and empty depth gaps get
  /// no resolution. Falls back to kRange when the range carries no usable histogram.
  kHistogram = 1,
};

/// PCF kernels of csm.glsl (values of CSM_KERNEL_* in csm/shared_constants.h); chosen by
/// ShadowSettings::kernel, which sets the lighting pipeline's specialization constant
/// CSM_SPEC_KERNEL (csm::lightingSpecConstants).
enum class PcfKernel : std::uint32_t {
  k1Tap = CSM_KERNEL_1TAP,
  kTent3 = CSM_KERNEL_TENT3,
  kTent5 = CSM_KERNEL_TENT5,
  kTent7 = CSM_KERNEL_TENT7,
  kPoisson16 = CSM_KERNEL_POISSON16,
  /// Percentage-closer soft shadows (penumbra from ShadowSettings::lightAngularDiameterDeg).
  kPcss = CSM_KERNEL_PCSS,
  /// Prefiltered (isPrefiltered()): variance shadow maps, two moments, Chebyshev's bound.
  kVsm = CSM_KERNEL_VSM,
  /// Prefiltered: exponential variance shadow maps, four exponential moments.
  kEvsm = CSM_KERNEL_EVSM,
  /// Prefiltered: moment shadow maps, four power moments (Peters and Klein 2015).
  kMsm = CSM_KERNEL_MSM,
};

/// Whether a filter reads the blurred, mip-mapped moments instead of comparing depths (vsm,
/// evsm, msm): the renderer then keeps a moment image beside the depth array.
[[nodiscard]] constexpr bool isPrefiltered(PcfKernel k) noexcept {
  return k == PcfKernel::kVsm || k == PcfKernel::kEvsm || k == PcfKernel::kMsm;
}

/// How a cached cascade's sampled layer is restored to the static depth
/// (ShadowDiagnostics::cacheRestore). Whatever the choice, a new window or a change over most of
/// the layer copies the whole layer, and every choice gives the same depth in every texel.
enum class CacheRestore : std::uint8_t {
  /// Copy the whole static layer whenever anything in the cascade changed (dynamic casters
  /// included): the simplest scheme.
  kWholeLayer,
  /// Copy only the changed rectangles (vkCmdCopyImage). On lavapipe its partial depth copies
  /// cost about as much as whole ones (shadows/docs/cache.md).
  kCopyRects,
  /// Clear the changed rectangles and draw the static casters over them again, scissored,
  /// in the dynamic casters' pass: no copy. Bit-identical (a texel is always rasterised with the
  /// same vertices, viewport and tile). Costs every triangle of every static caster that touches
  /// a rectangle: cheap in small scenes, many milliseconds where a small vehicle stands on a big
  /// terrain patch. Rectangles adding up to an eighth of the layer or more are copied instead.
  kRedraw,
  /// The default. Draw each changed rectangle, scissored, in the dynamic casters' pass with a
  /// fragment shader that reads the static layer texel by texel and writes that depth: a copy
  /// whose cost follows the texels restored, not the casters over them, with no transfer
  /// between the passes. Bit-identical on float depth formats (the value is written as read);
  /// on a UNORM depth format (D16), whose conversion from the shader's float Vulkan leaves to
  /// the implementation's rounding, it restores as kRedraw.
  kShaderCopy,
};

/// The switches that exist to measure the module against itself, in one group: each turns off
/// (or swaps out) something that keeps the shadows stable, exact or cheap. A host leaves them at
/// their defaults; the tests, the trade-off sweep and the fly-through's comparison keys change
/// them. The shipping choices (filter, cache, LODs, bias) are ShadowSettings' and
/// RendererOptions' other fields.
struct ShadowDiagnostics {
  /// Stabilised cascades (bounding sphere, whole-texel snapping). Off: tight fit, no snap
  /// (shimmers; the baseline the shimmer tests compare with). The cache needs it on.
  bool stabilize = true;
  /// The size ladder (ShadowSettings::ladderStepsPerOctave; stabilised mode only). Off: sizes
  /// follow their inputs continuously (the texel size changes on every frame such an input
  /// moves).
  bool sizeLadder = true;
  /// Cached cascades: how the sampled layer gets the static depth back where it changed (the
  /// rectangles re-rendered this frame and those dynamic casters covered last frame) before the
  /// dynamic casters are drawn. Every choice gives the same depth; only the cost differs.
  CacheRestore cacheRestore = CacheRestore::kShaderCopy;
  /// Where the renderer's cullMode is none: casters flagged CasterInstance::closed are drawn with
  /// their faces turned away from the light culled. Along any light ray the nearest surface of
  /// a closed caster faces the light, so every texel keeps its depth while about half of those
  /// triangles are not rasterised; up to float rounding: a back face's depth plane evaluated at
  /// a silhouette texel can round a few ulps nearer than the front face's (test
  /// ClosedCasters.CullingKeepsEveryTexelsDepth, per-layer, layered and cached). False draws
  /// them like every other caster.
  bool cullClosedCasters = true;
};

/// What a host sets once and changes rarely. Every field is checked by validate(); nothing is
/// clamped silently.
struct ShadowSettings {
  /// Number of cascades, [1, CSM_MAX_CASCADES].
  std::uint32_t cascadeCount = 4;
  /// Side of every cascade's shadow map in texels: a power of two in [256, 16384].
  std::uint32_t resolution = 2048;
  /// Practical split blend: 0 = uniform, 1 = logarithmic, [0, 1].
  double splitLambda = 0.75;
  /// Distance along the view direction that shadows reach, metres; > camera near, at most
  /// kMaxWorldCoordinateM.
  /// Clamped further (in quantised steps) to the camera's far plane and the scene's extent.
  double shadowDistanceM = 400.0;
  /// Width of the blend band at the far end of each cascade, as a fraction of that cascade's
  /// depth range, [0, 0.5]. 0 switches cascades with no blend.
  double blendBand = 0.1;
  /// Shadows fade out toward the shadow distance instead of stopping at a hard line: over its
  /// last fadeFraction (view depth shadowDistanceM x (1 - fadeFraction) to shadowDistanceM) the
  /// shadow factor rises smoothly (smoothstep) to lit. [0, 1]; 0 is the hard cut.
  double fadeFraction = 0.1;
  /// Constant depth bias, in units of the depth format's minimum resolvable difference, >= 0.
  float depthBiasConstant = 1.0f;
  /// Slope-scaled depth bias of the depth pass (depthBiasSlopeFactor), >= 0. 0 by default: the
  /// shader's normal offset already covers the receiver's slope over the kernel's reach, and a
  /// raster slope bias only pushes steep casters (walls under a high sun) away from their
  /// receivers, which lights the ground next to them (measured: README, "Bias").
  float depthBiasSlope = 0.0f;
  /// Normal-offset bias of the bilinear comparison tap, in texels: every tap of a filter compares
  /// with the receiver's plane at the tap (receiver-plane depth bias, csm.glsl), and each tap
  /// compares its 2x2 texels with one depth, so the shader moves the receiver along its normal by
  /// normalOffsetTexels x the cascade's texel size (m) x (|n_x| + |n_y|), the normal's parts along
  /// the map's texel axes. That puts it texel x (|n_x| + |n_y|) / |n_z| in front of its plane
  /// along the light: how far the plane's stored depth varies over one texel in x and one in y,
  /// at every orientation of the plane against the texel grid. So 1 is the least that has no acne
  /// on planes; the default adds a quarter (1.1 left a receiver in a depth tie that flickered in
  /// the extremes test; measured: shadows/docs/bias.md). [0, 16].
  float normalOffsetTexels = 1.25f;
  /// Constant depth floor of the shadow test in texels of the receiver's cascade (metres =
  /// depthFloorTexels x texel size), subtracted along the light in the shader on top of the
  /// depth format's own quantum (added automatically: one step of D16, 16 ulp of D32). It is the
  /// only bias left where the light meets a surface head-on (no slope, no normal offset). [0, 16].
  float depthFloorTexels = 0.25f;
  /// Casters whose bounds span fewer than this many texels of a cascade are not drawn into it
  /// (they cannot show there). 0 turns the test off. [0, 1e6].
  float minCasterTexels = 0.0f;
  /// Explicit split positions instead of splitLambda (as Filament's cascadeSplitPositions): the
  /// first cascadeCount - 1 entries place the inner splits between the camera's near plane and
  /// the shadow far distance, as fractions in (0, 1), strictly increasing:
  /// split_i = near + splitPositions[i - 1] * (far - near). All 0 (the default): splitLambda
  /// places them. Entries past cascadeCount - 1 are ignored.
  std::array<double, kMaxCascades - 1> splitPositions{};

  /// Whether splitPositions is in use (any of its first cascadeCount - 1 entries is non-zero).
  [[nodiscard]] bool explicitSplits() const noexcept {
    for (std::uint32_t i = 0; i + 1 < cascadeCount && i < kMaxCascades - 1; ++i) {
      if (splitPositions[i] != 0.0) return true;
    }
    return false;
  }

  // ---- The size ladder (stabilised mode only; ShadowDiagnostics::sizeLadder) ----
  /// Every length that sets a cascade's extent or texel size (box half side, depth range, the
  /// interior split distances) takes only values 2^(k / ladderStepsPerOctave) metres,
  /// with hysteresis kept in CascadeHistory, so a zoom, a resize, a near-plane or a lambda change
  /// changes a texel size only at rare rung events.
  /// Rungs per doubling, [1, 64]: 8 gives steps of 2^(1/8) = 9.05%.
  double ladderStepsPerOctave = 8.0;
  /// How far, in rungs, a length must move past a rung before the ladder leaves it, [0, 8].
  double ladderHysteresisSteps = 1.0;
  /// Box fit: the sphere's box, or the slice's own light-space extent where that is smaller
  /// (light near the view axis, narrow fields of view). Both on the ladder and snapped.
  BoxFit boxFit = BoxFit::kSphere;
  /// Light direction used for shadows advances in steps of this angle and holds in between
  /// (kept in CascadeHistory), so a moving sun changes the maps only at steps. 0 = follow the
  /// light exactly. Degrees, [0, 10].
  double lightStepDeg = 0.0;
  /// Receiver-driven splits (when computeCascades is given a ReceiverDepthRange): the range is
  /// widened by this fraction on each side for camera motion before the splits are fitted to it,
  /// [0, 1].
  double receiverDepthMargin = 0.15;
  /// How receiver-driven splits place the interior splits (kHistogram needs a histogram in the
  /// ReceiverDepthRange; without one it acts as kRange). kHistogram by measurement (README,
  /// "Tighter where the receivers are"): as accurate as kRange on a narrow zoom, and on a wide view
  /// whose receivers crowd the near end it keeps the near cascades tight and draws fewer triangles.
  ReceiverSplitScheme receiverSplitScheme = ReceiverSplitScheme::kHistogram;
  /// Receiver-driven box bounds (a ReceiverDepthRange carrying ReceiverLightBounds): each side of
  /// the receivers' light-space rectangle is pushed out by this fraction of the box half side
  /// the cascade would have without them (the sphere's or the tight square's), for new receivers
  /// that come into view before the next bounds arrive, [0, 1].
  double receiverBoundsMargin = 0.05;

  // ---- Soft shadows (the PCSS kernel) ----
  /// Angular diameter of the light (the sun: 0.53 degrees), in degrees, [0, 20]. Sets the
  /// penumbra of the PCSS kernel: width = 2 tan(diameter / 2) x blocker-to-receiver distance.
  double lightAngularDiameterDeg = 0.53;
  /// Widest penumbra the PCSS kernel draws, metres, [0, 100]: the diameter of its blocker search
  /// and the bound of its filter (a fixed number of taps spread wider finds thin blockers less
  /// surely and shows more noise). 0.5 m: a 0.53 degree sun 54 m above the receiver. 0 gives
  /// hard shadows.
  double maxPenumbraM = 0.5;

  // ---- The filter of the lighting shader ----
  // These set the lighting pipeline's specialization constants: build it with the view's
  // (csm::vk::ShadowView::lightingSpecialization, or csm::lightingSpecConstants), so that the
  // CPU and the shader cannot disagree; rebuild it when they change. The cascade blend follows
  // blendBand (0: the hard switch, no band to sample).
  /// The PCF kernel (CSM_SPEC_KERNEL), one of PcfKernel.
  PcfKernel kernel = PcfKernel::kTent3;
  /// PCSS only: gathers of its blocker search and comparison taps of its filter
  /// (CSM_SPEC_PCSS_TAPS), [1, CSM_PCSS_MAX_TAPS = 64].
  std::uint32_t pcssTaps = CSM_PCSS_DEFAULT_TAPS;
  /// Keep the PCF kernel the same size in metres in every cascade (that of cascade 0): tap
  /// spacing in cascade i becomes texel_0 / texel_i texels (CsmCascadeGpu::kernelScale). Off:
  /// the same size in texels.
  bool worldSpaceKernel = false;

  // ---- Prefiltered filters (kernel vsm, evsm or msm) ----
  /// Width of the moment blur in metres (its Gaussian's 2-sigma radius), the same in every
  /// cascade so that a shadow's softness does not jump at a split; capped at
  /// CSM_MOMENT_MAX_BLUR_TEXELS texels of a cascade, and below a texel the bilinear tap is the
  /// filter. [0, 10].
  double momentBlurM = 0.1;
  /// Light-bleeding reduction: lit fractions below it read 0 and the rest is rescaled to [0, 1]
  /// (vsm, evsm and msm alike). Cuts the bleeding of stacked occluders at the cost of narrower
  /// penumbrae. [0, 0.95].
  float momentBleedReduction = 0.2f;
  /// EVSM's exponents for depth warped to [-1, 1]: positive e^(c+ w), negative -e^(-c- w).
  /// (0, CSM_EVSM_MAX_EXPONENT = 42]: beyond it e^(2c) overflows a 32-bit float.
  float evsmPositiveExponent = 40.0f;
  float evsmNegativeExponent = 10.0f;
  /// MSM's moment bias: the filtered moments are mixed with those of a uniform depth
  /// distribution by this weight, so the reconstruction never divides by a vanishing variance
  /// (32-bit float moments). [1e-7, 0.01].
  float msmMomentBias = 3e-5f;

  /// Comparison-only switches (see ShadowDiagnostics): leave at their defaults to ship.
  ShadowDiagnostics diagnostics;
};

/// Receiver pixels counted per view-depth bin, log-spaced: bin i covers view depths
/// [nearM * r^i, nearM * r^(i + 1)) with r = (farM / nearM)^(1 / kDepthHistogramBins); depths
/// before nearM count in bin 0, from farM on in the last (depthHistogramBin()). nearM = 0: no
/// histogram. 0 < nearM < farM, finite, when present.
struct ReceiverDepthHistogram {
  double nearM = 0.0;
  double farM = 0.0;
  std::array<std::uint32_t, kDepthHistogramBins> counts{};

  [[nodiscard]] bool present() const noexcept { return nearM != 0.0; }
};

/// The light-space x, y bounds of the visible receivers per cascade, the second half of
/// sample-distribution shadow maps (partition bounds): from one frame, each receiver pixel binned
/// into a cascade by its view depth against that frame's splits, then the min and max of its
/// light-space x, y about the world origin (transpose(lightBasisWs) * posWs, in double).
/// computeCascades sizes each cascade's box to them (never larger than without them) only when
/// they were taken with this frame's cascade count and light basis, exactly, and the cascade's
/// view-depth interval then held this frame's (a split that moved outward, or any other
/// change, falls back); otherwise (and for a cascade with no receiver, minLs > maxLs) the box is
/// as without them, and also once the camera has turned or changed its field of view since; its
/// light-space motion since widens them.
/// cascadeCount = 0: no bounds.
struct ReceiverLightBounds {
  std::uint32_t cascadeCount = 0;
  std::array<double, kMaxCascades + 1> splitsM{};
  glm::dmat3 lightBasisWs{1.0};
  glm::dvec3 cameraPositionWs{0.0};
  /// The camera's orientation (camera to world) and field of view when they were taken.
  glm::dquat cameraOrientationWs{1.0, 0.0, 0.0, 0.0};
  double fovYRad = 0.0;
  double aspect = 0.0;
  std::array<glm::dvec2, kMaxCascades> minLs{};
  std::array<glm::dvec2, kMaxCascades> maxLs{};

  [[nodiscard]] bool present() const noexcept { return cascadeCount != 0; }
  /// Cascade i saw at least one receiver.
  [[nodiscard]] bool hasReceivers(std::uint32_t i) const noexcept {
    return minLs[i].x <= maxLs[i].x && minLs[i].y <= maxLs[i].y;
  }
};

inline constexpr std::uint32_t kTilesPerSide = CSM_TILES_PER_SIDE;
inline constexpr std::uint32_t kTileGridSide = CSM_TILE_GRID_SIDE;
inline constexpr std::uint32_t kTileWords = CSM_TILE_WORDS;
static_assert(kTileGridSide == kTilesPerSide + 1 &&
              kTileWords * 32 >= kTileGridSide * kTileGridSide);

/// The shadow-map tiles that the visible receivers of one frame sample, per cascade (receiver-
/// marked tiles, as virtual shadow maps mark pages from the depth buffer): tiles are
/// tileTexels = resolution / kTilesPerSide texels on the world-anchored texel grid of the cascade
/// (world texel index floor(light-space x / texel), tile index floor(texel index / tileTexels));
/// a cascade's grid holds kTileGridSide^2 of them from gridOrigin, which covers its box. The
/// receivers a cascade shades (the first non-empty one whose [splitsM[i], splitsM[i + 1]) holds
/// their view depth, as the lighting shader selects, and the next one too inside the blend band)
/// mark the tiles that the light-space rectangle of their x, y, widened by reachM[i], touches
/// (what the cascade's filter can read there, csm::receiverSampleReachTexels): per 16x16 block of
/// pixels on the GPU (DepthRangeReducer, with ReceiverBoundsInputs::tiles), per receiver or
/// rectangle on the CPU (csm::markReceiverTiles, markTileRect in csm/receiver_tiles.hpp). A
/// block that straddles a silhouette so marks the tiles between its receivers too.
/// cascadeCount = 0: no marks.
struct ReceiverTileMarks {
  std::uint32_t cascadeCount = 0;
  std::uint32_t nonEmptyMask = 0;
  std::uint32_t tileTexels = 0;
  std::array<double, kMaxCascades + 1> splitsM{};
  /// View depth where cascade i's blend band toward i + 1 starts (= splitsM[i + 1]: no band).
  std::array<double, kMaxCascades> blendStartM{};
  glm::dmat3 lightBasisWs{1.0};
  std::array<double, kMaxCascades> texelM{};
  std::array<double, kMaxCascades> reachM{};
  /// World tile index (x, y) of grid tile (0, 0).
  std::array<glm::i64vec2, kMaxCascades> gridOrigin{};
  /// Bit y * kTileGridSide + x of cascade i: grid tile (x, y) is marked.
  std::array<std::array<std::uint32_t, kTileWords>, kMaxCascades> bits{};
  /// The camera's position when the marks were taken (the receivers a slice holds move with it).
  glm::dvec3 cameraPositionWs{0.0};

  [[nodiscard]] bool present() const noexcept { return cascadeCount != 0; }
  [[nodiscard]] bool marked(std::uint32_t i, std::uint32_t x, std::uint32_t y) const noexcept {
    const std::uint32_t b = y * kTileGridSide + x;
    return (bits[i][b / 32] >> (b % 32)) & 1u;
  }
  void mark(std::uint32_t i, std::uint32_t x, std::uint32_t y) noexcept {
    const std::uint32_t b = y * kTileGridSide + x;
    bits[i][b / 32] |= 1u << (b % 32);
  }
  /// Tiles marked in cascade i.
  [[nodiscard]] std::uint32_t markedCount(std::uint32_t i) const noexcept;
};

/// The view-depth range [minM, maxM] of the receivers visible this frame (as a depth-buffer
/// reduction reports it, typically one or two frames late). 0 <= minM <= maxM, finite.
/// Optionally the histogram of the same receivers' view depths (ReceiverSplitScheme::kHistogram).
struct ReceiverDepthRange {
  double minM = 0.0;
  double maxM = 0.0;
  ReceiverDepthHistogram histogram{};
  /// Optionally the receivers' light-space bounds per cascade (the boxes' partition bounds).
  ReceiverLightBounds lightBounds{};
  /// Optionally the tiles the receivers sample per cascade (receiver-marked tiles).
  ReceiverTileMarks tiles{};
};

/// A perspective camera. Looks down its local -Z with +Y up (the GLM/Vulkan view convention).
struct Camera {
  glm::dvec3 positionWs{0.0};
  /// Rotation from camera space to world space (unit quaternion).
  glm::dquat orientationWs{1.0, 0.0, 0.0, 0.0};
  /// Vertical field of view in radians, (0, pi).
  double fovYRad = glm::radians(60.0);
  /// Width over height, (0, 1e4].
  double aspect = 16.0 / 9.0;
  /// Near and far plane distances: near >= kMinNearM (1e-6 m), near < far <= near x
  /// kMaxFarOverNear (1e10). The position's coordinates are within +-kMaxWorldCoordinateM.
  double nearM = 0.1;
  double farM = 5000.0;

  [[nodiscard]] glm::dvec3 forwardWs() const noexcept {
    return orientationWs * glm::dvec3(0, 0, -1);
  }
  [[nodiscard]] glm::dvec3 upWs() const noexcept { return orientationWs * glm::dvec3(0, 1, 0); }
  [[nodiscard]] glm::dvec3 rightWs() const noexcept { return orientationWs * glm::dvec3(1, 0, 0); }
};

/// A directional light. `directionWs` is the direction light travels (from the light toward the
/// scene): the sun overhead is (0, -1, 0). Any finite non-zero vector; normalised internally.
struct DirectionalLight {
  glm::dvec3 directionWs{0.0, -1.0, 0.0};
};

/// Axis-aligned box in world space. Used for the scene's extent (receivers and casters).
/// Coordinates within +-kMaxWorldCoordinateM, max >= min.
struct AabbWs {
  glm::dvec3 minWs{0.0};
  glm::dvec3 maxWs{0.0};
};

/// Each returns the first invalid field, or nothing when the input is valid.
[[nodiscard]] std::optional<ValidationError> validate(const ShadowSettings& settings);
[[nodiscard]] std::optional<ValidationError> validate(const Camera& camera);
[[nodiscard]] std::optional<ValidationError> validate(const DirectionalLight& light);
[[nodiscard]] std::optional<ValidationError> validate(const AabbWs& box, const char* field);
[[nodiscard]] std::optional<ValidationError> validate(const ReceiverDepthRange& range);
/// The checks that involve more than one struct (shadow distance > camera near).
[[nodiscard]] std::optional<ValidationError> validate(const ShadowSettings& settings,
                                                      const Camera& camera,
                                                      const DirectionalLight& light);

}  // namespace csm
