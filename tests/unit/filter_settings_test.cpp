// The filter is a setting: ShadowSettings::kernel, pcssTaps and blendBand give the lighting
// pipeline's specialization constants (csm::lightingSpecConstants), and worldSpaceKernel the
// kernel's tap spacing per cascade (packUniforms). One source, so the CPU and the shader cannot
// disagree.
#include <gtest/gtest.h>

#include <csm/core.hpp>
#include <csm/gpu_layout.hpp>
#include <csm/names.hpp>
#include <csm/presets.hpp>

#include <cstdint>

#include "test_util.hpp"

namespace csm {
namespace {

std::uint32_t constantOf(const ShadowSettings& s, std::uint32_t id) {
  for (const SpecConstant& c : lightingSpecConstants(s)) {
    if (c.id == id) return c.value;
  }
  ADD_FAILURE() << "no constant " << id;
  return 0xffffffffu;
}

TEST(FilterSettings, SpecConstantsFollowTheSettings) {
  ShadowSettings s;
  // The defaults are csm.glsl's own defaults: a host that specialises nothing gets the same.
  EXPECT_EQ(constantOf(s, CSM_SPEC_KERNEL), std::uint32_t(CSM_KERNEL_TENT3));
  EXPECT_EQ(constantOf(s, CSM_SPEC_BLEND), 1u);
  EXPECT_EQ(constantOf(s, CSM_SPEC_PCSS_TAPS), std::uint32_t(CSM_PCSS_DEFAULT_TAPS));
  for (PcfKernel k : kAllKernels) {
    s.kernel = k;
    EXPECT_EQ(constantOf(s, CSM_SPEC_KERNEL), static_cast<std::uint32_t>(k)) << kernelName(k);
  }
  s.pcssTaps = 40;
  EXPECT_EQ(constantOf(s, CSM_SPEC_PCSS_TAPS), 40u);
  // The blend follows the band: no band, the hard switch (the two cannot disagree).
  s.blendBand = 0.0;
  EXPECT_EQ(constantOf(s, CSM_SPEC_BLEND), 0u);
  s.blendBand = 1e-9;
  EXPECT_EQ(constantOf(s, CSM_SPEC_BLEND), 1u);
  // Each id once.
  const auto constants = lightingSpecConstants(s);
  for (std::size_t i = 0; i < constants.size(); ++i) {
    for (std::size_t j = i + 1; j < constants.size(); ++j) {
      EXPECT_NE(constants[i].id, constants[j].id);
    }
  }
}

TEST(FilterSettings, OtherFieldsLeaveTheConstantsAlone) {
  const ShadowSettings a;
  ShadowSettings b;
  b.cascadeCount = 6;
  b.resolution = 512;
  b.shadowDistanceM = 90.0;
  b.normalOffsetTexels = 2.0f;
  b.worldSpaceKernel = true;
  b.blendBand = 0.3;
  const auto ca = lightingSpecConstants(a);
  const auto cb = lightingSpecConstants(b);
  for (std::size_t i = 0; i < ca.size(); ++i) {
    EXPECT_EQ(ca[i].id, cb[i].id);
    EXPECT_EQ(ca[i].value, cb[i].value) << "constant " << ca[i].id;
  }
}

TEST(FilterSettings, PresetsSetTheKernelInTheSettings) {
  ShadowSettings base;
  base.pcssTaps = 24;
  base.shadowDistanceM = 250.0;
  EXPECT_EQ(presetConfig(Preset::kUltra, base).settings.kernel, PcfKernel::kPcss);
  EXPECT_EQ(presetConfig(Preset::kHigh, base).settings.kernel, PcfKernel::kTent3);
  for (Preset p : kAllPresets) {
    const ShadowSettings s = presetConfig(p, base).settings;
    EXPECT_EQ(s.pcssTaps, 24u) << presetName(p);
    EXPECT_EQ(s.shadowDistanceM, 250.0) << presetName(p);
    EXPECT_FALSE(validate(s).has_value()) << presetName(p);
  }
  // Outside Preset: the base, kernel included, unchanged.
  base.kernel = PcfKernel::kTent7;
  EXPECT_EQ(presetConfig(static_cast<Preset>(9), base).settings.kernel, PcfKernel::kTent7);
}

TEST(FilterSettings, WorldSpaceKernelScalesTapsByTexelRatio) {
  ShadowSettings s;
  Camera c;
  c.positionWs = {10.0, 5.0, -3.0};
  const DirectionalLight l{{0.3, -1.0, 0.2}};
  const Result<CascadeFrame> frame = computeCascades(s, c, l);
  ASSERT_TRUE(frame.ok());
  const CascadeFrame& f = frame.value();
  const CsmUniforms texels = packUniforms(f, s);
  s.worldSpaceKernel = true;
  const CsmUniforms metres = packUniforms(f, s);
  const double texel0 = f.cascades[0].texelSizeM();
  for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
    if (f.cascades[i].empty) continue;
    EXPECT_EQ(texels.cascades[i].kernelScale, 1.0f) << i;
    EXPECT_FLOAT_EQ(metres.cascades[i].kernelScale,
                    static_cast<float>(texel0 / f.cascades[i].texelSizeM()))
        << i;
  }
  EXPECT_LT(metres.cascades[f.cascadeCount - 1].kernelScale, 1.0f)
      << "the last cascade's texels are larger: its taps come closer";
}

}  // namespace
}  // namespace csm
