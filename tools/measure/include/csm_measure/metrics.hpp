// The numbers: frame-to-frame shimmer at fixed receivers, and accuracy of a rendered frame
// against a ray-traced truth. Plus the report helpers (JSON values, gnuplot PNGs).
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "csm_measure/harness.hpp"
#include "csm_measure/raytracer.hpp"
#include "csm_measure/scene.hpp"

namespace csm_measure {

/// A change of a shadow factor that 8-bit output can show.
inline constexpr double kVisibleStep = 1.0 / 255.0;

/// |s(t) - s(t-1)| over a set of (point, frame) pairs.
struct ShimmerStats {
  uint64_t pairs = 0;
  uint64_t visible = 0;  ///< pairs that changed by more than kVisibleStep
  double sum = 0.0;
  double max = 0.0;
  void add(double delta) noexcept;
  void merge(const ShimmerStats& other) noexcept;
  [[nodiscard]] double mean() const noexcept { return pairs ? sum / double(pairs) : 0.0; }
  [[nodiscard]] double visibleFraction() const noexcept {
    return pairs ? double(visible) / double(pairs) : 0.0;
  }
  [[nodiscard]] nlohmann::json toJson() const;
};

/// Shimmer of one frame (or of a run), by what the point's cascade selection did.
struct ShimmerClasses {
  /// Same cascade in both frames and outside every blend band: only texel crawl can move it.
  ShimmerStats stayed;
  /// Same cascade, but inside the blend band toward the next one in either frame (the blend
  /// weight follows the view depth, so the value moves smoothly with the camera).
  ShimmerStats band;
  /// Another cascade (or none) than in the previous frame.
  ShimmerStats crossed;
  void merge(const ShimmerClasses& other) noexcept;
  [[nodiscard]] nlohmann::json toJson() const;
};

/// A camera motion: the camera of frame f.
using CameraPath = std::function<csm::Camera(int frame)>;

/// The shimmer of a run over `frames` frames.
struct ShimmerRun {
  std::vector<ShimmerClasses> perFrame;  ///< frame f (from 1) against frame f - 1
  ShimmerClasses total;
  uint64_t nonFinite = 0;      ///< NaN / inf in shader outputs or cascade matrices
  uint64_t pointsTracked = 0;  ///< receivers inside the view in the first frame
  /// Stayed points that changed visibly: (frame, receiver index, |ds|, depth gap in m, the
  /// factor in the two frames, the cascade), for diagnosis (at most 100 kept).
  struct Change {
    int frame;
    size_t receiver;
    double delta;
    double depthGapM;
    float before = 0.0f;
    float after = 0.0f;
    int cascade = -1;
  };
  std::vector<Change> visibleChanges;
  [[nodiscard]] nlohmann::json toJson(bool perFrameSeries) const;
};

/// Renders `frames` frames along `path` (cascade history carried over) and compares csm.glsl's
/// shadow factor at each receiver with the previous frame's. Pairs count only where the point
/// lies inside the view frustum in both frames. The probe hands csmShadow each receiver's screen
/// pixel in that frame (at 720 pixels high), as a lighting shader would.
ShimmerRun measureShimmer(Harness& harness, std::span<const Receiver> receivers,
                          const csm::DirectionalLight& light, const CameraPath& path, int frames,
                          csm::PcfKernel kernel, bool blend = true);

/// Misclassification and error against the ray-traced truth, per cascade.
struct AccuracyBucket {
  uint64_t pixels = 0;
  uint64_t misclassified = 0;  ///< |s - v| > 0.5
  uint64_t shadowedTruth = 0;  ///< pixels the ray tracer puts in shadow (v = 0)
  double absErrorSum = 0.0;
  [[nodiscard]] double rate() const noexcept {
    return pixels ? double(misclassified) / double(pixels) : 0.0;
  }
  [[nodiscard]] double meanAbsError() const noexcept {
    return pixels ? absErrorSum / double(pixels) : 0.0;
  }
  void add(double s, double v) noexcept;
  [[nodiscard]] nlohmann::json toJson() const;
};

/// Texel-to-pixel ratio histogram: bin k counts log2(ratio) in [kLo + k, kLo + k + 1).
struct RatioHistogram {
  static constexpr int kLo = -4;
  static constexpr int kBins = 14;  ///< [-4, 10); values outside go to the end bins
  std::array<uint64_t, kBins> counts{};
  void add(double ratio) noexcept;
  [[nodiscard]] nlohmann::json toJson() const;
};

struct AccuracyStats {
  AccuracyBucket overall;  ///< every receiver pixel inside the shadow range (some cascade)
  std::array<AccuracyBucket, csm::kMaxCascades> perCascade{};
  AccuracyBucket outside;  ///< receiver pixels beyond every cascade (lit by design)
  RatioHistogram texelToPixel;
  uint64_t backFacing = 0;  ///< pixels facing away from the light, not counted
  uint64_t nonFinite = 0;   ///< NaN / inf among the pass's outputs
  void merge(const AccuracyStats& other) noexcept;
  [[nodiscard]] nlohmann::json toJson(uint32_t cascadeCount) const;
};

/// The ray-traced visibility `visibility` of pixel `p` as the module means to show it: toward
/// the shadow distance the frame fades to lit by design (ShadowSettings::fadeFraction,
/// csm::shadowFade), so there the truth is faded alike: v + fade x (1 - v).
double fadedTruth(double visibility, const PixelSample& p, const csm::CascadeFrame& frame) noexcept;

/// Runs `work(begin, end)` over [0, count) in one contiguous chunk per hardware thread (at most
/// `maxThreads`) and waits for all of them. For the ray-traced truths: RayTracer is
/// thread-compatible, and each chunk writes only its own outputs.
void parallelChunks(size_t count, unsigned maxThreads,
                    const std::function<void(size_t, size_t)>& work);

/// Compares each receiver pixel's shadow factor s with the visibility v of a shadow ray toward
/// the light (Embree, full-detail triangles). Pixels with dot(n, -lightDir) <= 0 are unlit by
/// shading whatever the shadow says and are left out.
AccuracyStats measureAccuracy(std::span<const PixelSample> pixels, const csm::CascadeFrame& frame,
                              const RayTracer& tracer, const csm::DirectionalLight& light);

/// Why the misclassified pixels of a frame are wrong: every pixel that measureAccuracy counts in
/// `overall` with |s - v| > 0.5, put in the first of these classes that fits it.
struct MissCauses {
  /// The first occluder's chord along the light below which it counts as thin (m): fence rails
  /// (6 x 10 cm), cables (3 cm), a pole's cross arm; thinner than the texels of distant cascades,
  /// they can fall between texel centres.
  static constexpr double kThinChordM = 0.25;
  /// Occluders within this distance along the light (m) are contact shadows, which the bias
  /// (a fraction of a texel to a few texels) can lose.
  static constexpr double kContactM = 2.0;
  /// The camera ray through the pixel's position meets a face whose geometric normal faces away
  /// from the light while the pixel's interpolated normal faces it: faceted terrain at the
  /// terminator, or a corner where the pixel centre's ray meets another face than the raster's.
  /// The truth ray starts outside such a surface; the shadow map sees the surface itself.
  uint64_t facingAway = 0;
  /// Truth lit, shadow map shadowed.
  uint64_t falseShadow = 0;
  /// Truth shadowed, map lit, by an occluder whose chord along the light is < kThinChordM.
  uint64_t missedThin = 0;
  /// Truth shadowed, map lit, by a thicker occluder (or an open surface) within kContactM.
  uint64_t missedContact = 0;
  /// Truth shadowed, map lit, by an occluder further along the light.
  uint64_t missedFar = 0;
  /// (x, y) of every pixel counted, sorted: to compare two configurations pixel by pixel.
  std::vector<std::pair<uint32_t, uint32_t>> pixels;
  [[nodiscard]] uint64_t total() const noexcept {
    return facingAway + falseShadow + missedThin + missedContact + missedFar;
  }
  /// How many of these pixels are misclassified in `other` too.
  [[nodiscard]] uint64_t sharedWith(const MissCauses& other) const;
  [[nodiscard]] nlohmann::json toJson() const;
};

/// The causes of a frame's misclassified pixels (the same pixels, truth and filter as
/// measureAccuracy, whose overall.misclassified equals total()), found with more rays: the
/// camera ray from `cameraWs` through each pixel's position, the shadow ray's first occluder
/// and its exit face.
MissCauses classifyMisses(std::span<const PixelSample> pixels, const csm::CascadeFrame& frame,
                          const RayTracer& tracer, const csm::DirectionalLight& light,
                          const glm::dvec3& cameraWs);

/// Whether a frame's cascade data are all finite.
bool frameIsFinite(const csm::CascadeFrame& frame) noexcept;

/// Runs gnuplot on `script` (written next to `scriptPath`); false when gnuplot is missing or
/// fails (the message is printed).
bool runGnuplot(const std::string& scriptPath, const std::string& script);

/// Writes `value` as pretty JSON.
void writeJson(const std::string& path, const nlohmann::json& value);

}  // namespace csm_measure
