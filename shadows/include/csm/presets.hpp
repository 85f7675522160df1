// Named quality tiers: a host picks one in one call and sets its own distances on top. Pure (no
// Vulkan). The names ("low", "medium", "high", "ultra") are in names.hpp (presetName,
// parsePreset). How each tier was chosen and what it measured: tools/tradeoff/README.md,
// "Presets".
#pragma once

#include <array>
#include <cstdint>

#include "csm/gpu_layout.hpp"
#include "csm/types.hpp"

namespace csm {

/// Quality tiers, cheapest first, each the most accurate configuration of the measured
/// speed/accuracy sweep (csm_tradeoff on the sample world's forest path) within a budget of
/// shadow-map memory (tools/tradeoff/README.md, "Presets"). kHigh is the
/// module's default (ShadowSettings{}, whose kernel is PcfKernel::kTent3).
enum class Preset : std::uint8_t {
  /// 6 cascades of 512^2 (6 MiB at D32), PCF tent 3x3: within 8 MiB.
  kLow = 0,
  /// 6 cascades of 1024^2 (24 MiB), PCF tent 3x3: within 32 MiB and two thirds of high's shadow
  /// pass on lavapipe.
  kMedium = 1,
  /// 4 cascades of 2048^2 (64 MiB), PCF tent 3x3: the default.
  kHigh = 2,
  /// 4 cascades of 4096^2 (256 MiB), percentage-closer soft shadows (PCSS) of the sun's disk.
  kUltra = 3,
};

/// Every preset, cheapest first: iterate this for menus, sweeps and tests.
inline constexpr std::array<Preset, 4> kAllPresets{Preset::kLow, Preset::kMedium, Preset::kHigh,
                                                   Preset::kUltra};

/// What a preset chooses: the settings, the PCF kernel among them (settings.kernel, which the
/// lighting pipeline's specialization constants follow: csm::lightingSpecConstants).
struct PresetConfig {
  ShadowSettings settings;
};

/// The preset's choices on top of `base`: it sets the cascade count, the resolution and the
/// kernel, and keeps every other field of `base` (shadow distance, splits, bias, ladder, light
/// steps, PCSS taps: the host's). A preset outside Preset gives `base` unchanged. The result
/// passes validate() whenever `base` does.
[[nodiscard]] PresetConfig presetConfig(Preset preset, const ShadowSettings& base = {}) noexcept;

}  // namespace csm
