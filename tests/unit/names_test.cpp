// One spelling per kernel, debug mode and depth format (csm/names.hpp): every value's name parses
// back to it, the names are distinct, the older kernel and depth-format spellings are still
// accepted, and anything else is refused with a message naming the field, the value and every
// allowed name.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "csm/names.hpp"
#include "csm/presets.hpp"

namespace {

TEST(Names, EveryKernelRoundTripsThroughItsName) {
  std::set<std::string> seen;
  for (csm::PcfKernel k : csm::kAllFilters) {
    const std::string name = csm::kernelName(k);
    EXPECT_TRUE(seen.insert(name).second) << name;
    const csm::Result<csm::PcfKernel> parsed = csm::parseKernel(name);
    ASSERT_TRUE(parsed.ok()) << name;
    EXPECT_EQ(parsed.value(), k) << name;
  }
  EXPECT_EQ(seen.size(), std::size_t(CSM_FILTER_COUNT));
  // The README's names (without the space) and the order of CSM_KERNEL_*.
  EXPECT_EQ(csm::kernelNames(), "1tap, tent3x3, tent5x5, tent7x7, poisson16, pcss, vsm, evsm, msm");
  for (std::size_t i = 0; i < csm::kAllFilters.size(); ++i) {
    EXPECT_EQ(static_cast<std::uint32_t>(csm::kAllFilters[i]), i);
  }
  EXPECT_EQ(csm::kAllKernels.size(), std::size_t(CSM_KERNEL_COUNT));
  EXPECT_STREQ(csm::kernelName(static_cast<csm::PcfKernel>(99)), "unknown");
}

TEST(Names, OlderKernelSpellingsAreAccepted) {
  EXPECT_EQ(csm::parseKernel("tent3").value(), csm::PcfKernel::kTent3);
  EXPECT_EQ(csm::parseKernel("tent5").value(), csm::PcfKernel::kTent5);
  EXPECT_EQ(csm::parseKernel("tent7").value(), csm::PcfKernel::kTent7);
}

TEST(Names, UnknownKernelIsRefusedNamingFieldValueAndNames) {
  for (const char* bad : {"", "TENT3", "tent 3x3", "tent4", "pcss ", "1"}) {
    const csm::Result<csm::PcfKernel> r = csm::parseKernel(bad, "shadow.kernel");
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.error().message(), std::string("shadow.kernel = '") + bad +
                                       "' is invalid: allowed one of 1tap, tent3x3, tent5x5, "
                                       "tent7x7, poisson16, pcss, vsm, evsm, msm");
  }
}

TEST(Names, EveryDebugModeRoundTripsThroughItsName) {
  std::set<std::string> seen;
  for (csm::DebugMode m : csm::kAllDebugModes) {
    const std::string name = csm::debugModeName(m);
    EXPECT_TRUE(seen.insert(name).second) << name;
    const csm::Result<csm::DebugMode> parsed = csm::parseDebugMode(name);
    ASSERT_TRUE(parsed.ok()) << name;
    EXPECT_EQ(parsed.value(), m) << name;
  }
  EXPECT_EQ(seen.size(), std::size_t(CSM_DEBUG_COUNT));
  const csm::Result<csm::DebugMode> r = csm::parseDebugMode("shadow factor", "debug");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message(),
            "debug = 'shadow factor' is invalid: allowed one of none, normal, shadow, "
            "lightcoords, depth, depthdiff, cascade, tiles");
  EXPECT_STREQ(csm::debugModeName(static_cast<csm::DebugMode>(99)), "unknown");
}

