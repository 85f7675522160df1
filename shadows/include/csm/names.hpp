// One spelling per enum value, for code, CLI, JSON, reports and UI alike, and parsing by name.
// Pure (no Vulkan): the tables live in names.cpp, in the order of the CSM_* values, and every
// lookup goes through them (no index casts that depend on the enum's order).
//
// Kernels: "1tap", "tent3x3", "tent5x5", "tent7x7", "poisson16", "pcss" (the README's names,
// without the space). parseKernel() also accepts "tent3", "tent5" and "tent7", the fly-through's
// spelling before the names were unified, so that existing configs and command lines still work.
// Debug modes: "none", "normal", "shadow", "lightcoords", "depth", "depthdiff", "cascade".
#pragma once

#include <array>
#include <span>
#include <string>
#include <string_view>

#include "csm/error.hpp"
#include "csm/gpu_layout.hpp"

namespace csm {

/// Every PCF kernel, in the order of CSM_KERNEL_*: iterate this for menus, sweeps and tests.
inline constexpr std::array<PcfKernel, CSM_KERNEL_COUNT> kAllKernels{
    PcfKernel::k1Tap,  PcfKernel::kTent3,     PcfKernel::kTent5,
    PcfKernel::kTent7, PcfKernel::kPoisson16, PcfKernel::kPcss};

/// Every debug output, in the order of CSM_DEBUG_*.
inline constexpr std::array<DebugMode, CSM_DEBUG_COUNT> kAllDebugModes{
    DebugMode::kNone,        DebugMode::kNormal,       DebugMode::kShadowFactor,
    DebugMode::kLightCoords, DebugMode::kSampledDepth, DebugMode::kDepthDifference,
    DebugMode::kCascadeTint};

// kernelName(PcfKernel) (the one spelling of a kernel) is declared in gpu_layout.hpp.

/// The kernel called `name` (kernelName(), or one of the compatibility spellings above). Else
/// a ValidationError: field `field`, "'<name>' is not a kernel" and the allowed names.
[[nodiscard]] Result<PcfKernel> parseKernel(std::string_view name,
                                            std::string_view field = "kernel");
/// "1tap, tent3x3, tent5x5, tent7x7, poisson16, pcss": the names parseKernel() documents.
[[nodiscard]] std::string kernelNames();

/// The one spelling of a debug mode ("depthdiff"); "unknown" for a value outside DebugMode.
[[nodiscard]] const char* debugModeName(DebugMode mode) noexcept;
/// The debug mode called `name` (debugModeName()), else a ValidationError naming `field`.
[[nodiscard]] Result<DebugMode> parseDebugMode(std::string_view name,
                                               std::string_view field = "debugMode");
/// "none, normal, shadow, lightcoords, depth, depthdiff, cascade".
[[nodiscard]] std::string debugModeNames();

}  // namespace csm
