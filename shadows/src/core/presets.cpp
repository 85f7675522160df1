// The quality tiers (presets.hpp).
#include "csm/presets.hpp"

#include <iterator>

namespace csm {
namespace {

struct Tier {
  Preset preset;
  std::uint32_t cascadeCount;
  std::uint32_t resolution;
  PcfKernel kernel;
};

// What each tier chooses (tools/tradeoff/README.md, "Presets": how and what they measured).
constexpr Tier kTiers[] = {
    {Preset::kLow, 6, 512, PcfKernel::kTent3},
    {Preset::kMedium, 6, 1024, PcfKernel::kTent3},
    {Preset::kHigh, 4, 2048, PcfKernel::kTent3},
    {Preset::kUltra, 4, 4096, PcfKernel::kPcss},
};
static_assert(std::size(kTiers) == kAllPresets.size());

}  // namespace

PresetConfig presetConfig(Preset preset, const ShadowSettings& base) noexcept {
  PresetConfig c{base};
  for (const Tier& t : kTiers) {
    if (t.preset != preset) continue;
    c.settings.cascadeCount = t.cascadeCount;
    c.settings.resolution = t.resolution;
    c.settings.kernel = t.kernel;
  }
  return c;
}

}  // namespace csm
