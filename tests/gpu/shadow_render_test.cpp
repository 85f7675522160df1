// GPU tests of the shadow renderer and csm.glsl against the analytic answer: a plane with
// spheres and boxes above it under a directional light, headless, validation on.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "glue/shadow_host.hpp"
#include "shadow_scene.hpp"

namespace csm_test {
namespace {

constexpr csm::PcfKernel kKernels[] = {csm::PcfKernel::k1Tap,      csm::PcfKernel::kTent3,
                                       csm::PcfKernel::kTent5,     csm::PcfKernel::kTent7,
                                       csm::PcfKernel::kPoisson16, csm::PcfKernel::kPcss};

class ShadowAnalytic : public ::testing::TestWithParam<uint32_t> {};

TEST_P(ShadowAnalytic, EveryKernelAgreesWithAnalyticShadowAwayFromEdges) {
  const uint32_t cascades = GetParam();
  {
    ShadowScene scene;
    CSM_ASSERT_OK(scene.update(testSettings(cascades, cascades == 4 ? 512 : 1024)));
    for (csm::PcfKernel kernel : kKernels) {
      SCOPED_TRACE(csm::kernelName(kernel));
      const Rendered r = scene.render(kernel, csm::DebugMode::kShadowFactor);
      const Agreement a = compareWithAnalytic(scene, r);
      scene.saveArtefact(
          r.image, "shadow_analytic_c" + std::to_string(cascades) + "_" + csm::kernelName(kernel));
      std::printf("cascades %u %-10s compared %llu (shadowed %llu) agreement %.4f%%\n", cascades,
                  csm::kernelName(kernel), (unsigned long long)a.compared,
                  (unsigned long long)a.shadowed, 100.0 * a.ratio());
      EXPECT_GT(a.compared, 10000u);
      EXPECT_GT(a.shadowed, 500u);
      EXPECT_GE(a.ratio(), 0.995);
    }
    // One lit image per cascade count, for people to look at.
    const Rendered lit = scene.render(csm::PcfKernel::kTent5, csm::DebugMode::kNone);
    scene.saveArtefact(lit.image, "shadow_lit_c" + std::to_string(cascades));
  }
  EXPECT_EQ(validationMessages(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Cascades, ShadowAnalytic, ::testing::Values(1u, 2u, 4u));

// Maps a tint pixel back to a cascade index (-1 for black); -2 when it matches no tint.
int cascadeFromTint(const std::array<uint8_t, 4>& px, uint32_t count) {
  for (int i = -1; i < int(count); ++i) {
    const glm::vec3 t = csm::cascadeTint(i) * 255.0f;
    if (std::abs(t.r - px[0]) <= 2 && std::abs(t.g - px[1]) <= 2 && std::abs(t.b - px[2]) <= 2) {
      return i;
    }
  }
  return -2;
}

TEST(ShadowCascadeTint, MatchesCpuSelectionOffBoundaries) {
  {
    ShadowScene scene;
    csm::ShadowSettings settings = testSettings(4, 512);
    settings.splitLambda = 0.5;  // so that the first cascade reaches the visible ground
    CSM_ASSERT_OK(scene.update(settings));
    const Rendered r = scene.render(csm::PcfKernel::k1Tap, csm::DebugMode::kCascadeTint);
    scene.saveArtefact(r.image, "shadow_cascade_tint");
    const double band = scene.settings().blendBand;
    auto indexAt = [&](int x, int y, bool* plane) -> int {
      const ShadowScene::Hit h = scene.trace(uint32_t(x), uint32_t(y));
      *plane = h.plane;
      if (!h.hit) return -3;
      return csm::selectCascade(r.frame, csm::viewDepthM(r.frame, h.posWs), band).index;
    };
    uint64_t compared = 0, mismatched = 0;
    uint32_t seen = 0;  // bit mask of cascades seen
    for (int y = 1; y + 1 < int(r.image.height); ++y) {
      for (int x = 1; x + 1 < int(r.image.width); ++x) {
        bool plane = false;
        const int index = indexAt(x, y, &plane);
        if (index == -3) continue;
        bool boundary = false;
        for (const auto& [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
          bool p2 = false;
          if (indexAt(x + dx, y + dy, &p2) != index || p2 != plane) boundary = true;
        }
        if (boundary) continue;
        ++compared;
        const int gpu = cascadeFromTint(r.image.at(uint32_t(x), uint32_t(y)), 4);
        if (gpu != index) {
          if (mismatched < 5) {
            std::printf("pixel (%d, %d): GPU cascade %d, CPU %d\n", x, y, gpu, index);
          }
          ++mismatched;
        }
        if (index >= 0) seen |= 1u << index;
      }
    }
    std::printf("compared %llu pixels, %llu mismatches, cascades seen 0x%x\n",
                (unsigned long long)compared, (unsigned long long)mismatched, seen);
    EXPECT_GT(compared, 30000u);
    EXPECT_EQ(mismatched, 0u);
    EXPECT_EQ(seen, 0xFu) << "every cascade should show in the view";
  }
  EXPECT_EQ(validationMessages(), 0u);
}

TEST(ShadowRuntimeChanges, ResolutionCountAndFormatChangesStayCorrect) {
  {
    ShadowScene scene;
    struct Step {
      uint32_t cascades, resolution;
      VkFormat format;
    };
    const Step steps[] = {{2, 1024, VK_FORMAT_D32_SFLOAT},
                          {4, 512, VK_FORMAT_D32_SFLOAT},
                          {3, 1024, VK_FORMAT_D16_UNORM},
                          {1, 512, VK_FORMAT_D16_UNORM},
                          {2, 1024, VK_FORMAT_D32_SFLOAT}};
    for (const Step& s : steps) {
      SCOPED_TRACE("cascades " + std::to_string(s.cascades) + " resolution " +
                   std::to_string(s.resolution) + " format " + std::to_string(s.format));
      csm::vk::RendererOptions options;
      options.depthFormat = s.format;
      CSM_ASSERT_OK(scene.update(testSettings(s.cascades, s.resolution), options));
      // Twice: the second frame reuses every resource (frames in flight, barriers).
      scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
      const Rendered r = scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
      const Agreement a = compareWithAnalytic(scene, r);
      // 184 at 1 cascade of 512^2: the size ladder rounds the box up (up to 2^(2/8) in length),
      // and the 2-texel band excluded along the shadow edges widens with it.
      EXPECT_GT(a.shadowed, 150u);
      EXPECT_GE(a.ratio(), 0.995);
    }
  }
  EXPECT_EQ(validationMessages(), 0u);
}

TEST(ShadowRenderModes, LayeredAndPerLayerRenderTheSameImage) {
  {
    ShadowScene scene;
    if (!scene.context().features().shaderOutputLayer) GTEST_SKIP() << "no shaderOutputLayer";
    for (uint32_t cascades : {1u, 4u}) {
      SCOPED_TRACE("cascades " + std::to_string(cascades));
      csm::vk::RendererOptions options;
      options.renderMode = csm::vk::RenderMode::kPerLayer;
      CSM_ASSERT_OK(scene.update(testSettings(cascades, 512), options));
      const Rendered a = scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
      options.renderMode = csm::vk::RenderMode::kLayered;
      CSM_ASSERT_OK(scene.update(testSettings(cascades, 512), options));
      EXPECT_EQ(scene.renderer().renderMode(), csm::vk::RenderMode::kLayered);
      const Rendered b = scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
      ASSERT_EQ(a.image.rgba.size(), b.image.rgba.size());
      size_t differing = 0;
      for (size_t i = 0; i < a.image.rgba.size(); ++i) {
        differing += a.image.rgba[i] != b.image.rgba[i];
      }
      EXPECT_EQ(differing, 0u);
      EXPECT_GE(compareWithAnalytic(scene, b).ratio(), 0.995);
    }
  }
  EXPECT_EQ(validationMessages(), 0u);
}

TEST(ShadowApiMisuse, RefusedCallsReturnErrorsAndLeaveTheRendererUsable) {
  {
    ShadowScene scene;
    csm::vk::ShadowRenderer& renderer = scene.renderer();
    const csm::ShadowSettings settings = testSettings(2, 512);
    csm::Result<csm::CascadeFrame> frame =
        csm::computeCascades(settings, scene.csmCamera(), scene.light);
    ASSERT_TRUE(frame.ok());
    csm::vk::Status status;
    // Record before update().
    scene.context().submitAndWait([&](VkCommandBuffer cmd) {
      status = renderer.recordShadowPass(cmd, frame.value(), csm::vk::CasterList{}, nullptr);
    });
    EXPECT_EQ(status.code(), csm::vk::ErrorCode::kWrongOrder) << status.message();
    EXPECT_EQ(renderer.writeLightingSet(renderer.lightingSet()).code(),
              csm::vk::ErrorCode::kWrongOrder);

    // Invalid settings and an unsupported depth format.
    csm::ShadowSettings bad = settings;
    bad.resolution = 300;
    status = scene.update(bad);
    EXPECT_EQ(status.code(), csm::vk::ErrorCode::kInvalidArgument);
    EXPECT_NE(status.message().find("resolution"), std::string::npos) << status.message();
    csm::vk::RendererOptions badFormat;
    badFormat.depthFormat = VK_FORMAT_R8G8B8A8_UNORM;
    EXPECT_EQ(scene.update(settings, badFormat).code(), csm::vk::ErrorCode::kUnsupportedFormat);
    EXPECT_FALSE(renderer.ready());

    CSM_ASSERT_OK(scene.update(settings));
    // A frame computed for other settings.
    csm::Result<csm::CascadeFrame> other =
        csm::computeCascades(testSettings(3, 512), scene.csmCamera(), scene.light);
    ASSERT_TRUE(other.ok());
    scene.context().submitAndWait([&](VkCommandBuffer cmd) {
      status = renderer.recordShadowPass(cmd, other.value(), csm::vk::CasterList{}, nullptr);
    });
    EXPECT_EQ(status.code(), csm::vk::ErrorCode::kInvalidArgument) << status.message();
    // Visible lists and instances naming casters or meshes that do not exist.
    csm::CullResult cull;
    cull.visible[0] = {0, 7};
    const csm::vk::CasterInstance one{};
    scene.context().submitAndWait([&](VkCommandBuffer cmd) {
      status = renderer.recordShadowPass(cmd, frame.value(),
                                         csm::vk::CasterList{{}, std::span(&one, 1)}, &cull);
    });
    EXPECT_EQ(status.code(), csm::vk::ErrorCode::kIndexOutOfRange) << status.message();
    std::printf("%s\n", status.message().c_str());

    // Still usable: renders correctly afterwards.
    const Rendered r = scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
    const Agreement a = compareWithAnalytic(scene, r);
    EXPECT_GE(a.ratio(), 0.995);
  }
  EXPECT_EQ(validationMessages(), 0u);
}

TEST(ShadowApiMisuse, ResolutionAboveTheLimitIsRefusedAndTheRendererKeepsItsImage) {
  {
    ShadowScene scene;
    engine::Context& ctx = scene.context();
    // lavapipe's own limit (16384) equals the settings' maximum, so the device-limit path is
    // reached through the host's cap, which shares it.
    csm::vk::DeviceInfo info = glue::shadowDeviceInfo(ctx);
    info.maxResolution = 1024;
    csm::vk::Status status;
    auto renderer = csm::vk::ShadowRenderer::create(info, csm::vk::VertexLayout{}, &status);
    ASSERT_TRUE(renderer) << status.message();
    CSM_ASSERT_OK(renderer->update(testSettings(2, 1024)));
    const VkImage image = renderer->image();
    status = renderer->update(testSettings(2, 2048));
    EXPECT_EQ(status.code(), csm::vk::ErrorCode::kDeviceLimit) << status.message();
    EXPECT_NE(status.message().find("settings.resolution = 2048"), std::string::npos);
    EXPECT_NE(status.message().find("at most 1024"), std::string::npos) << status.message();
    // Nothing changed: the renderer keeps its image and accepts the next valid update.
    EXPECT_TRUE(renderer->ready());
    EXPECT_EQ(renderer->image(), image);
    CSM_ASSERT_OK(renderer->update(testSettings(3, 512)));
    EXPECT_TRUE(renderer->ready());
    renderer.reset();
  }
  EXPECT_EQ(validationMessages(), 0u);
}

}  // namespace
}  // namespace csm_test
