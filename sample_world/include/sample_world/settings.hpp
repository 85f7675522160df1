// Everything the fly-through lets a user change (the ImGui panel, --set key=value, --config
// FILE), with its validation: an invalid value is refused with a message that lists what is
// allowed, never clamped.
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "csm/gpu_layout.hpp"
#include "csm/presets.hpp"
#include "csm/types.hpp"
#include "sample_world/paths.hpp"
#include "sample_world/world.hpp"

namespace world {

/// How the split distances are chosen: lambda 0 (uniform), 1 (logarithmic) or the user's.
enum class SplitScheme : std::uint32_t { kPractical, kUniform, kLogarithmic };
/// Every split scheme (for menus: iterate this, name each with schemeKey()).
inline constexpr std::array<SplitScheme, 3> kAllSplitSchemes{
    SplitScheme::kPractical, SplitScheme::kUniform, SplitScheme::kLogarithmic};

struct AppSettings {
  /// The quality tier applied (--set preset=NAME, csm::presetConfig: cascade count, resolution
  /// and kernel), none by default. A preset is applied before every other setting of the same
  /// command line or config, so those go on top of it.
  std::optional<csm::Preset> preset;
  csm::ShadowSettings shadow{};
  SplitScheme scheme = SplitScheme::kPractical;
  /// true: D16_UNORM shadow maps, false: D32_SFLOAT.
  bool depth16 = false;
  /// Cached cascades (csm::vk::RendererOptions::cache): static casters' depth kept across
  /// frames, only what changed re-rendered; the world's dynamic casters drawn every frame. On by
  /// default (the fly-through's shadow pass is 8x cheaper on `fast` with it; every frame is
  /// exact). Needs stabilised cascades and the per-layer render mode.
  bool shadowCache = true;
  /// The cache's texel budget (csm::vk::RendererOptions::cacheBudgetTexels): at most this many
  /// static texels re-rendered per frame beyond cascade 0; 0 = no cap (every frame exact).
  std::uint64_t cacheBudgetTexels = 0;
  /// Thin casters (the clusters of cables, fence segments and poles, World's CasterCluster::thin)
  /// widened by thinWidenTexels on each side in the depth pass
  /// (csm::vk::RendererOptions::thinCasterWidenTexels). Needs geometry shaders (or conservative
  /// rasterisation) on the device; else drawn as is. A sixteenth of a texel, the module's
  /// default: the most that keeps every cable's shadow in the image within one pixel of the
  /// ray-traced truth on the cables (StabilityThinCasters.CableShadowsInTheImage..., where half a
  /// texel is up to 4.3 px darker and one texel, the old default, 7.4 px); it halves how much the
  /// unwidened shadow varies along a cable, but does not make it continuous where a texel is
  /// wider than a pixel (shadows/docs/thin_casters.md).
  bool thinCasters = true;
  float thinWidenTexels = 0.0625f;
  /// Sun direction: azimuth from +x toward +z, elevation above the horizon, degrees.
  double lightAzimuthDeg = 140.0;
  double lightElevationDeg = 32.0;
  /// The clock of the `day` and `cut` paths (day.lengthS, cut.everyS).
  PathClock clock{};
  float ambient = 0.3f;
  /// Caster LODs on: each cascade draws a cluster's coarsest LOD whose geometric error is at
  /// most lodMaxErrorTexels of its texels (csm::vk::RendererOptions::lodMaxErrorTexels), and at
  /// least LOD cascadeLod[c] (an explicit schedule; all 0 by default).
  bool casterLods = true;
  /// Receiver-driven splits: the splits follow the visible receivers' depth range, reduced on
  /// the GPU from the lit pass's depth buffer a few frames late (the view's receiver fit,
  /// csm::vk::RendererOptions::receiverFit and ShadowView::recordReceiverDepth).
  bool receiverSplits = false;
  /// With receiverSplits: the same reduction also bounds the visible receivers in light space
  /// per cascade (csm::ReceiverDepthRange::lightBounds), and each cascade's box covers only them
  /// (never more than without). On by measurement (README, "Tighter where the receivers are").
  bool receiverBounds = true;
  /// Measures receiver-marked tiles (csm::ReceiverTileMarks): each frame a reduction over the
  /// lit pass's depth buffer marks, per cascade, the shadow-map tiles (1/16 of a layer's side)
  /// that visible pixels sample with this frame's filter, bias and blend band; report.json gives
  /// the count per cascade ("tiles_marked", of csm::kTileGridSide^2, a few frames late) and the
  /// reduction's GPU time ("tile marks"). Nothing is skipped: it measures what rendering only
  /// those tiles would leave out. Off by default.
  bool tileMarks = false;
  std::array<std::uint32_t, csm::kMaxCascades> cascadeLod{};
  float lodMaxErrorTexels = 0.5f;
  csm::DebugMode debug = csm::DebugMode::kNone;
  /// The cascade-visualisation overlay and its parts.
  bool overlay = false;
  bool overlayTint = true;
  bool overlayChecker = true;
  bool overlayThumbnails = true;
  bool overlayMap = true;
  /// Depth pre-pass: the visible world drawn depth-only first, then the lit pass with depth test
  /// EQUAL and no depth writes, so the lit fragment shader (the shadow lookup) runs about once per
  /// pixel instead of once per rasterised fragment.
  bool depthPrepass = true;
  /// Deferred shading: the visible world drawn once into a G-buffer (albedo, normals, camera-
  /// relative position), then the shading and the shadow lookup once per pixel in a full-view
  /// pass (depthPrepass then does not apply). The same image as the forward lit pass within the
  /// G-buffer's rounding; on a CPU rasteriser the lookup no longer runs for the unseen pixels of
  /// the 4x4 blocks that pixel-sized distant triangles are shaded in. The default: the whole
  /// fly-through frame measured 0.83-1.01x the forward one (README, "Deferred shading").
  bool deferred = true;
  /// Back faces of closed meshes (every LOD watertight and outward, every placement keeping the
  /// winding) culled in the pre-pass and the lit pass; open meshes (terrain, fences) draw both.
  bool cullBackFaces = true;
  /// View (window size at start, or the headless image).
  std::uint32_t width = 1280;
  std::uint32_t height = 720;
  double fovDeg = 60.0;
  double farM = 6000.0;
  WorldDesc world{};
  /// Bits a texel of msm's moment image (csm::vk::RendererOptions::msmMomentBits): 128 (32-bit
  /// floats, the default) or 64 (quantised to 16 bits, half the memory, where the device stores
  /// RGBA16_UNORM).
  std::uint32_t msmMomentBits = 128;
  /// Receiver-marked tiles (csm::vk::RendererOptions::tiles), on top of the cache: the cascades
  /// the last one can stand in for draw only the tiles the visible pixels of a few frames ago
  /// sampled (the tileMarks reduction, which this turns on), and pixels whose tiles are not
  /// drawn yet fall back to a coarser cascade. Needs a depth-comparison kernel; without the cache
  /// (shadow.cache=false, or unstabilised) it does nothing. report.json gives "tiles_drawn" and
  /// "tiles_held" per cascade. Off by default.
  bool shadowTiles = false;
  /// With shadowTiles: the most static texels the partial cascades draw per frame
  /// (csm::vk::RendererOptions::tileBudgetTexels): a light step or a cut spreads over frames,
  /// the pixels of tiles not drawn yet fall back meanwhile. 0 = no cap (default); else at least
  /// one tile, (shadow.resolution / 16)^2. report.json gives "tiles_deferred" per cascade.
  std::uint64_t tileBudgetTexels = 0;

