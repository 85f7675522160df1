// csm.glsl on cached cascades: with toroidal layers (non-zero wrap offsets after the camera
// moves) every kernel still agrees with the analytic shadow, and the image matches the uncached
// renderer's except where the depth window's precision differs.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "shadow_scene.hpp"

namespace csm_test {
namespace {

constexpr csm::PcfKernel kKernels[] = {csm::PcfKernel::k1Tap, csm::PcfKernel::kTent3,
                                       csm::PcfKernel::kTent5, csm::PcfKernel::kTent7,
                                       csm::PcfKernel::kPoisson16};

TEST(ShadowCacheSampling, WrappedLayersAgreeWithAnalyticShadowWhileTheCameraMoves) {
  {
    ShadowScene scene;
    csm::vk::RendererOptions options;
    options.cache = true;
    CSM_ASSERT_OK(scene.update(testSettings(4, 512), options));
    const glm::dvec3 start = scene.camera.positionWs;
    bool wrapped = false;
    for (int f = 0; f < 24; ++f) {
      SCOPED_TRACE("frame " + std::to_string(f));
      // Sideways and forward, a few texels of every cascade per frame.
      scene.camera.positionWs = start + glm::dvec3(0.37 * f, 0.0, -0.29 * f);
      const csm::PcfKernel kernel = kKernels[f % 5];
      const Rendered r = scene.render(kernel, csm::DebugMode::kShadowFactor);
      const Agreement a = compareWithAnalytic(scene, r);
      EXPECT_GT(a.compared, 10000u);
      // Enough shadowed pixels for the agreement to mean something (the camera walks away from
      // the casters: 488 at frame 3 with the bias that needs no tuning).
      EXPECT_GT(a.shadowed, 400u);
      EXPECT_GE(a.ratio(), 0.995) << csm::kernelName(kernel);
      for (std::uint32_t c = 0; c < 4; ++c) {
        const glm::vec2 d = scene.renderer().uniforms().cascades[c].wrapOffset;
        wrapped = wrapped || d.x != 0.0f || d.y != 0.0f;
      }
      if (f == 23) scene.saveArtefact(r.image, "shadow_cache_wrapped_f23");
    }
    EXPECT_TRUE(wrapped) << "the camera should have moved the layers' wrap offsets";
    EXPECT_EQ(scene.renderer().uniforms().wrappedLayers, 1u);
  }
  EXPECT_EQ(validationMessages(), 0u);
}

TEST(ShadowCacheSampling, CachedAndUncachedImagesAgree) {
  {
    ShadowScene scene;
    for (csm::PcfKernel kernel : kKernels) {
      SCOPED_TRACE(csm::kernelName(kernel));
      csm::vk::RendererOptions options;
      CSM_ASSERT_OK(scene.update(testSettings(4, 512), options));
      // A few frames so the cached view has scrolled (wrap offsets) before the comparison.
      const glm::dvec3 start = scene.camera.positionWs;
      Rendered off, on;
      for (int f = 0; f < 4; ++f) {
        scene.camera.positionWs = start + glm::dvec3(0.5 * f, 0.0, -0.4 * f);
        off = scene.render(kernel, csm::DebugMode::kShadowFactor);
      }
      options.cache = true;
      CSM_ASSERT_OK(scene.update(testSettings(4, 512), options));
      for (int f = 0; f < 4; ++f) {
        scene.camera.positionWs = start + glm::dvec3(0.5 * f, 0.0, -0.4 * f);
        on = scene.render(kernel, csm::DebugMode::kShadowFactor);
      }
      ASSERT_EQ(off.image.rgba.size(), on.image.rgba.size());
      std::size_t differing = 0, total = off.image.rgba.size() / 4;
      for (std::size_t i = 0; i < total; ++i) {
        const int d = int(off.image.rgba[4 * i]) - int(on.image.rgba[4 * i]);
        differing += (d > 8 || d < -8) ? 1 : 0;
      }
      std::printf("%-10s pixels differing by more than 8/255 cached vs uncached: %zu of %zu\n",
                  csm::kernelName(kernel), differing, total);
      // The depth window is wider than the uncached range (quantised, with margins): the
      // comparison differs only at a few shadow-edge pixels.
      EXPECT_LE(differing, total / 1000);
      EXPECT_GE(compareWithAnalytic(scene, on).ratio(), 0.995);
      scene.camera.positionWs = start;
    }
  }
  EXPECT_EQ(validationMessages(), 0u);
}

}  // namespace
}  // namespace csm_test
