// The quality tiers (presets.hpp).
#include "csm/presets.hpp"

namespace csm {

PresetConfig presetConfig(Preset preset, const ShadowSettings& base) noexcept {
  PresetConfig c{base, PcfKernel::kTent3};
  switch (preset) {
    case Preset::kLow:
      c.settings.cascadeCount = 6;
      c.settings.resolution = 512;
      break;
    case Preset::kMedium:
      c.settings.cascadeCount = 6;
      c.settings.resolution = 1024;
      break;
    case Preset::kHigh:
      c.settings.cascadeCount = 4;
      c.settings.resolution = 2048;
      break;
    case Preset::kUltra:
      c.settings.cascadeCount = 4;
      c.settings.resolution = 4096;
      c.kernel = PcfKernel::kPcss;
      break;
  }
  return c;
}

}  // namespace csm