  AppSettings();
};

/// Sets `key` from its text form; returns the error (naming key, value and what is allowed).
/// Key "preset" applies a quality tier (csm::presetConfig) over the current settings.
[[nodiscard]] std::optional<std::string> setSetting(AppSettings& s, const std::string& key,
                                                    const std::string& value);
/// The preset whose choices (cascade count, resolution, kernel: csm::presetConfig) `s` holds now,
/// whether or not it was applied by name; nothing when none does ("custom" in the panel).
[[nodiscard]] std::optional<csm::Preset> matchingPreset(const AppSettings& s) noexcept;
/// Applies a JSON config file: an object whose members are setting keys (values as JSON
/// numbers, strings, booleans or, for lod.cascades, an array); "preset" first, wherever it is.
[[nodiscard]] std::optional<std::string> loadConfig(AppSettings& s, const std::string& path);
/// Applies the text of a JSON config (what loadConfig does after reading the file); `name`
/// starts every message ("--config FILE"). Bounded: size, nesting depth, duplicate keys.
[[nodiscard]] std::optional<std::string> applyConfigText(AppSettings& s, std::string_view text,
                                                         const std::string& name);
/// Limits of a config file.
inline constexpr std::size_t kMaxConfigBytes = 1u << 20;
inline constexpr int kMaxConfigDepth = 2;

/// The checks that involve more than one field (and csm::validate of the shadow settings).
[[nodiscard]] std::optional<std::string> validateSettings(const AppSettings& s);
/// Every setting as JSON (key -> value), the form report.json records.
[[nodiscard]] nlohmann::json settingsJson(const AppSettings& s);
/// "key: allowed values" lines for usage messages.
[[nodiscard]] std::string settingsHelp();

/// The light's direction of travel from azimuth and elevation.
[[nodiscard]] glm::dvec3 lightDirection(const AppSettings& s) noexcept;
/// The ShadowSettings with the split scheme applied to lambda.
[[nodiscard]] csm::ShadowSettings effectiveShadow(const AppSettings& s) noexcept;

const char* kernelKey(csm::PcfKernel k) noexcept;
const char* debugKey(csm::DebugMode m) noexcept;
const char* schemeKey(SplitScheme s) noexcept;

}  // namespace world