TEST(Names, EveryDepthFormatRoundTripsAndTheCsvSpellingIsAccepted) {
  std::set<std::string> seen;
  for (csm::DepthFormat f : csm::kAllDepthFormats) {
    const std::string name = csm::depthFormatName(f);
    EXPECT_TRUE(seen.insert(name).second) << name;
    const csm::Result<csm::DepthFormat> parsed = csm::parseDepthFormat(name);
    ASSERT_TRUE(parsed.ok()) << name;
    EXPECT_EQ(parsed.value(), f) << name;
  }
  EXPECT_EQ(csm::depthFormatNames(), "d32, d16");
  EXPECT_EQ(csm::kAllDepthFormats[0], csm::DepthFormat::kD32);  // the default first
  EXPECT_EQ(csm::depthFormatBits(csm::DepthFormat::kD32), 32u);
  EXPECT_EQ(csm::depthFormatBits(csm::DepthFormat::kD16), 16u);
  // The CSV reports' older spelling.
  EXPECT_EQ(csm::parseDepthFormat("D32").value(), csm::DepthFormat::kD32);
  EXPECT_EQ(csm::parseDepthFormat("D16").value(), csm::DepthFormat::kD16);
  EXPECT_STREQ(csm::depthFormatName(static_cast<csm::DepthFormat>(9)), "unknown");
  for (const char* bad : {"", "d24", "D16_UNORM", "d16 ", "32"}) {
    const csm::Result<csm::DepthFormat> r = csm::parseDepthFormat(bad, "shadow.depthFormat");
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.error().message(), std::string("shadow.depthFormat = '") + bad +
                                       "' is invalid: allowed one of d32, d16");
  }
}

TEST(Names, EveryPresetRoundTripsThroughItsName) {
  std::set<std::string> seen;
  for (csm::Preset p : csm::kAllPresets) {
    const std::string name = csm::presetName(p);
    EXPECT_TRUE(seen.insert(name).second) << name;
    const csm::Result<csm::Preset> parsed = csm::parsePreset(name);
    ASSERT_TRUE(parsed.ok()) << name;
    EXPECT_EQ(parsed.value(), p) << name;
  }
  EXPECT_EQ(csm::presetNames(), "low, medium, high, ultra");
  EXPECT_STREQ(csm::presetName(static_cast<csm::Preset>(9)), "unknown");
  for (const char* bad : {"", "Low", "epic", "high "}) {
    const csm::Result<csm::Preset> r = csm::parsePreset(bad);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.error().message(), std::string("preset = '") + bad +
                                       "' is invalid: allowed one of low, medium, high, ultra");
  }
}

// A preset sets the cascade count, the resolution and the kernel, keeps every other field of the
// host's settings, always validates, and rises in cost and quality from low to ultra; high is
// the module's default.
TEST(Presets, SetTheirFieldsKeepTheRestAndHighIsTheDefault) {
  csm::ShadowSettings base;
  base.shadowDistanceM = 1500.0;
  base.splitLambda = 0.8;
  base.lightStepDeg = 0.25;
  base.normalOffsetTexels = 2.0f;
  base.fadeFraction = 0.2;
  std::uint64_t lastTexels = 0;
  for (csm::Preset p : csm::kAllPresets) {
    SCOPED_TRACE(csm::presetName(p));
    const csm::PresetConfig c = csm::presetConfig(p, base);
    EXPECT_FALSE(csm::validate(c.settings).has_value());
    EXPECT_EQ(c.settings.shadowDistanceM, 1500.0);
    EXPECT_EQ(c.settings.splitLambda, 0.8);
    EXPECT_EQ(c.settings.lightStepDeg, 0.25);
    EXPECT_EQ(c.settings.normalOffsetTexels, 2.0f);
    EXPECT_EQ(c.settings.fadeFraction, 0.2);
    const std::uint64_t texels =
        std::uint64_t(c.settings.cascadeCount) * c.settings.resolution * c.settings.resolution;
    EXPECT_GT(texels, lastTexels);
    lastTexels = texels;
  }
  const csm::PresetConfig high = csm::presetConfig(csm::Preset::kHigh);
  const csm::ShadowSettings def;
  EXPECT_EQ(high.settings.cascadeCount, def.cascadeCount);
  EXPECT_EQ(high.settings.resolution, def.resolution);
  EXPECT_EQ(high.settings.kernel, csm::PcfKernel::kTent3);
  EXPECT_EQ(csm::presetConfig(csm::Preset::kUltra).settings.kernel, csm::PcfKernel::kPcss);
  EXPECT_EQ(csm::presetConfig(csm::Preset::kLow).settings.resolution, 512u);
}

}  // namespace
