// The bias data packed for csm.glsl (depthFloorTexels, depthFloorQuantum) and the depth quantum per
// format: what the shader's depth floor is made of. The floor must exceed one D16 step and the
// float noise of D32 at every cascade, and nothing that is not finite may reach the GPU.
#include <gtest/gtest.h>

#include <csm/core.hpp>
#include <csm/gpu_layout.hpp>
#include <csm/moments.hpp>

#include <cmath>
#include <cstddef>

namespace {

TEST(BiasUniforms, BiasParamsIsAppendedAfterCountsAndSoftParamsCanFollow) {
  EXPECT_EQ(offsetof(csm::CsmUniforms, depthFloorTexels),
            offsetof(csm::CsmUniforms, cascadeCount) + 16);
  EXPECT_EQ(offsetof(csm::CsmUniforms, tanHalfLightAngle),
            offsetof(csm::CsmUniforms, depthFloorTexels) + 16);
  // The prefiltered filters' parameters follow the soft ones, one vec4.
  EXPECT_EQ(offsetof(csm::CsmUniforms, moments),
            offsetof(csm::CsmUniforms, tanHalfLightAngle) + 16);
  // Then the receiver-marked tiles: a header vec4, a vec4 per cascade, three uvec4 per cascade.
  EXPECT_EQ(offsetof(csm::CsmUniforms, tilePartialMask), offsetof(csm::CsmUniforms, moments) + 16);
  EXPECT_EQ(offsetof(csm::CsmUniforms, tileGrid), offsetof(csm::CsmUniforms, tilePartialMask) + 16);
  EXPECT_EQ(sizeof(csm::CsmUniforms),
            offsetof(csm::CsmUniforms, tileGrid) + 16 * CSM_MAX_CASCADES * 4);
}

TEST(BiasUniforms, DepthQuantumIsOneD16StepAndSixteenD32UlpsAtDepthOne) {
  EXPECT_FLOAT_EQ(csm::depthQuantum(16), 1.0f / 65535.0f);
  EXPECT_FLOAT_EQ(csm::depthQuantum(32), 16.0f * std::ldexp(1.0f, -24));
  // 16 ulp of depths in [0.5, 1) (2^-24 each): above the float noise of the receiver's depth.
  EXPECT_GE(csm::depthQuantum(32), 8.0f * std::ldexp(1.0f, -24));
  EXPECT_LT(csm::depthQuantum(32), csm::depthQuantum(16));
}

TEST(BiasUniforms, PackUniformsCarriesTheFloorAndTheFormatQuantum) {
  csm::ShadowSettings s;
  s.depthFloorTexels = 0.4f;
  const csm::CascadeFrame frame{};
  csm::UniformOptions o;
  o.depthBits = 16;
  csm::CsmUniforms u = csm::packUniforms(frame, s, o);
  EXPECT_FLOAT_EQ(u.depthFloorTexels, 0.4f);
  EXPECT_FLOAT_EQ(u.depthFloorQuantum, csm::depthQuantum(16));
  EXPECT_EQ(u.momentQuantized, 0u);
  EXPECT_EQ(u.momentAnisotropy, 1.0f);  // a trilinear moment sampler unless the host says
  o.momentAnisotropy = 8.0f;
  EXPECT_EQ(csm::packUniforms(frame, s, o).momentAnisotropy, 8.0f);
  o.momentAnisotropy = std::nanf("");
  EXPECT_EQ(csm::packUniforms(frame, s, o).momentAnisotropy, 1.0f);
  o.momentAnisotropy = 0.0f;
  EXPECT_EQ(csm::packUniforms(frame, s, o).momentAnisotropy, 1.0f);
  o.depthBits = 32;
  u = csm::packUniforms(frame, s, o);
  EXPECT_FLOAT_EQ(u.depthFloorQuantum, csm::depthQuantum(32));
  EXPECT_FLOAT_EQ(u.normalOffsetTexels, s.normalOffsetTexels);
  // Quantised moments: only msm reads them, with a moment bias raised to the format's floor.
  o.msmQuantizedMoments = true;
  EXPECT_EQ(csm::packUniforms(frame, s, o).momentQuantized, 0u);  // tent 3x3 keeps no moments
  s.kernel = csm::PcfKernel::kMsm;
  u = csm::packUniforms(frame, s, o);
  EXPECT_EQ(u.momentQuantized, 1u);
  EXPECT_EQ(u.moments.y, csm::kMsmQuantizedMinMomentBias);
  s.msmMomentBias = 1e-3f;  // a larger bias is kept
  EXPECT_EQ(csm::packUniforms(frame, s, o).moments.y, 1e-3f);
  o.msmQuantizedMoments = false;
  s.msmMomentBias = 3e-5f;
  u = csm::packUniforms(frame, s, o);
  EXPECT_EQ(u.momentQuantized, 0u);
  EXPECT_EQ(u.moments.y, 3e-5f);
}

TEST(BiasUniforms, DefaultsAreValidAndNeedNoRasterSlopeBias) {
  const csm::ShadowSettings s;
  EXPECT_FALSE(csm::validate(s).has_value());
  EXPECT_GT(s.depthFloorTexels, 0.0f);
  EXPECT_GE(s.normalOffsetTexels, 1.0f) << "below 1 the offset does not cover the kernel's reach";
  EXPECT_EQ(s.depthBiasSlope, 0.0f);
}

}  // namespace
