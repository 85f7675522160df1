// One spelling per enum value (see names.hpp).
#include "csm/names.hpp"

#include <utility>

namespace csm {
namespace {

template <class T>
struct Named {
  const char* name;
  T value;
};

// The canonical names first, in the enum's order; then the accepted older spellings.
constexpr Named<PcfKernel> kKernelNames[] = {
    {"1tap", PcfKernel::k1Tap},
    {"tent3x3", PcfKernel::kTent3},
    {"tent5x5", PcfKernel::kTent5},
    {"tent7x7", PcfKernel::kTent7},
    {"poisson16", PcfKernel::kPoisson16},
    {"pcss", PcfKernel::kPcss},
    {"vsm", PcfKernel::kVsm},
    {"evsm", PcfKernel::kEvsm},
    {"msm", PcfKernel::kMsm},
};
constexpr Named<PcfKernel> kKernelCompatNames[] = {
    {"tent3", PcfKernel::kTent3}, {"tent5", PcfKernel::kTent5}, {"tent7", PcfKernel::kTent7}};

constexpr Named<DebugMode> kDebugModeNames[] = {
    {"none", DebugMode::kNone},           {"normal", DebugMode::kNormal},
    {"shadow", DebugMode::kShadowFactor}, {"lightcoords", DebugMode::kLightCoords},
    {"depth", DebugMode::kSampledDepth},  {"depthdiff", DebugMode::kDepthDifference},
    {"cascade", DebugMode::kCascadeTint}, {"tiles", DebugMode::kTileFallback},
};

constexpr Named<DepthFormat> kDepthFormatNames[] = {
    {"d32", DepthFormat::kD32},
    {"d16", DepthFormat::kD16},
};
constexpr Named<DepthFormat> kDepthFormatCompatNames[] = {{"D32", DepthFormat::kD32},
                                                          {"D16", DepthFormat::kD16}};

constexpr Named<Preset> kPresetNames[] = {
    {"low", Preset::kLow},
    {"medium", Preset::kMedium},
    {"high", Preset::kHigh},
    {"ultra", Preset::kUltra},
};

static_assert(std::size(kPresetNames) == kAllPresets.size());
static_assert(std::size(kKernelNames) == kAllFilters.size());
static_assert(std::size(kDepthFormatNames) == kAllDepthFormats.size());
static_assert(std::size(kDebugModeNames) == kAllDebugModes.size());

template <class T, std::size_t N>
const char* nameOf(const Named<T> (&table)[N], T value) noexcept {
  for (const Named<T>& n : table) {
    if (n.value == value) return n.name;
  }
  return "unknown";
}

template <class T, std::size_t N>
std::string joinNames(const Named<T> (&table)[N]) {
  std::string out;
  for (const Named<T>& n : table) {
    if (!out.empty()) out += ", ";
    out += n.name;
  }
  return out;
}

template <class T, std::size_t N>
const T* find(const Named<T> (&table)[N], std::string_view name) noexcept {
  for (const Named<T>& n : table) {
    if (name == n.name) return &n.value;
  }
  return nullptr;
}

ValidationError badName(std::string_view field, std::string_view name, std::string names) {
  return ValidationError{std::string(field), 0.0, "one of " + std::move(names), std::string(name)};
}

}  // namespace

const char* kernelName(PcfKernel kernel) noexcept {
  return nameOf(kKernelNames, kernel);
}

std::string kernelNames() {
  return joinNames(kKernelNames);
}

Result<PcfKernel> parseKernel(std::string_view name, std::string_view field) {
  if (const PcfKernel* k = find(kKernelNames, name)) return *k;
  if (const PcfKernel* k = find(kKernelCompatNames, name)) return *k;
  return badName(field, name, kernelNames());
}

const char* debugModeName(DebugMode mode) noexcept {
  return nameOf(kDebugModeNames, mode);
}

std::string debugModeNames() {
  return joinNames(kDebugModeNames);
}

Result<DebugMode> parseDebugMode(std::string_view name, std::string_view field) {
  if (const DebugMode* m = find(kDebugModeNames, name)) return *m;
  return badName(field, name, debugModeNames());
}

const char* depthFormatName(DepthFormat format) noexcept {
  return nameOf(kDepthFormatNames, format);
}

std::string depthFormatNames() {
  return joinNames(kDepthFormatNames);
}

Result<DepthFormat> parseDepthFormat(std::string_view name, std::string_view field) {
  if (const DepthFormat* f = find(kDepthFormatNames, name)) return *f;
  if (const DepthFormat* f = find(kDepthFormatCompatNames, name)) return *f;
  return badName(field, name, depthFormatNames());
}

const char* presetName(Preset preset) noexcept {
  return nameOf(kPresetNames, preset);
}

std::string presetNames() {
  return joinNames(kPresetNames);
}

Result<Preset> parsePreset(std::string_view name, std::string_view field) {
  if (const Preset* p = find(kPresetNames, name)) return *p;
  return badName(field, name, presetNames());
}

}  // namespace csm
