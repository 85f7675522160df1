// The module's lifetime promises, with validation on (any message fails): the lighting set can
// be sampled before the first shadow pass (it reads "lit"); settings can change between
// recording and submitting and with frames in flight; a view can be destroyed with a frame in
// flight; two views (split screen) record into one command buffer, each lighting its own camera;
// the domain's edges and casters outside it are refused by name.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include "glue/shadow_host.hpp"
#include "shadow_scene.hpp"

namespace csm_test {
namespace {

// Plane pixels of two images with the same camera: how many are darker in `shadowed` than in
// `unshadowed` (by more than 10 of 255) and how many are brighter (by more than 2).
struct Difference {
  uint64_t plane = 0;
  uint64_t darker = 0;
  uint64_t brighter = 0;
};
Difference compareImages(const ShadowScene& scene, const engine::CpuImage& unshadowed,
                         const engine::CpuImage& shadowed) {
  Difference d;
  scene.forEachGroundPixel(shadowed.width, shadowed.height,
                           [&](uint32_t x, uint32_t y, const glm::dvec3&) {
                             ++d.plane;
                             const int a = unshadowed.at(x, y)[0], b = shadowed.at(x, y)[0];
                             d.darker += b < a - 10 ? 1 : 0;
                             d.brighter += b > a + 2 ? 1 : 0;
                           });
  return d;
}

// Appends a mesh with no triangles (an "empty LOD") and returns its index.
std::uint32_t withEmptyMesh(std::vector<csm::vk::MeshDraw>& meshes) {
  meshes.push_back(csm::vk::MeshDraw{});  // indexCount 0: draws nothing
  return static_cast<std::uint32_t>(meshes.size() - 1);
}

// Plane pixels of the first three cascades, away from blend bands: how many are dark (< 128,
// shadowed) in the rendered shadow factor and how many the analytic shadow says are shadowed.
struct PerCascade {
  std::array<uint64_t, 3> dark{};
  std::array<uint64_t, 3> analytic{};
};
PerCascade shadowedPerCascade(const ShadowScene& scene, const Rendered& r) {
  PerCascade c;
  scene.forEachGroundPixel(r.image.width, r.image.height,
                           [&](uint32_t x, uint32_t y, const glm::dvec3& posWs) {
                             const csm::CascadeSelection sel = scene.selection(r.frame, posWs);
                             if (sel.index < 0 || sel.index >= 3 || sel.blendIndex >= 0) return;
                             c.dark[sel.index] += r.image.at(x, y)[0] < 128 ? 1 : 0;
                             c.analytic[sel.index] += scene.shadowedAnalytic(posWs) ? 1 : 0;
                           });
  return c;
}

TEST(ShadowLifetime, LightingSetSampledBeforeTheFirstShadowPassReadsLit) {
  {
    ShadowScene scene;
    CSM_ASSERT_OK(scene.update(testSettings(3, 512)));
    EXPECT_FALSE(scene.renderer().needsPrepare());  // cleared on DeviceInfo::queue by update()
    ShadowScene::FrameHooks noPass;
    noPass.shadowPass = false;
    const Rendered before = scene.renderFrame(csm::PcfKernel::kTent3, noPass);
    // The same shading (no debug output) with the shadow pass.
    ShadowScene::FrameHooks shaded;
    shaded.debug = csm::DebugMode::kNone;
    const Rendered with = scene.renderFrame(csm::PcfKernel::kTent3, shaded);
    const Agreement a = compareWithAnalytic(
        scene, scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor));
    // The uniform block holds no cascade before the first pass: every plane pixel is lit, and
    // the render with shadows darkens only (where the analytic answer is shadowed).
    const Difference d = compareImages(scene, before.image, with.image);
    std::printf(
        "before the first pass: %llu plane pixels, %llu darker with shadows, %llu brighter;"
        " analytic agreement with shadows %.4f (%llu shadowed)\n",
        (unsigned long long)d.plane, (unsigned long long)d.darker, (unsigned long long)d.brighter,
        a.ratio(), (unsigned long long)a.shadowed);
    EXPECT_GT(d.plane, 10000u);
    EXPECT_GE(d.darker, a.shadowed / 2);
    EXPECT_GT(d.darker, 500u);
    EXPECT_EQ(d.brighter, 0u);
    EXPECT_GE(a.ratio(), 0.995);
    scene.saveArtefact(before.image, "lifetime_before_first_pass");
    scene.saveArtefact(with.image, "lifetime_after_first_pass");
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// The moment sampler's anisotropy is checked against the device at creation: below 1, above the
// device's limit or not a number is refused, naming the field; 1 and the limit are accepted.
TEST(ShadowLifetime, MomentAnisotropyOutsideTheDevicesRangeIsRefusedByName) {
  {
    ShadowScene scene;
    const float limit = scene.context().properties().limits.maxSamplerAnisotropy;
    for (float bad :
         {0.5f, std::max(limit, 1.0f) * 2.0f, std::numeric_limits<float>::quiet_NaN()}) {
      csm::vk::DeviceInfo info = glue::shadowDeviceInfo(scene.context());
      info.maxSamplerAnisotropy = bad;
      csm::vk::Status status;
      EXPECT_FALSE(csm::vk::ShadowRenderer::create(info, csm::vk::VertexLayout{}, &status)) << bad;
      EXPECT_NE(status.message().find("DeviceInfo::maxSamplerAnisotropy"), std::string::npos)
          << status.message();
      EXPECT_NE(status.message().find("allowed"), std::string::npos) << status.message();
    }
    std::vector<float> good = {1.0f};
    if (scene.context().features().samplerAnisotropy) good.push_back(limit);
    for (float ok : good) {
      csm::vk::DeviceInfo info = glue::shadowDeviceInfo(scene.context(), ok);
      csm::vk::Status status;
      auto renderer = csm::vk::ShadowRenderer::create(info, csm::vk::VertexLayout{}, &status);
      ASSERT_TRUE(renderer) << status.message();
      EXPECT_EQ(renderer->momentAnisotropy(), ok);
    }
  }
  EXPECT_EQ(validationMessages(), 0u);
}

TEST(ShadowLifetime, WithoutAQueuePrepareRecordsTheClear) {
  {
    ShadowScene scene;
    csm::vk::DeviceInfo info = glue::shadowDeviceInfo(scene.context());
    info.queue = VK_NULL_HANDLE;
    csm::vk::Status status;
    auto renderer = csm::vk::ShadowRenderer::create(info, csm::vk::VertexLayout{}, &status);
    ASSERT_TRUE(renderer) << status.message();
    CSM_ASSERT_OK(renderer->update(testSettings(2, 512)));
    EXPECT_TRUE(renderer->needsPrepare());
    scene.context().submitAndWait([&](VkCommandBuffer cmd) { status = renderer->prepare(cmd); });
    CSM_ASSERT_OK(status);
    EXPECT_FALSE(renderer->needsPrepare());
  }
  EXPECT_EQ(validationMessages(), 0u);
}

TEST(ShadowLifetime, SettingsChangeBetweenRecordingAndSubmitting) {
  {
    ShadowScene scene;
    CSM_ASSERT_OK(scene.update(testSettings(2, 512)));
    (void)scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
    const VkImage first = scene.renderer().image();
    // The recorded frame uses the 512 image and its lighting set; the new settings replace
    // both before it is submitted. It must still run, with no validation message.
    ShadowScene::FrameHooks hooks;
    hooks.beforeSubmit = [&] {
      const csm::vk::Status s = scene.update(testSettings(3, 1024));
      EXPECT_TRUE(s.ok()) << s.message();
    };
    const Rendered recordedBefore = scene.renderFrame(csm::PcfKernel::kTent3, hooks);
    EXPECT_GE(compareWithAnalytic(scene, recordedBefore).ratio(), 0.99);
    EXPECT_NE(scene.renderer().image(), first);
    // The next frames render with the new settings, correctly, past the retirement of the old.
    for (int i = 0; i < 4; ++i) {
      const Rendered r = scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
      EXPECT_EQ(r.frame.cascadeCount, 3u);
      const Agreement a = compareWithAnalytic(scene, r);
      EXPECT_GE(a.ratio(), 0.995) << "frame " << i;
    }
  }
  EXPECT_EQ(validationMessages(), 0u);
}

TEST(ShadowLifetime, SettingsChangeWithFramesInFlight) {
  {
    ShadowScene scene;
    CSM_ASSERT_OK(scene.update(testSettings(2, 512)));
    // Each frame is submitted, then the settings change at once, with the frame still in flight
    // (the hook runs right after submission, before the frame's readback waits for it).
    const csm::ShadowSettings cycle[] = {testSettings(3, 1024), testSettings(2, 512),
                                         testSettings(4, 512), testSettings(1, 1024)};
    for (int i = 0; i < 8; ++i) {
      ShadowScene::FrameHooks hooks;
      const csm::ShadowSettings next = cycle[i % 4];
      hooks.afterSubmit = [&] {
        const csm::vk::Status s = scene.update(next);
        EXPECT_TRUE(s.ok()) << s.message();
      };
      const Rendered r = scene.renderFrame(csm::PcfKernel::kTent3, hooks);
      EXPECT_GE(compareWithAnalytic(scene, r).ratio(), 0.99) << "frame " << i;
    }
  }
  EXPECT_EQ(validationMessages(), 0u);
}

TEST(ShadowLifetime, ViewDestroyedWithAFrameInFlight) {
  {
    ShadowScene scene;
    CSM_ASSERT_OK(scene.update(testSettings(3, 1024)));
    (void)scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
    ShadowScene::FrameHooks hooks;
    hooks.afterSubmit = [&] { scene.destroyView(); };  // waits for DeviceInfo::queue
    const Rendered r = scene.renderFrame(csm::PcfKernel::kTent3, hooks);
    EXPECT_GT(r.image.width, 0u);
  }
  EXPECT_EQ(validationMessages(), 0u);
}

TEST(ShadowLifetime, TwoViewsRecordIntoOneCommandBufferEachLightingItsOwnCamera) {
  {
    ShadowScene scene;
    CSM_ASSERT_OK(scene.update(testSettings(3, 1024)));
    // The second camera: elsewhere, looking another way (split screen, two players).
    scene.secondCamera = scene.camera;
    scene.secondCamera.positionWs = {-8.0, 9.0, -4.0};
    scene.secondCamera.lookAt({2.0, 0.0, -20.0});
    scene.enableSecondView();
    for (int frame = 0; frame < 3; ++frame) {
      ShadowScene::FrameHooks first;
      const Rendered a = scene.renderFrame(csm::PcfKernel::kTent3, first);
      const Agreement ga = compareWithAnalytic(scene, a);
      ShadowScene::FrameHooks second;
      second.litFromSecond = true;
      const Rendered b = scene.renderFrame(csm::PcfKernel::kTent3, second);
      std::swap(scene.camera, scene.secondCamera);  // compare from the camera b was lit from
      const Agreement gb = compareWithAnalytic(scene, b);
      std::swap(scene.camera, scene.secondCamera);
      std::printf("frame %d: view 1 agrees %.4f (%llu px), view 2 agrees %.4f (%llu px)\n", frame,
                  ga.ratio(), (unsigned long long)ga.compared, gb.ratio(),
                  (unsigned long long)gb.compared);
      EXPECT_GE(ga.ratio(), 0.995);
      EXPECT_GE(gb.ratio(), 0.995);
      EXPECT_GT(ga.compared, 5000u);
      EXPECT_GT(gb.compared, 5000u);
      // The two views' frames differ (their own cameras), so neither borrowed the other's.
      EXPECT_NE(a.frame.cameraPositionWs, b.frame.cameraPositionWs);
      if (frame == 0) {
        scene.saveArtefact(a.image, "lifetime_split_view1");
        scene.saveArtefact(b.image, "lifetime_split_view2");
      }
    }
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// Caster LODs in the module: every caster but the ground gets an empty LOD 1 (no triangles), and
// the cascades that draw LOD 1 (the first and the last) show no shadow of them while the one
// that draws LOD 0 does; per-layer
// and layered (one instanced draw per distinct LOD mesh) alike.
TEST(ShadowView, CascadesDrawTheLodTheSettingsName) {
  {
    ShadowScene scene;
    CSM_ASSERT_OK(scene.update(testSettings(3, 1024)));
    (void)scene.render(csm::PcfKernel::k1Tap, csm::DebugMode::kShadowFactor);  // builds the scene
    csm::vk::ShadowView& view = scene.view();
    std::vector<csm::vk::MeshDraw> meshes(view.meshes().begin(), view.meshes().end());
    std::vector<csm::vk::CasterInstance> instances(view.instances().begin(),
                                                   view.instances().end());
    const std::uint32_t empty = withEmptyMesh(meshes);
    for (std::size_t i = 1; i < instances.size(); ++i) instances[i].lodMeshes[0] = empty;
    const std::vector<csm::AabbWs>& bounds = scene.casterBounds();
    CSM_ASSERT_OK(view.setCasters(meshes, instances, bounds));

    std::vector<csm::vk::RenderMode> modes = {csm::vk::RenderMode::kPerLayer};
    if (scene.context().features().shaderOutputLayer)
      modes.push_back(csm::vk::RenderMode::kLayered);
    for (csm::vk::RenderMode mode : modes) {
      SCOPED_TRACE(mode == csm::vk::RenderMode::kLayered ? "layered" : "per-layer");
      csm::vk::RendererOptions options;
      options.renderMode = mode;
      options.cascadeLod = {1, 0, 1};
      CSM_ASSERT_OK(scene.update(testSettings(3, 1024), options));
      const Rendered r = scene.render(csm::PcfKernel::k1Tap, csm::DebugMode::kShadowFactor);
      // Dark pixels (shadowed) by the cascade that shades them, away from blend bands.
      const auto [dark, analytic] = shadowedPerCascade(scene, r);
      std::printf(
          "cascade LODs {1, 0, 1}: shadowed pixels per cascade %llu, %llu, %llu "
          "(analytic %llu, %llu, %llu)\n",
          (unsigned long long)dark[0], (unsigned long long)dark[1], (unsigned long long)dark[2],
          (unsigned long long)analytic[0], (unsigned long long)analytic[1],
          (unsigned long long)analytic[2]);
      EXPECT_GT(analytic[1], 100u);
      EXPECT_GT(dark[1], analytic[1] / 2);  // LOD 0 casts
      EXPECT_GT(analytic[2], 100u);
      EXPECT_EQ(dark[0] + dark[2], 0u);  // LOD 1 is empty: nothing casts there
    }
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// LOD choice by texel error (csm::vk::casterLod): the coarsest LOD the instance has whose error
// is within maxErrorTexels of the cascade's texel; the schedule is a floor; unknown errors and a
// zero budget leave the schedule alone.
TEST(ShadowView, CasterLodIsTheCoarsestWithinTheTexelBudget) {
  csm::vk::CasterInstance in;
  in.lodMeshes = {7, 8, 9};
  in.lodErrorM = {0.125f, 0.375f, 2.0f};                 // exact in float and double
  EXPECT_EQ(csm::vk::casterLod(in, 0, 0.2, 0.5f), 0u);   // budget 0.1 m < 0.125 m
  EXPECT_EQ(csm::vk::casterLod(in, 0, 0.25, 0.5f), 1u);  // budget 0.125 m: LOD 1 exactly
  EXPECT_EQ(csm::vk::casterLod(in, 0, 0.74, 0.5f), 1u);  // 0.37 m < 0.375 m
  EXPECT_EQ(csm::vk::casterLod(in, 0, 0.75, 0.5f), 2u);  // 0.375 m
  EXPECT_EQ(csm::vk::casterLod(in, 0, 4.0, 0.5f), 3u);   // 2 m
  EXPECT_EQ(csm::vk::casterLod(in, 0, 4.0, 0.0f), 0u);   // budget off: the schedule alone
  EXPECT_EQ(csm::vk::casterLod(in, 2, 0.1, 0.5f), 2u);   // the schedule is a floor
  EXPECT_EQ(csm::vk::casterLod(in, 9, 0.1, 0.5f), 3u);   // clamped to the LODs there are
  in.lodMeshes[2] = csm::vk::kNoMesh;                    // no LOD 3: the next one that exists
  EXPECT_EQ(csm::vk::casterLod(in, 0, 4.0, 0.5f), 2u);
  in.lodErrorM = {csm::vk::kUnknownLodError, csm::vk::kUnknownLodError, csm::vk::kUnknownLodError};
  EXPECT_EQ(csm::vk::casterLod(in, 0, 1e6, 64.0f), 0u);  // unknown error: never by error
  EXPECT_EQ(csm::vk::casterLod(in, 1, 1e6, 64.0f), 1u);
}

// The renderer draws the LOD casterLod() chooses per (caster, cascade): every caster but the
// ground gets an empty LOD 1 whose error lies between the texels of cascades 1 and 2, so with
// half a texel of budget cascade 2 draws LOD 1 (no shadow) and cascades 0 and 1 draw LOD 0; with
// the budget off every cascade casts again. Per-layer and layered alike. Invalid budgets and
// errors are refused by name.
TEST(ShadowView, CascadesDrawTheLodTheirTexelErrorBudgetAllows) {
  {
    ShadowScene scene;
    CSM_ASSERT_OK(scene.update(testSettings(3, 1024)));
    const Rendered first = scene.render(csm::PcfKernel::k1Tap, csm::DebugMode::kShadowFactor);
    const double t1 =
        std::min(first.frame.cascades[1].texelSizeLs.x, first.frame.cascades[1].texelSizeLs.y);
    const double t2 =
        std::min(first.frame.cascades[2].texelSizeLs.x, first.frame.cascades[2].texelSizeLs.y);
    ASSERT_LT(t1 * 1.5, t2);
    // Half a texel of cascade 2 covers it, half a texel of cascade 1 does not.
    const float errorM = static_cast<float>(0.5 * std::sqrt(t1 * t2));
    std::printf("texels %.4f / %.4f m, LOD 1 error %.4f m\n", t1, t2, double(errorM));
    csm::vk::ShadowView& view = scene.view();
    std::vector<csm::vk::MeshDraw> meshes(view.meshes().begin(), view.meshes().end());
    std::vector<csm::vk::CasterInstance> instances(view.instances().begin(),
                                                   view.instances().end());
    const std::uint32_t empty = withEmptyMesh(meshes);
    for (std::size_t i = 1; i < instances.size(); ++i) {
      instances[i].lodMeshes[0] = empty;
      instances[i].lodErrorM[0] = errorM;
    }
    const std::vector<csm::AabbWs>& bounds = scene.casterBounds();
    CSM_ASSERT_OK(view.setCasters(meshes, instances, bounds));

    std::vector<csm::vk::RenderMode> modes = {csm::vk::RenderMode::kPerLayer};
    if (scene.context().features().shaderOutputLayer)
      modes.push_back(csm::vk::RenderMode::kLayered);
    for (csm::vk::RenderMode mode : modes) {
      for (float budget : {0.5f, 0.0f}) {
        SCOPED_TRACE(mode == csm::vk::RenderMode::kLayered ? "layered" : "per-layer");
        SCOPED_TRACE(budget);
        csm::vk::RendererOptions options;
        options.renderMode = mode;
        options.lodMaxErrorTexels = budget;
        CSM_ASSERT_OK(scene.update(testSettings(3, 1024), options));
        const Rendered r = scene.render(csm::PcfKernel::k1Tap, csm::DebugMode::kShadowFactor);
        const auto [dark, analytic] = shadowedPerCascade(scene, r);
        std::printf(
            "lodMaxErrorTexels %.1f: shadowed pixels per cascade %llu, %llu, %llu (analytic "
            "%llu, %llu, %llu)\n",
            double(budget), (unsigned long long)dark[0], (unsigned long long)dark[1],
            (unsigned long long)dark[2], (unsigned long long)analytic[0],
            (unsigned long long)analytic[1], (unsigned long long)analytic[2]);
        EXPECT_GT(analytic[1], 100u);
        EXPECT_GT(analytic[2], 100u);
        EXPECT_GT(dark[1], analytic[1] / 2);  // LOD 0: its error exceeds half a texel
        if (budget > 0.0f) {
          EXPECT_EQ(dark[2], 0u);  // the empty LOD 1 is within half a texel
        } else {
          EXPECT_GT(dark[2], analytic[2] / 2);  // budget off, schedule all 0: full detail
        }
      }
    }
    auto expectRefused = [](const csm::vk::Status& s, const char* name) {
      EXPECT_EQ(s.code(), csm::vk::ErrorCode::kInvalidArgument) << s.message();
      EXPECT_NE(s.message().find(name), std::string::npos) << s.message();
      std::printf("refused: %s\n", s.message().c_str());
    };
    for (float bad : {-0.5f, 65.0f, std::numeric_limits<float>::quiet_NaN()}) {
      csm::vk::RendererOptions options;
      options.lodMaxErrorTexels = bad;
      expectRefused(scene.update(testSettings(3, 1024), options), "options.lodMaxErrorTexels");
    }
    instances[1].lodErrorM[0] = -1.0f;
    expectRefused(view.setCasters(meshes, instances, bounds), "instances[1].lodErrorM[0]");
    instances[1].lodErrorM[0] = 0.0f;
    for (float bad : {-0.1f, 1001.0f, std::numeric_limits<float>::quiet_NaN(),
                      std::numeric_limits<float>::infinity()}) {
      instances[1].thinWidthM = bad;
      expectRefused(view.setCasters(meshes, instances, bounds), "instances[1].thinWidthM");
    }
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// Cached and uncached passes pack the uniform block alike: with D16 the depth floor carries
// D16's quantum in both (the cached pass once left UniformOptions::depthBits at 32). Stabilised
// per-layer cascades are windowed (toroidal layers) cached or not; unstabilised ones are not.
TEST(ShadowView, CachedAndUncachedPassesPackTheDepthFormatsQuantum) {
  {
    ShadowScene scene;
    for (int mode = 0; mode < 3; ++mode) {
      const bool cache = mode == 1, stabilize = mode != 2;
      SCOPED_TRACE(cache ? "cached" : (stabilize ? "uncached" : "unstabilised"));
      csm::vk::RendererOptions options;
      options.depthFormat = VK_FORMAT_D16_UNORM;
      options.cache = cache;
      csm::ShadowSettings settings = testSettings(4, 512);
      settings.diagnostics.stabilize = stabilize;
      CSM_ASSERT_OK(scene.update(settings, options));
      (void)scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
      EXPECT_EQ(scene.renderer().uniforms().depthFloorQuantum, csm::depthQuantum(16));
      EXPECT_EQ(scene.renderer().uniforms().wrappedLayers, stabilize ? 1u : 0u);
    }
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// Out-of-range enums and values are refused with a Status naming them, and a frame computed with
// other settings than the renderer's is refused naming the differing field.
TEST(ShadowView, OutOfRangeValuesAndMismatchedFramesAreRefusedByName) {
  {
    ShadowScene scene;
    CSM_ASSERT_OK(scene.update(testSettings(2, 512)));
    (void)scene.render(csm::PcfKernel::k1Tap, csm::DebugMode::kShadowFactor);
    csm::vk::ShadowView& view = scene.view();
    // kAuto (the default) chooses per-layer for stabilised cascades on every device, and for
    // unstabilised ones on a CPU implementation such as lavapipe; layered for unstabilised
    // cascades on a GPU that enabled shaderOutputLayer.
    const bool cpu = scene.context().properties().deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
    EXPECT_EQ(scene.renderer().renderMode(), csm::vk::RenderMode::kPerLayer);
    csm::ShadowSettings unstable = testSettings(2, 512);
    unstable.diagnostics.stabilize = false;
    CSM_ASSERT_OK(view.setSettings(unstable));
    EXPECT_EQ(scene.renderer().renderMode(), !cpu && scene.context().features().shaderOutputLayer
                                                 ? csm::vk::RenderMode::kLayered
                                                 : csm::vk::RenderMode::kPerLayer);
    CSM_ASSERT_OK(view.setSettings(testSettings(2, 512)));
    auto expectRefused = [](const csm::vk::Status& s, const char* name) {
      EXPECT_EQ(s.code(), csm::vk::ErrorCode::kInvalidArgument) << s.message();
      EXPECT_NE(s.message().find(name), std::string::npos) << s.message();
      std::printf("refused: %s\n", s.message().c_str());
    };
    csm::vk::RendererOptions badMode;
    badMode.renderMode = static_cast<csm::vk::RenderMode>(7);
    expectRefused(view.setSettings(testSettings(2, 512), badMode), "options.renderMode = 7");
    csm::vk::RendererOptions badLod;
    badLod.cascadeLod[1] = 9;
    expectRefused(view.setSettings(testSettings(2, 512), badLod), "options.cascadeLod[1] = 9");

    csm::vk::Status status;
    view.setDebugMode(static_cast<csm::DebugMode>(99));
    scene.context().submitAndWait(
        [&](VkCommandBuffer cmd) { status = view.record(cmd, scene.csmCamera(), scene.light); });
    expectRefused(status, "debugMode = 99");
    view.setDebugMode(csm::DebugMode::kNone);

    // A frame computed with another blend band / normal offset than the renderer's settings.
    csm::ShadowSettings other = testSettings(2, 512);
    other.blendBand = 0.3;
    auto frame = csm::computeCascades(other, scene.csmCamera(), scene.light);
    ASSERT_TRUE(frame.ok());
    scene.context().submitAndWait(
        [&](VkCommandBuffer cmd) { status = view.record(cmd, frame.value()); });
    expectRefused(status, "frame.blendBand = 0.3");
    other = testSettings(2, 512);
    other.normalOffsetTexels = 2.0f;
    frame = csm::computeCascades(other, scene.csmCamera(), scene.light);
    ASSERT_TRUE(frame.ok());
    scene.context().submitAndWait(
        [&](VkCommandBuffer cmd) { status = view.record(cmd, frame.value()); });
    expectRefused(status, "frame.normalOffsetTexels = 2");

    csm::vk::DeviceInfo info = glue::shadowDeviceInfo(scene.context());
    info.framesInFlight = 0;
    EXPECT_EQ(csm::vk::ShadowView::create(info, csm::vk::VertexLayout{}, &status), nullptr);
    expectRefused(status, "framesInFlight = 0");

    // Still usable, and correct.
    const Rendered r = scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
    EXPECT_GE(compareWithAnalytic(scene, r).ratio(), 0.995);
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// The domain's edges (types.hpp) are refused by name, casters with transforms that are not
// finite or lie outside it are refused naming the instance and field and leave the previous
// casters, and setCasters() between compute() and recordPass() re-culls instead of failing.
TEST(ShadowView, DomainEdgesAndNonFiniteCastersAreRefusedByName) {
  {
    ShadowScene scene;
    CSM_ASSERT_OK(scene.update(testSettings(2, 512)));
    (void)scene.render(csm::PcfKernel::k1Tap, csm::DebugMode::kShadowFactor);
    csm::vk::ShadowView& view = scene.view();
    auto expectRefused = [](const csm::vk::Status& s, const char* name) {
      EXPECT_FALSE(s.ok());
      EXPECT_NE(s.message().find(name), std::string::npos) << s.message();
      std::printf("refused: %s\n", s.message().c_str());
    };
    const std::vector<csm::vk::MeshDraw> meshes(view.meshes().begin(), view.meshes().end());
    const std::vector<csm::vk::CasterInstance> good(view.instances().begin(),
                                                    view.instances().end());
    const std::vector<csm::AabbWs>& bounds = scene.casterBounds();
    ASSERT_GE(good.size(), 3u);

    auto withBad = [&](auto edit) {
      std::vector<csm::vk::CasterInstance> bad = good;
      edit(bad[2]);
      return view.setCasters(meshes, bad, bounds);
    };
    const double nan = std::numeric_limits<double>::quiet_NaN();
    expectRefused(withBad([&](auto& c) { c.translationWs.y = nan; }),
                  "casters.instances[2].translationWs.y = nan");
    expectRefused(withBad([](auto& c) { c.translationWs.x = 2e9; }),
                  "casters.instances[2].translationWs.x = 2e+09");
    expectRefused(
        withBad([](auto& c) { c.linearWs[1][0] = std::numeric_limits<float>::infinity(); }),
        "casters.instances[2].linearWs[1][0] = inf");
    std::vector<csm::AabbWs> farBounds = bounds;
    farBounds[1].maxWs.z = 1.5e9;
    expectRefused(view.setCasters(meshes, good, farBounds), "caster.maxWs[2] = 1500000000");
    EXPECT_EQ(view.casterCount(), good.size());  // the previous casters stayed

    csm::Camera cam = scene.csmCamera();
    cam.positionWs.x = 1.0000001e9;
    expectRefused(view.compute(cam, scene.light), "camera.positionWs.x = 1000000100");
    cam = scene.csmCamera();
    cam.nearM = 1e-7;
    expectRefused(view.compute(cam, scene.light), "camera.nearM = ");
    cam = scene.csmCamera();
    cam.farM = cam.nearM * 2e10;
    expectRefused(view.compute(cam, scene.light), "camera.farM");

    // compute(); setCasters() with the last instance left out; recordPass() culls the new list.
    CSM_ASSERT_OK(view.compute(scene.csmCamera(), scene.light));
    const std::vector<csm::vk::CasterInstance> fewer(good.begin(), good.end() - 1);
    const std::vector<csm::AabbWs> fewerBounds(bounds.begin(), bounds.end() - 1);
    CSM_ASSERT_OK(view.setCasters(meshes, fewer, fewerBounds));
    csm::vk::Status status;
    scene.context().submitAndWait([&](VkCommandBuffer cmd) { status = view.recordPass(cmd); });
    CSM_ASSERT_OK(status);
    std::size_t listed = 0;
    for (std::uint32_t c = 0; c < view.frame().cascadeCount; ++c) {
      for (std::uint32_t i : view.cull().visible[c]) {
        EXPECT_LT(i, fewer.size());
        ++listed;
      }
    }
    EXPECT_GT(listed, 0u);
    CSM_ASSERT_OK(view.setCasters(meshes, good, bounds));

    // Still usable, and correct.
    const Rendered r = scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
    EXPECT_GE(compareWithAnalytic(scene, r).ratio(), 0.995);
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// A shadow distance that does not reach past the near plane is refused by setSettings() once
// the view has seen a camera, instead of failing every later frame; the view stays usable.
TEST(ShadowView, ShadowDistanceInsideTheNearPlaneIsRefusedBySetSettings) {
  {
    ShadowScene scene;
    CSM_ASSERT_OK(scene.update(testSettings(2, 512)));
    (void)scene.render(csm::PcfKernel::k1Tap, csm::DebugMode::kShadowFactor);
    csm::ShadowSettings bad = testSettings(2, 512);
    bad.shadowDistanceM = scene.csmCamera().nearM * 0.5;
    const csm::vk::Status s = scene.view().setSettings(bad);
    EXPECT_EQ(s.code(), csm::vk::ErrorCode::kInvalidArgument);
    EXPECT_NE(s.message().find("settings.shadowDistanceM"), std::string::npos) << s.message();
    EXPECT_EQ(scene.view().settings().shadowDistanceM, testSettings(2, 512).shadowDistanceM);
    const Rendered r = scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
    EXPECT_GE(compareWithAnalytic(scene, r).ratio(), 0.995);
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// setSettings(settings) keeps the options given before (it used to reset them to the defaults:
// the cache off, D32, no LODs); setSettings(settings, options) replaces them.
TEST(ShadowView, SetSettingsWithoutOptionsKeepsTheOptions) {
  {
    ShadowScene scene;
    csm::vk::RendererOptions options;
    options.cache = true;
    options.depthFormat = VK_FORMAT_D16_UNORM;
    options.cascadeLod[1] = 2;
    CSM_ASSERT_OK(scene.update(testSettings(2, 512), options));
    csm::ShadowSettings next = testSettings(2, 512);
    next.blendBand = 0.2;
    CSM_ASSERT_OK(scene.view().setSettings(next));
    EXPECT_TRUE(scene.view().options().cache);
    EXPECT_EQ(scene.view().options().depthFormat, VK_FORMAT_D16_UNORM);
    EXPECT_EQ(scene.view().options().cascadeLod[1], 2u);
    EXPECT_EQ(scene.renderer().depthFormat(), VK_FORMAT_D16_UNORM);
    EXPECT_EQ(scene.view().settings().blendBand, 0.2);
    CSM_ASSERT_OK(scene.view().setSettings(next, csm::vk::RendererOptions{}));
    EXPECT_FALSE(scene.view().options().cache);
    EXPECT_EQ(scene.renderer().depthFormat(), VK_FORMAT_D32_SFLOAT);
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// The filter is a setting: the view's specialization of the lighting pipeline follows its
// settings (kernel, blend band, PCSS taps), a refused change leaves it whole, and a pipeline
// built from it renders what one specialised by hand with the same filter renders, bit for bit
// (and not what the shader's defaults render).
TEST(ShadowView, LightingSpecializationFollowsTheSettings) {
  {
    ShadowScene scene;
    csm::ShadowSettings settings = testSettings(2, 512);
    settings.kernel = csm::PcfKernel::kTent7;
    CSM_ASSERT_OK(scene.update(settings));
    const VkSpecializationInfo* info = scene.view().lightingSpecializationInfo();
    ASSERT_NE(info, nullptr);
    ASSERT_EQ(info->mapEntryCount, csm::kLightingSpecConstantCount);
    // What a pipeline created with `info` reads, by constant id.
    auto valueOf = [&](std::uint32_t id) {
      for (std::uint32_t i = 0; i < info->mapEntryCount; ++i) {
        const VkSpecializationMapEntry& e = info->pMapEntries[i];
        if (e.constantID != id) continue;
        EXPECT_EQ(e.size, sizeof(std::uint32_t));
        EXPECT_LE(e.offset + e.size, info->dataSize);
        std::uint32_t v = 0;
        std::memcpy(&v, static_cast<const char*>(info->pData) + e.offset, sizeof v);
        return v;
      }
      ADD_FAILURE() << "constant " << id << " missing";
      return 0xffffffffu;
    };
    EXPECT_EQ(valueOf(CSM_SPEC_KERNEL), std::uint32_t(CSM_KERNEL_TENT7));
    EXPECT_EQ(valueOf(CSM_SPEC_BLEND), 1u);
    EXPECT_EQ(valueOf(CSM_SPEC_PCSS_TAPS), std::uint32_t(CSM_PCSS_DEFAULT_TAPS));

    ShadowScene::FrameHooks byView;
    byView.viewSpecialization = true;
    ShadowScene::FrameHooks byHand;
    const Rendered viewTent7 = scene.renderFrame(csm::PcfKernel::kTent3, byView);
    const Rendered handTent7 = scene.renderFrame(csm::PcfKernel::kTent7, byHand);
    const Rendered handTent3 = scene.renderFrame(csm::PcfKernel::kTent3, byHand);
    EXPECT_TRUE(viewTent7.image.rgba == handTent7.image.rgba);
    EXPECT_FALSE(viewTent7.image.rgba == handTent3.image.rgba)
        << "tent 7x7 and the default tent 3x3 must differ here, or this proves nothing";

    // Refused (naming the field): the constants stay.
    csm::ShadowSettings bad = settings;
    bad.kernel = csm::PcfKernel::kPcss;
    bad.pcssTaps = CSM_PCSS_MAX_TAPS + 1;
    const csm::vk::Status refused = scene.view().setSettings(bad);
    EXPECT_EQ(refused.code(), csm::vk::ErrorCode::kInvalidArgument);
    EXPECT_NE(refused.message().find("settings.pcssTaps"), std::string::npos) << refused.message();
    EXPECT_EQ(valueOf(CSM_SPEC_KERNEL), std::uint32_t(CSM_KERNEL_TENT7));

    // Accepted: PCSS with 32 taps and no band (the hard switch), through the same pointer.
    settings.kernel = csm::PcfKernel::kPcss;
    settings.pcssTaps = 32;
    settings.blendBand = 0.0;
    CSM_ASSERT_OK(scene.view().setSettings(settings));
    EXPECT_EQ(scene.view().lightingSpecializationInfo(), info);
    EXPECT_EQ(valueOf(CSM_SPEC_KERNEL), std::uint32_t(CSM_KERNEL_PCSS));
    EXPECT_EQ(valueOf(CSM_SPEC_BLEND), 0u);
    EXPECT_EQ(valueOf(CSM_SPEC_PCSS_TAPS), 32u);
    const csm::vk::LightingSpecialization copy = scene.view().lightingSpecialization();
    EXPECT_TRUE(copy == csm::vk::LightingSpecialization(settings));
    EXPECT_FALSE(copy == csm::vk::LightingSpecialization(testSettings(2, 512)));
    // With the shader's own tap count, PCSS and the hard switch render as the same filter
    // specialised by hand.
    settings.pcssTaps = CSM_PCSS_DEFAULT_TAPS;
    CSM_ASSERT_OK(scene.view().setSettings(settings));
    byHand.blend = false;
    const Rendered viewPcss = scene.renderFrame(csm::PcfKernel::kTent3, byView);
    const Rendered handPcss = scene.renderFrame(csm::PcfKernel::kPcss, byHand);
    EXPECT_TRUE(viewPcss.image.rgba == handPcss.image.rgba);
    EXPECT_FALSE(viewPcss.image.rgba == viewTent7.image.rgba);
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// setSettings() is all or nothing: a Vulkan failure injected at each step of update() that
// creates objects (after the steps before it succeeded) leaves the settings, options, image,
// lighting set, static image and thin pipelines as they were, and the next frame renders the
// same image bit for bit; without the fault the same change then succeeds.
TEST(ShadowView, SetSettingsIsAllOrNothingUnderFaultsAtEachStep) {
  using Step = csm::vk::ShadowRenderer::UpdateStep;
  struct Change {
    const char* name;
    Step step;
    std::uint32_t resolution;
    VkFormat format;
    float widen;
  };
  const Change changes[] = {
      {"depth format (pipelines)", Step::kPipelines, 512, VK_FORMAT_D16_UNORM, 0.0625f},
      {"resolution (image)", Step::kImage, 1024, VK_FORMAT_D32_SFLOAT, 0.0625f},
      {"resolution (static image)", Step::kStaticImage, 1024, VK_FORMAT_D32_SFLOAT, 0.0625f},
      {"thin widening (thin pipelines)", Step::kThinPipelines, 512, VK_FORMAT_D32_SFLOAT, 0.25f},
      {"resolution (thin pipelines, last)", Step::kThinPipelines, 1024, VK_FORMAT_D32_SFLOAT,
       0.0625f},
  };
  for (const Change& change : changes) {
    SCOPED_TRACE(change.name);
    ShadowScene scene;
    csm::vk::RendererOptions options;
    options.cache = true;
    options.thinCasterWidenTexels = 0.0625f;
    CSM_ASSERT_OK(scene.update(testSettings(2, 512), options));
    const Rendered before = scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
    csm::vk::ShadowRenderer& renderer = scene.renderer();
    ASSERT_GT(renderer.thinMarginTexels(), 0.0f) << "lavapipe has a geometry stage";
    const VkImage image = renderer.image();
    const VkImage staticImage = renderer.staticImage();
    const VkDescriptorSet set = renderer.lightingSet();
    const float margin = renderer.thinMarginTexels();

    csm::vk::RendererOptions next = options;
    next.depthFormat = change.format;
    next.thinCasterWidenTexels = change.widen;
    renderer.failNextUpdateAt(change.step);
    // The change also picks another filter: a failure keeps the pipeline's constants too.
    csm::ShadowSettings changedSettings = testSettings(2, change.resolution);
    changedSettings.kernel = csm::PcfKernel::kTent5;
    const VkSpecializationInfo* spec = scene.view().lightingSpecializationInfo();
    const csm::vk::Status s = scene.view().setSettings(changedSettings, next);
    EXPECT_EQ(s.code(), csm::vk::ErrorCode::kVulkan) << s.message();
    EXPECT_NE(s.message().find("injected"), std::string::npos) << s.message();
    EXPECT_EQ(scene.view().settings().resolution, 512u);
    EXPECT_EQ(scene.view().options().depthFormat, VK_FORMAT_D32_SFLOAT);
    EXPECT_EQ(scene.view().options().thinCasterWidenTexels, 0.0625f);
    EXPECT_EQ(renderer.depthFormat(), VK_FORMAT_D32_SFLOAT);
    EXPECT_EQ(renderer.image(), image);
    EXPECT_EQ(renderer.staticImage(), staticImage);
    EXPECT_EQ(renderer.lightingSet(), set);
    EXPECT_EQ(renderer.thinMarginTexels(), margin);
    const Rendered after = scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
    EXPECT_TRUE(after.image.rgba == before.image.rgba) << "the image changed after a refusal";
    EXPECT_EQ(scene.view().lightingSpecialization().value(CSM_SPEC_KERNEL),
              static_cast<std::uint32_t>(testSettings(2, 512).kernel));

    CSM_ASSERT_OK(scene.view().setSettings(changedSettings, next));
    EXPECT_EQ(scene.view().lightingSpecializationInfo(), spec) << "the pointer stays the view's";
    EXPECT_EQ(scene.view().lightingSpecialization().value(CSM_SPEC_KERNEL),
              std::uint32_t(CSM_KERNEL_TENT5));
    EXPECT_EQ(renderer.depthFormat(), change.format);
    EXPECT_EQ(scene.view().settings().resolution, change.resolution);
    const Rendered changed = scene.render(csm::PcfKernel::kTent3, csm::DebugMode::kShadowFactor);
    EXPECT_GE(compareWithAnalytic(scene, changed).ratio(), 0.995);
  }
  EXPECT_EQ(validationMessages(), 0u);
}

namespace {

// Pixels of `a` and `b` whose red channel differs by more than `tolerance` (8-bit).
std::size_t differingPixels(const engine::CpuImage& a, const engine::CpuImage& b, int tolerance) {
  std::size_t n = 0;
  for (std::size_t i = 0; i + 3 < a.rgba.size() && i + 3 < b.rgba.size(); i += 4) {
    if (std::abs(int(a.rgba[i]) - int(b.rgba[i])) > tolerance) ++n;
  }
  return n;
}

}  // namespace

// The prefiltered filters through the view, cached and not: a change of kernel to, between and
// from vsm, evsm and msm makes (and retires) the moment image with the frames in flight, and
// every frame renders validation-clean. Each prefiltered image differs from the 3x3 tent's
// (the moments are read, not the depth binding) but puts its shadows where the tent does (few
// pixels differ by more than a penumbra's grey); the same frame twice is the same image (the
// resolve is deterministic); back on the tent, the first image again, bit for bit.
TEST(ShadowView, PrefilteredKernelsSwitchWithFramesInFlight) {
  for (bool cache : {false, true}) {
    SCOPED_TRACE(cache ? "cache on" : "cache off");
    ShadowScene scene;
    csm::vk::RendererOptions options;
    options.cache = cache;
    csm::ShadowSettings settings = testSettings(2, 512);
    settings.kernel = csm::PcfKernel::kTent3;
    CSM_ASSERT_OK(scene.update(settings, options));
    ShadowScene::FrameHooks byView;
    byView.viewSpecialization = true;
    const Rendered tent = scene.renderFrame(csm::PcfKernel::kTent3, byView);
    const std::size_t pixels = tent.image.rgba.size() / 4;
    for (csm::PcfKernel k : {csm::PcfKernel::kVsm, csm::PcfKernel::kEvsm, csm::PcfKernel::kMsm,
                             csm::PcfKernel::kVsm}) {
      SCOPED_TRACE(csm::kernelName(k));
      settings.kernel = k;
      CSM_ASSERT_OK(scene.update(settings, options));
      const Rendered first = scene.renderFrame(csm::PcfKernel::kTent3, byView);
      const Rendered again = scene.renderFrame(csm::PcfKernel::kTent3, byView);
      EXPECT_TRUE(first.image.rgba == again.image.rgba);
      const std::size_t changed = differingPixels(first.image, tent.image, 0);
      const std::size_t far = differingPixels(first.image, tent.image, 96);
      EXPECT_GT(changed, 50u) << "the moments must be read";
      EXPECT_LT(far, pixels / 50) << "shadows where the tent puts them";
    }
    settings.kernel = csm::PcfKernel::kTent3;
    CSM_ASSERT_OK(scene.update(settings, options));
    const Rendered back = scene.renderFrame(csm::PcfKernel::kTent3, byView);
    EXPECT_TRUE(back.image.rgba == tent.image.rgba);
  }
  EXPECT_EQ(validationMessages(), 0u);
}

}  // namespace
}  // namespace csm_test
