// One spelling per enum value, for code, CLI, JSON, reports and UI alike, and parsing by name.
// Pure (no Vulkan): the tables live in names.cpp, in the order of the CSM_* values, and every
// lookup goes through them (no index casts that depend on the enum's order).
//
// Kernels: "1tap", "tent3x3", "tent5x5", "tent7x7", "poisson16", "pcss", and the prefiltered
// "vsm", "evsm", "msm" (the README's names, without the space). parseKernel() also accepts "tent3",
// "tent5" and "tent7", the fly-through's spelling before the names were unified, so that existing
// configs and command lines still work. Debug modes: "none", "normal", "shadow", "lightcoords",
// "depth", "depthdiff", "cascade", "tiles". Shadow-map depth formats: "d32" (D32_SFLOAT), "d16"
// (D16_UNORM). parseDepthFormat() also accepts "D32" and "D16", the CSV reports' spelling before
// the names were unified. Presets: "low", "medium", "high", "ultra".
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "csm/error.hpp"
#include "csm/gpu_layout.hpp"
#include "csm/presets.hpp"

namespace csm {

/// Every percentage-closer kernel (they compare depths), in the order of CSM_KERNEL_*.
inline constexpr std::array<PcfKernel, CSM_KERNEL_COUNT> kAllKernels{
    PcfKernel::k1Tap,  PcfKernel::kTent3,     PcfKernel::kTent5,
    PcfKernel::kTent7, PcfKernel::kPoisson16, PcfKernel::kPcss};

/// The prefiltered filters (isPrefiltered()), in the order of CSM_KERNEL_*.
inline constexpr std::array<PcfKernel, CSM_FILTER_COUNT - CSM_KERNEL_COUNT> kPrefilteredKernels{
    PcfKernel::kVsm, PcfKernel::kEvsm, PcfKernel::kMsm};

/// Every filter, percentage-closer then prefiltered: iterate this for menus and parsing.
inline constexpr std::array<PcfKernel, CSM_FILTER_COUNT> kAllFilters{
    PcfKernel::k1Tap,  PcfKernel::kTent3,     PcfKernel::kTent5,
    PcfKernel::kTent7, PcfKernel::kPoisson16, PcfKernel::kPcss,
    PcfKernel::kVsm,   PcfKernel::kEvsm,      PcfKernel::kMsm};

/// Every debug output, in the order of CSM_DEBUG_*.
inline constexpr std::array<DebugMode, CSM_DEBUG_COUNT> kAllDebugModes{
    DebugMode::kNone,        DebugMode::kNormal,       DebugMode::kShadowFactor,
    DebugMode::kLightCoords, DebugMode::kSampledDepth, DebugMode::kDepthDifference,
    DebugMode::kCascadeTint, DebugMode::kTileFallback};

// kernelName(PcfKernel) (the one spelling of a kernel) is declared in gpu_layout.hpp.

/// The kernel called `name` (kernelName(), or one of the compatibility spellings above). Else
/// a ValidationError: field `field`, "'<name>' is not a kernel" and the allowed names.
[[nodiscard]] Result<PcfKernel> parseKernel(std::string_view name,
                                            std::string_view field = "kernel");
/// "1tap, tent3x3, tent5x5, tent7x7, poisson16, pcss, vsm, evsm, msm": the names parseKernel()
/// documents.
[[nodiscard]] std::string kernelNames();

/// The one spelling of a debug mode ("depthdiff"); "unknown" for a value outside DebugMode.
[[nodiscard]] const char* debugModeName(DebugMode mode) noexcept;
/// The debug mode called `name` (debugModeName()), else a ValidationError naming `field`.
[[nodiscard]] Result<DebugMode> parseDebugMode(std::string_view name,
                                               std::string_view field = "debugMode");
/// "none, normal, shadow, lightcoords, depth, depthdiff, cascade, tiles".
[[nodiscard]] std::string debugModeNames();

/// The shadow map's depth format (csm::vk::RendererOptions::depthFormat is its VkFormat:
/// csm/vulkan/depth_format.hpp converts).
enum class DepthFormat : std::uint8_t {
  kD32 = 0,  ///< VK_FORMAT_D32_SFLOAT, the default
  kD16 = 1,  ///< VK_FORMAT_D16_UNORM
};
/// Every depth format, the default first.
inline constexpr std::array<DepthFormat, 2> kAllDepthFormats{DepthFormat::kD32, DepthFormat::kD16};
/// Bits per texel of the format (UniformOptions::depthBits).
[[nodiscard]] constexpr std::uint32_t depthFormatBits(DepthFormat format) noexcept {
  return format == DepthFormat::kD16 ? 16u : 32u;
}
/// The one spelling of a depth format ("d32", "d16"); "unknown" for a value outside DepthFormat.
[[nodiscard]] const char* depthFormatName(DepthFormat format) noexcept;
/// The depth format called `name` (depthFormatName(), or "D32" / "D16"), else a ValidationError
/// naming `field`.
[[nodiscard]] Result<DepthFormat> parseDepthFormat(std::string_view name,
                                                   std::string_view field = "depthFormat");
/// "d32, d16".
[[nodiscard]] std::string depthFormatNames();

/// The one spelling of a preset ("low", "medium", "high", "ultra"); "unknown" outside Preset.
[[nodiscard]] const char* presetName(Preset preset) noexcept;
/// The preset called `name` (presetName()), else a ValidationError naming `field`.
[[nodiscard]] Result<Preset> parsePreset(std::string_view name, std::string_view field = "preset");
/// "low, medium, high, ultra".
[[nodiscard]] std::string presetNames();

}  // namespace csm
