// Cached cascades (RendererOptions::cache) against a full re-render of the same frame: every
// frame of a flight, with dynamic casters moving and static casters added and removed, all
// texels of every non-empty cascade are bit-identical; validation (synchronization included)
// stays silent.
#include <gtest/gtest.h>

#include <csm/core.hpp>
#include <csm/moments.hpp>
#include <csm/vulkan/shadow_view.hpp>
#include <engine/context.hpp>
#include <engine/debug.hpp>
#include <engine/memory.hpp>
#include <engine/mesh_store.hpp>
#include <glue/shadow_host.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace {

constexpr std::uint32_t kResolution = 512;
constexpr std::uint32_t kCascades = 3;

/// Copies `regions` of `image` (`aspect`; in the renderer's sampled layout, last written by its
/// pass or moment resolve) into `buffer`, then returns the image to that layout.
void copyToBuffer(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect,
                  std::span<const VkBufferImageCopy> regions, VkBuffer buffer) {
  const VkImageLayout sampled = csm::vk::ShadowRenderer::sampledLayout();
  engine::imageBarrier(
      cmd, image, aspect,
      VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
      VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT, sampled,
      VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
  vkCmdCopyImageToBuffer(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buffer,
                         static_cast<std::uint32_t>(regions.size()), regions.data());
  engine::imageBarrier(cmd, image, aspect, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE,
                       VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_NONE,
                       VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, sampled);
}

/// One view and the buffer its layers are read back into.
struct ViewRig {
  std::unique_ptr<csm::vk::ShadowView> view;
  std::unique_ptr<engine::Buffer> readback;
  /// Records the view's pass instead of ShadowView::record (another form of the same pass).
  std::function<csm::vk::Status(VkCommandBuffer, const csm::Camera&, const csm::DirectionalLight&)>
      record;
};

class CacheRig {
 public:
  CacheRig() {
    engine::resetValidationCounts();
    engine::ContextDesc desc;
    desc.appName = "csm cache tests";
    desc.validation = true;
    ctx_ = std::make_unique<engine::Context>(desc);
    meshes_ = std::make_unique<engine::MeshStore>(*ctx_, 1 << 14, 1 << 15, "cache test meshes");
    std::vector<engine::Vertex> v = {{{-1, 0, -1}, {0, 1, 0}},
                                     {{1, 0, -1}, {0, 1, 0}},
                                     {{1, 0, 1}, {0, 1, 0}},
                                     {{-1, 0, 1}, {0, 1, 0}}};
    std::vector<std::uint32_t> idx = {0, 2, 1, 0, 3, 2};
    const engine::MeshRange plane = meshes_->upload(v, idx);
    engine::makeCube(v, idx);
    const engine::MeshRange cube = meshes_->upload(v, idx);
    for (const engine::MeshRange& m : {plane, cube}) {
      csm::vk::MeshDraw d;
      d.vertexBuffer = meshes_->vertexBuffer();
      d.indexBuffer = meshes_->indexBuffer();
      d.firstIndex = m.firstIndex;
      d.indexCount = m.indexCount;
      d.vertexOffset = m.vertexOffset;
      meshDraws_.push_back(d);
    }
    // Static: a 400 m ground and a grid of boxes of varied sizes and yaw.
    addStatic(0, {0, 0, 0}, glm::dvec3(200, 1, 200), 0.0);
    for (int i = -8; i <= 8; ++i) {
      for (int j = -8; j <= 8; ++j) {
        const double h = 1.0 + double((i * 7 + j * 13) & 7);
        const double s = 0.6 + 0.15 * double((i * 3 + j * 5) & 7);
        addStatic(1, {i * 11.0 + 3.0, h * 0.5, j * 11.0 - 2.0}, {s, h, s}, 0.3 * (i + j));
      }
    }
    staticCount_ = instances_.size();
  }

  ~CacheRig() {
    if (ctx_) ctx_->waitIdle();
    views_.clear();
    meshes_.reset();
    if (ctx_) ctx_->shutdown();
  }

  void addStatic(std::uint32_t mesh, const glm::dvec3& at, const glm::dvec3& size, double yaw) {
    csm::vk::CasterInstance inst;
    inst.mesh = mesh;
    inst.translationWs = at;
    const double c = std::cos(yaw), s = std::sin(yaw);
    // Unit cube [-1, 1]^3 / quad scaled to `size` (half extents), then yawed.
    inst.linearWs =
        glm::mat3(glm::dmat3(glm::dvec3(c, 0, -s), glm::dvec3(0, 1, 0), glm::dvec3(s, 0, c)) *
                  glm::dmat3(glm::dvec3(size.x * 0.5, 0, 0),
                             glm::dvec3(0, size.y * (mesh == 0 ? 1.0 : 0.5), 0),
                             glm::dvec3(0, 0, size.z * 0.5)));
    instances_.push_back(inst);
    bounds_.push_back(boundsOf(inst));
  }

  /// World bounds of a unit-cube (or quad) instance: its transformed corners.
  static csm::AabbWs boundsOf(const csm::vk::CasterInstance& inst) {
    csm::AabbWs b{glm::dvec3(1e300), glm::dvec3(-1e300)};
    for (int k = 0; k < 8; ++k) {
      const glm::dvec3 p((k & 1) ? 1 : -1, (k & 2) ? 1 : -1, (k & 4) ? 1 : -1);
      const glm::dvec3 q = inst.translationWs + glm::dvec3(glm::dmat3(inst.linearWs) * p);
      b.minWs = glm::min(b.minWs, q);
      b.maxWs = glm::max(b.maxWs, q);
    }
    return b;
  }

  /// Adds a view: cached, or the reference (cached but fully re-rendered every frame).
  ViewRig& addView(std::uint64_t budgetTexels = 0,
                   csm::CacheRestore restore = csm::ShadowDiagnostics{}.cacheRestore) {
    csm::vk::RendererOptions options;
    options.cache = true;
    options.renderMode = csm::vk::RenderMode::kPerLayer;
    options.cacheBudgetTexels = budgetTexels;
    csm::ShadowDiagnostics diagnostics;
    diagnostics.cacheRestore = restore;
    return addView(options, diagnostics);
  }

  /// Adds a view drawn with `options` and `diagnostics` (the cascades, distance and scene of
  /// every view).
  ViewRig& addView(const csm::vk::RendererOptions& options,
                   const csm::ShadowDiagnostics& diagnostics = {}) {
    ViewRig rig;
    rig.view = glue::createShadowView(*ctx_);
    csm::ShadowSettings settings;
    settings.diagnostics = diagnostics;
    settings.cascadeCount = kCascades;
    settings.resolution = kResolution;
    settings.shadowDistanceM = 120.0;
    csm::vk::Status s = rig.view->setSettings(settings, options);
    if (!s.ok()) throw std::runtime_error(s.message());
    const csm::AabbWs scene{{-200, -1, -200}, {200, 20, 200}};
    s = rig.view->setSceneBounds(&scene);
    if (!s.ok()) throw std::runtime_error(s.message());
    const VkDeviceSize bytes = VkDeviceSize(kResolution) * kResolution * 4 * kCascades;
    rig.readback =
        std::make_unique<engine::Buffer>(*ctx_, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                         engine::MemoryUsage::Readback, "cache test readback");
    views_.push_back(std::move(rig));
    return views_.back();
  }

  /// Dynamic casters at frame `f`: a "vehicle" driving along x and a turning "blade".
  void setDynamic(int f) {
    instances_.resize(staticCount_ + extra_.size());
    bounds_.resize(instances_.size());
    for (std::size_t k = 0; k < extra_.size(); ++k) {
      instances_[staticCount_ + k] = extra_[k];
      bounds_[staticCount_ + k] = boundsOf(extra_[k]);
    }
    csm::vk::CasterInstance car;
    car.mesh = 1;
    car.dynamic = true;
    car.translationWs = {-60.0 + 0.7 * f, 1.0, -4.0};
    car.linearWs = glm::mat3(glm::dmat3(2.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0));
    csm::vk::CasterInstance blade = car;
    const double a = 0.05 * f;
    blade.translationWs = {2.0, 9.0, -14.0};
    blade.linearWs =
        glm::mat3(glm::dmat3(glm::dvec3(std::cos(a), std::sin(a), 0),
                             glm::dvec3(-std::sin(a), std::cos(a), 0), glm::dvec3(0, 0, 1)) *
                  glm::dmat3(6.0, 0, 0, 0, 0.3, 0, 0, 0, 0.3));
    for (const auto& d : {car, blade}) {
      instances_.push_back(d);
      bounds_.push_back(boundsOf(d));
    }
  }

  /// Records every view's pass for `camera` and `light`, submits, and reads the layers back.
  void frame(const csm::Camera& camera, const csm::DirectionalLight& light,
             const std::vector<bool>& fullRender) {
    for (std::size_t v = 0; v < views_.size(); ++v) {
      if (fullRender[v]) views_[v].view->invalidateAll();
    }
    ctx_->submitAndWait([&](VkCommandBuffer cmd) {
      for (ViewRig& rig : views_) {
        csm::vk::Status s =
            rig.record ? rig.record(cmd, camera, light) : rig.view->record(cmd, camera, light);
        ASSERT_TRUE(s.ok()) << s.message();
      }
      for (ViewRig& rig : views_) {
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 0, kCascades};
        region.imageExtent = {kResolution, kResolution, 1};
        copyToBuffer(cmd, rig.view->renderer().image(), VK_IMAGE_ASPECT_DEPTH_BIT, {&region, 1},
                     rig.readback->handle());
      }
    });
  }

  /// Texels of non-empty cascades where views a and b differ (bitwise), and the first one.
  std::uint64_t differences(std::size_t a, std::size_t b, std::string* first) const {
    const auto* pa = static_cast<const std::uint32_t*>(views_[a].readback->mapped());
    const auto* pb = static_cast<const std::uint32_t*>(views_[b].readback->mapped());
    const csm::CascadeFrame& fa = views_[a].view->frame();
    std::uint64_t n = 0;
    const std::size_t layer = std::size_t(kResolution) * kResolution;
    for (std::uint32_t c = 0; c < kCascades; ++c) {
      if (fa.cascades[c].empty) continue;
      for (std::size_t t = 0; t < layer; ++t) {
        if (pa[c * layer + t] != pb[c * layer + t]) {
          if (n == 0 && first != nullptr) {
            float x, y;
            std::memcpy(&x, &pa[c * layer + t], 4);
            std::memcpy(&y, &pb[c * layer + t], 4);
            *first = "cascade " + std::to_string(c) + " texel (" + std::to_string(t % kResolution) +
                     ", " + std::to_string(t / kResolution) + "): " + std::to_string(x) + " vs " +
                     std::to_string(y);
          }
          ++n;
        }
      }
    }
    return n;
  }

  std::unique_ptr<engine::Context> ctx_;
  std::unique_ptr<engine::MeshStore> meshes_;
  std::vector<csm::vk::MeshDraw> meshDraws_;
  std::vector<csm::vk::CasterInstance> instances_;
  std::vector<csm::AabbWs> bounds_;
  std::vector<csm::vk::CasterInstance> extra_;  // static casters added mid-flight
  std::size_t staticCount_ = 0;
  std::vector<ViewRig> views_;
};

/// The camera of frame f on a path: "walk" (1.4 m/s at 60 Hz, turning), "fast" (100 m/s,
/// straight and climbing), "turn" (in place, looking around), "sun" (walk with the sun moving
/// every 40 frames: new windows).
csm::Camera pathCamera(const std::string& path, int f) {
  csm::Camera cam;
  cam.aspect = 16.0 / 9.0;
  cam.nearM = 0.1;
  cam.farM = 400.0;
  double x = 0, z = 0, y = 2.0, yaw = 0.0, pitch = -0.15;
  if (path == "walk" || path == "sun") {
    x = 0.023 * f;
    z = -0.02 * f;
    yaw = 0.004 * f;
  } else if (path == "fast") {
    x = -90.0 + 1.6 * f;
    z = 10.0 - 0.4 * f;
    y = 3.0 + 0.05 * f;
    yaw = -1.2;
  } else {
    x = 1.0 + 0.01 * f;
    yaw = 0.03 * f;
    pitch = -0.1 - 0.2 * std::sin(0.02 * f);
  }
  cam.positionWs = {x, y, z};
  cam.orientationWs =
      glm::angleAxis(yaw, glm::dvec3(0, 1, 0)) * glm::angleAxis(pitch, glm::dvec3(1, 0, 0));
  return cam;
}

/// The sun path turns the light every 40 frames by `step` (0.02: about a degree; CacheBudget
/// takes larger steps, so that culling in the old light's basis and in the new one differ).
csm::DirectionalLight pathLight(const std::string& path, int f, double step = 0.02) {
  double a = 0.0;
  if (path == "sun") a = step * double(f / 40);
  return {glm::normalize(glm::dvec3(0.5 + a, -1.0, -0.3))};
}

int flightFrames() {
  const char* env = std::getenv("CSM_CACHE_TEST_FRAMES");
  return env != nullptr ? std::max(2, std::atoi(env)) : 240;
}

class CacheFlight : public ::testing::TestWithParam<std::string> {};

// Views: 0 cached, 1 the reference (fully re-rendered every frame), 2 cached but never given the
// caster added mid-flight (the map without it).
TEST_P(CacheFlight, EveryFrameBitIdenticalToFullRender) {
  // "path" or "path_restore": the cached view restores its layers by the shader copy (the
  // default), by redrawing, by rectangle copies or by whole-layer copies.
  const std::string path = GetParam().substr(0, GetParam().find('_'));
  csm::CacheRestore restore = csm::CacheRestore::kShaderCopy;
  if (GetParam().ends_with("_redraw")) restore = csm::CacheRestore::kRedraw;
  if (GetParam().ends_with("_copyrects")) restore = csm::CacheRestore::kCopyRects;
  if (GetParam().ends_with("_wholelayer")) restore = csm::CacheRestore::kWholeLayer;
  CacheRig rig;
  rig.addView(0, restore);
  rig.addView();
  rig.addView();
  const int frames = flightFrames();
  const int addAt = frames / 3, removeAt = 2 * frames / 3;
  std::uint64_t cachedTexels = 0, fullTexels = 0, copiedTexels = 0, copiedLayers = 0;
  std::uint64_t mergedDraws = 0;
  for (int f = 0; f < frames; ++f) {
    const csm::Camera cam = pathCamera(path, f);
    const csm::DirectionalLight light = pathLight(path, f);
    // A static box near the camera, added and removed mid-flight (views 0 and 1 only).
    rig.extra_.clear();
    if (f >= addAt && f < removeAt) {
      csm::vk::CasterInstance box;
      box.mesh = 1;
      const glm::dvec3 at =
          pathCamera(path, addAt).positionWs + pathCamera(path, addAt).forwardWs() * 8.0;
      box.translationWs = {at.x, 2.0, at.z};
      box.linearWs = glm::mat3(glm::dmat3(1.5, 0, 0, 0, 2.0, 0, 0, 0, 1.5));
      rig.extra_.push_back(box);
    }
    rig.setDynamic(f);
    // View 2 never sees the extra box: set its casters without it.
    {
      auto instances = rig.instances_;
      auto bounds = rig.bounds_;
      if (!rig.extra_.empty()) {
        instances.erase(instances.begin() + std::ptrdiff_t(rig.staticCount_));
        bounds.erase(bounds.begin() + std::ptrdiff_t(rig.staticCount_));
      }
      csm::vk::Status s = rig.views_[2].view->setCasters(rig.meshDraws_, instances, bounds);
      ASSERT_TRUE(s.ok()) << s.message();
    }
    for (std::size_t v = 0; v < 2; ++v) {
      csm::vk::Status s =
          rig.views_[v].view->setCasters(rig.meshDraws_, rig.instances_, rig.bounds_);
      ASSERT_TRUE(s.ok()) << s.message();
    }
    rig.frame(cam, light, {false, true, false});
    if (HasFailure()) return;
    std::string first;
    const std::uint64_t diff = rig.differences(0, 1, &first);
    ASSERT_EQ(diff, 0u) << path << " frame " << f << ": " << diff
                        << " texels differ from the full render, first at " << first;
    const std::uint64_t withoutBox = rig.differences(0, 2, nullptr);
    if (f == addAt) {
      EXPECT_GT(withoutBox, 0u) << "the added box does not show on the frame it was added";
    }
    if (f == removeAt || f < addAt) {
      EXPECT_EQ(withoutBox, 0u) << path << " frame " << f
                                << ": the removed box still shows (or the views diverged)";
    }
    for (std::uint32_t c = 0; c < kCascades; ++c) {
      cachedTexels += rig.views_[0].view->renderer().cacheStats()[c].staticTexels;
      fullTexels += rig.views_[1].view->renderer().cacheStats()[c].staticTexels;
      const csm::vk::CascadeCacheStats& st = rig.views_[0].view->renderer().cacheStats()[c];
      copiedTexels += st.restoredTexels;
      copiedLayers += st.copied || st.restoredTexels > 0 ? 1 : 0;
      mergedDraws += st.mergedDraws;
    }
  }
  EXPECT_EQ(engine::validationMessageCount(), 0u);
  // The cache renders a fraction of the texels (it can fail: a cache that re-rendered
  // everything would pass the identity above).
  std::printf("[cache] %s: %d frames, static texels re-rendered cached %llu, full %llu (%.2f%%)\n",
              path.c_str(), frames, static_cast<unsigned long long>(cachedTexels),
              static_cast<unsigned long long>(fullTexels),
              100.0 * double(cachedTexels) / double(std::max<std::uint64_t>(fullTexels, 1)));
  EXPECT_LT(cachedTexels * 4, fullTexels);
  // Only the changed rectangles are copied into the sampled layers (the dynamic casters of the
  // last and this frame, the re-rendered strips), not whole layers.
  const std::uint64_t layer = std::uint64_t(kResolution) * kResolution;
  std::printf(
      "[cache] %s: restored %llu texels in %llu layers (%.2f%% of whole layers)\n",
      GetParam().c_str(), static_cast<unsigned long long>(copiedTexels),
      static_cast<unsigned long long>(copiedLayers),
      100.0 * double(copiedTexels) / double(std::max<std::uint64_t>(copiedLayers * layer, 1)));
  std::printf("[cache] %s: %llu draws saved by drawing a caster once over several rectangles\n",
              GetParam().c_str(), static_cast<unsigned long long>(mergedDraws));
  if (restore != csm::CacheRestore::kWholeLayer) {
    EXPECT_LT(copiedTexels * 4, copiedLayers * layer);
  }
}

// A still camera re-renders nothing; an invalidated box re-renders only the texels under it
// (and the result is still bit-identical to a full render).
TEST(ShadowCache, InvalidatedBoxRerendersOnlyItsTexels) {
  CacheRig rig;
  rig.addView();
  rig.addView();
  const csm::Camera cam = pathCamera("walk", 0);
  const csm::DirectionalLight light = pathLight("walk", 0);
  for (std::size_t v = 0; v < 2; ++v) {
    csm::vk::Status s = rig.views_[v].view->setCasters(rig.meshDraws_, rig.instances_, rig.bounds_);
    ASSERT_TRUE(s.ok()) << s.message();
  }
  rig.frame(cam, light, {false, true});
  rig.frame(cam, light, {false, true});
  const auto& stats = rig.views_[0].view->renderer().cacheStats();
  for (std::uint32_t c = 0; c < kCascades; ++c) {
    EXPECT_EQ(stats[c].staticTexels, 0u) << "cascade " << c;
    EXPECT_FALSE(stats[c].copied) << "cascade " << c << ": nothing changed, nothing copied";
  }
  const csm::AabbWs box{{1.0, 0.0, -8.0}, {3.0, 3.0, -6.0}};
  ASSERT_TRUE(rig.views_[0].view->invalidate(box).ok());
  rig.frame(cam, light, {false, true});
  std::string first;
  EXPECT_EQ(rig.differences(0, 1, &first), 0u) << first;
  const std::uint64_t layer = std::uint64_t(kResolution) * kResolution;
  EXPECT_GT(stats[0].staticTexels, 0u);
  EXPECT_LT(stats[0].staticTexels * 50, layer) << "a 2 m box is a small part of cascade 0";
  // Refused: an invalid box, caching without stabilised cascades or with a layered pass.
  EXPECT_FALSE(rig.views_[0].view->invalidate({{0.0, 0.0, 0.0}, {-1.0, 1.0, 1.0}}).ok());
  csm::ShadowSettings settings = rig.views_[0].view->settings();
  csm::vk::RendererOptions options = rig.views_[0].view->options();
  settings.diagnostics.stabilize = false;
  csm::vk::Status s = rig.views_[0].view->setSettings(settings, options);
  EXPECT_EQ(s.code(), csm::vk::ErrorCode::kInvalidArgument);
  EXPECT_NE(s.message().find("stabilize"), std::string::npos) << s.message();
  settings.diagnostics.stabilize = true;
  options.renderMode = csm::vk::RenderMode::kLayered;
  s = rig.views_[0].view->setSettings(settings, options);
  EXPECT_EQ(s.code(), csm::vk::ErrorCode::kInvalidArgument);
  // A frame the windows were not applied to is refused by the renderer.
  auto frame = rig.views_[0].view->computeFrame(cam, light);
  ASSERT_TRUE(frame.ok());
  rig.ctx_->submitAndWait([&](VkCommandBuffer cmd) {
    const csm::vk::Status r = rig.views_[0].view->renderer().recordShadowPass(
        cmd, frame.value(), csm::vk::CasterList{rig.meshDraws_, rig.instances_, rig.bounds_},
        &rig.views_[0].view->cull());
    EXPECT_EQ(r.code(), csm::vk::ErrorCode::kInvalidArgument) << r.message();
  });
  EXPECT_EQ(engine::validationMessageCount(), 0u);
}

// Casters by handle: view 0 is given its casters once and then only changes (the two dynamic
// movers updated every frame; a static box added, moved, removed, and another added into its
// slot), view 1 the whole list every frame and a full render. Every frame's layers are bit for
// bit the same, stale handles are refused by name, and a removed caster is culled into no list.
TEST(ShadowCache, CastersByHandleStayBitIdenticalToFullRender) {
  CacheRig rig;
  rig.addView();
  rig.addView();
  csm::vk::ShadowView& view = *rig.views_[0].view;
  rig.setDynamic(0);
  ASSERT_TRUE(view.setCasters(rig.meshDraws_, rig.instances_, rig.bounds_).ok());
  const std::uint32_t car = static_cast<std::uint32_t>(rig.staticCount_);
  const csm::vk::CasterHandle carHandle = view.casterHandle(car);
  const csm::vk::CasterHandle bladeHandle = view.casterHandle(car + 1);
  ASSERT_TRUE(view.valid(carHandle));
  ASSERT_TRUE(view.valid(bladeHandle));
  csm::vk::CasterHandle box{}, first{};
  csm::vk::CasterInstance boxInstance;
  boxInstance.mesh = 1;
  boxInstance.linearWs = glm::mat3(glm::dmat3(1.5, 0, 0, 0, 2.0, 0, 0, 0, 1.5));
  constexpr int kFrames = 60;
  for (int f = 0; f < kFrames; ++f) {
    SCOPED_TRACE("frame " + std::to_string(f));
    const csm::Camera cam = pathCamera("walk", f);
    const csm::DirectionalLight light = pathLight("walk", f);
    // The static box 8 m ahead of where the camera was at frame 10, moved 3 m at frame 25.
    if (f == 10 || f == 25) {
      const glm::dvec3 at = pathCamera("walk", 10).positionWs +
                            pathCamera("walk", 10).forwardWs() * (f == 10 ? 8.0 : 11.0);
      boxInstance.translationWs = {at.x, 2.0, at.z};
      if (f == 10) {
        ASSERT_TRUE(view.addCaster(boxInstance, CacheRig::boundsOf(boxInstance), &box).ok());
        first = box;
      } else {
        ASSERT_TRUE(view.updateCaster(box, boxInstance, CacheRig::boundsOf(boxInstance)).ok());
      }
    }
    if (f == 40) {
      ASSERT_TRUE(view.removeCaster(box).ok());
      EXPECT_FALSE(view.valid(box));
      const csm::vk::Status stale = view.removeCaster(box);
      EXPECT_EQ(stale.code(), csm::vk::ErrorCode::kInvalidArgument);
      EXPECT_NE(stale.message().find("names no caster"), std::string::npos) << stale.message();
    }
    if (f == 45) {  // another box, into the removed one's slot; the old handle stays stale
      boxInstance.translationWs += glm::dvec3(-4.0, 0.0, 2.0);
      ASSERT_TRUE(view.addCaster(boxInstance, CacheRig::boundsOf(boxInstance), &box).ok());
      EXPECT_EQ(box.index, first.index);
      EXPECT_NE(box.generation, first.generation);
      EXPECT_FALSE(view.valid(first));
      EXPECT_FALSE(view.updateCaster(first, boxInstance, CacheRig::boundsOf(boxInstance)).ok());
    }
    // The movers: only they change, by handle.
    rig.setDynamic(f);
    ASSERT_TRUE(view.updateCaster(carHandle, rig.instances_[car], rig.bounds_[car]).ok());
    ASSERT_TRUE(view.updateCaster(bladeHandle, rig.instances_[car + 1], rig.bounds_[car + 1]).ok());
    // The reference: the whole list (the box while it exists), fully rendered.
    auto instances = rig.instances_;
    auto bounds = rig.bounds_;
    if (f >= 10 && f != 40 && f != 41 && f != 42 && f != 43 && f != 44) {
      instances.push_back(boxInstance);
      bounds.push_back(CacheRig::boundsOf(boxInstance));
    }
    ASSERT_TRUE(rig.views_[1].view->setCasters(rig.meshDraws_, instances, bounds).ok());
    rig.frame(cam, light, {false, true});
    if (HasFailure()) return;
    std::string firstDiff;
    const std::uint64_t diff = rig.differences(0, 1, &firstDiff);
    ASSERT_EQ(diff, 0u) << diff << " texels differ from the full render, first at " << firstDiff;
    if (f >= 40 && f < 45) {
      for (std::uint32_t c = 0; c < kCascades; ++c) {
        for (std::uint32_t i : view.cull().visible[c]) ASSERT_NE(i, first.index);
      }
    }
  }
  // Refused by name, nothing changed: an instance naming a mesh that does not exist, bounds
  // that are not a box, no handle to fill.
  csm::vk::CasterInstance bad = boxInstance;
  bad.mesh = 7;
  const std::size_t slots = view.casterCount();
  csm::vk::CasterHandle none{};
  const csm::vk::Status mesh = view.addCaster(bad, CacheRig::boundsOf(boxInstance), &none);
  EXPECT_EQ(mesh.code(), csm::vk::ErrorCode::kIndexOutOfRange);
  EXPECT_NE(mesh.message().find("mesh = 7"), std::string::npos) << mesh.message();
  const csm::vk::Status box2 =
      view.updateCaster(box, boxInstance, {{0.0, 0.0, 0.0}, {-1.0, 1.0, 1.0}});
  EXPECT_EQ(box2.code(), csm::vk::ErrorCode::kInvalidArgument);
  EXPECT_NE(box2.message().find("caster.maxWs[0]"), std::string::npos) << box2.message();
  EXPECT_FALSE(view.addCaster(boxInstance, CacheRig::boundsOf(boxInstance), nullptr).ok());
  EXPECT_EQ(view.casterCount(), slots);
  EXPECT_TRUE(view.valid(box));
  // setCasters replaces the set: every earlier handle is stale.
  ASSERT_TRUE(view.setCasters(rig.meshDraws_, rig.instances_, rig.bounds_).ok());
  EXPECT_FALSE(view.valid(carHandle));
  EXPECT_FALSE(view.valid(box));
  EXPECT_TRUE(view.valid(view.casterHandle(car)));
  EXPECT_EQ(engine::validationMessageCount(), 0u);
}

/// The layer `c` of view `v` as read back by the last frame.
std::vector<std::uint32_t> layerOf(const CacheRig& rig, std::size_t v, std::uint32_t c) {
  const auto* p = static_cast<const std::uint32_t*>(rig.views_[v].readback->mapped());
  const std::size_t layer = std::size_t(kResolution) * kResolution;
  return {p + c * layer, p + (c + 1) * layer};
}

class CacheBudget : public ::testing::TestWithParam<std::string> {};

// A texel budget of one layer per frame (the least allowed): cascade 0 is bit-identical to a
// full render every frame; the other cascades re-render at most the budget per frame; a cascade
// that is refreshed is bit-identical to the full render, one that is deferred shows exactly what
// it showed at its last refresh with that refresh's box and matrix (without dynamic casters,
// "sun": its texels unchanged), and once the camera stops every cascade is bit-identical within
// a frame per cascade. View 0 is also invalidated whole every 30 frames and on the first still
// frame (all cascades want a layer each: the budget must spread them); the sun path changes the
// light every 40 frames (deferred cascades keep the old light's basis, their casters culled in
// it).
TEST_P(CacheBudget, NearExactFarLagConsistentlyAndConverge) {
  const std::string path = GetParam().substr(0, GetParam().find('_'));
  const bool dynamic = GetParam() != "sun";  // "sun": no dynamic casters, deferred layers still
  const std::uint64_t budget = std::uint64_t(kResolution) * kResolution;
  CacheRig rig;
  rig.addView(budget);
  rig.addView();
  const int moving = std::max(2, flightFrames() / 2), still = 8;
  std::array<csm::Cascade, kCascades> shownCascade{};
  std::array<glm::dmat3, kCascades> shownBasis{};
  std::array<std::vector<std::uint32_t>, kCascades> shownLayer;
  std::uint64_t deferredFrames = 0;
  std::uint64_t oldBasisFrames = 0;  // cascade-frames deferred across a change of light
  // Cascade-frames whose cull in the old basis differs from one in the current basis.
  std::uint64_t basisMattered = 0;
  std::uint32_t maxLag = 0;
  int convergedAt = -1;
  for (int f = 0; f < moving + still; ++f) {
    const int at = std::min(f, moving - 1);
    const csm::Camera cam = pathCamera(path, at);
    // Steps of about 10 degrees: a deferred cascade's casters culled in the new light's basis
    // differ from those in the old one (counted below: the basis check can fail).
    const csm::DirectionalLight light = pathLight(path, at, 0.25);
    if (dynamic) {
      rig.setDynamic(f);
    } else {
      rig.instances_.resize(rig.staticCount_);
      rig.bounds_.resize(rig.staticCount_);
    }
    for (std::size_t v = 0; v < 2; ++v) {
      csm::vk::Status s =
          rig.views_[v].view->setCasters(rig.meshDraws_, rig.instances_, rig.bounds_);
      ASSERT_TRUE(s.ok()) << s.message();
    }
    if ((f % 30 == 15 && f < moving) || f == moving) rig.views_[0].view->invalidateAll();
    rig.frame(cam, light, {false, true});
    if (HasFailure()) return;
    const auto& stats = rig.views_[0].view->renderer().cacheStats();
    const csm::CascadeFrame& fr = rig.views_[0].view->frame();
    const csm::CascadeFrame& ref = rig.views_[1].view->frame();
    // The view culled each cascade once, in the basis the plan draws it in: its lists are a
    // cull of the same casters with the plan's bases (a deferred cascade across a change of
    // light: the old light's).
    {
      csm::CasterSet set;
      for (const csm::AabbWs& b : rig.bounds_) ASSERT_TRUE(set.addBox(b.minWs, b.maxWs).ok());
      set.build();
      const csm::CachePlan& plan = rig.views_[0].view->renderer().cachePlan();
      std::array<glm::dmat3, kCascades> bases;
      for (std::uint32_t c = 0; c < kCascades; ++c) {
        bases[c] = plan.cascades[c].active ? plan.cascades[c].basis : fr.lightBasisWs;
        if (plan.cascades[c].active && !(bases[c] == fr.lightBasisWs)) ++oldBasisFrames;
      }
      csm::CullResult expected;
      csm::cullCasters(set, fr, csm::ShadowSettings{}.minCasterTexels, expected,
                       std::span(bases.data(), fr.cascadeCount));
      for (std::uint32_t c = 0; c < fr.cascadeCount; ++c) {
        ASSERT_EQ(rig.views_[0].view->cull().visible[c], expected.visible[c])
            << path << " frame " << f << " cascade " << c << ": not culled in the plan's basis";
      }
      // What a cull in this frame's light basis alone would have given: where it differs for a
      // cascade shown in the old basis, the check above tells the two apart.
      csm::CullResult current;
      csm::cullCasters(set, fr, csm::ShadowSettings{}.minCasterTexels, current);
      for (std::uint32_t c = 0; c < fr.cascadeCount; ++c) {
        if (!(bases[c] == fr.lightBasisWs) && current.visible[c] != expected.visible[c]) {
          ++basisMattered;
        }
      }
    }
    std::uint64_t capped = 0;
    bool allExact = true;
    for (std::uint32_t c = 0; c < kCascades; ++c) {
      if (fr.cascades[c].empty) continue;
      const std::string where =
          path + " frame " + std::to_string(f) + " cascade " + std::to_string(c);
      // Capped: cascades beyond the exact one, after their first frame (nothing to show yet).
      if (c > 0 && !shownLayer[c].empty()) capped += stats[c].staticTexels;
      const std::vector<std::uint32_t> layer = layerOf(rig, 0, c);
      // The renderer's public plan says what it recorded: refreshed or deferred, and the basis
      // a host culls the cascade in (the old light's for a deferred one).
      const csm::CachePlan& plan = rig.views_[0].view->renderer().cachePlan();
      ASSERT_EQ(plan.cascades[c].refreshed, !stats[c].deferred) << where;
      ASSERT_TRUE(plan.cascades[c].basis == (stats[c].deferred ? shownBasis[c] : fr.lightBasisWs))
          << where;
      if (!stats[c].deferred) {
        ASSERT_EQ(stats[c].lagFrames, 0u) << where;
        ASSERT_TRUE(layer == layerOf(rig, 1, c)) << where << ": refreshed but not bit-identical";
        ASSERT_EQ(fr.cascades[c].boxCenterWs, ref.cascades[c].boxCenterWs) << where;
        shownCascade[c] = fr.cascades[c];
        shownBasis[c] = fr.lightBasisWs;
        shownLayer[c] = layer;
        continue;
      }
      ASSERT_GT(c, 0u) << where << ": cascade 0 must be exact";
      allExact = false;
      ++deferredFrames;
      maxLag = std::max(maxLag, stats[c].lagFrames);
      // Self-consistent: the box, window and matrix of its last refresh (about today's camera).
      const csm::Cascade& was = shownCascade[c];
      ASSERT_EQ(fr.cascades[c].boxCenterWs, was.boxCenterWs) << where;
      ASSERT_EQ(fr.cascades[c].halfExtentLs, was.halfExtentLs) << where;
      ASSERT_EQ(fr.cascades[c].depthNearLs, was.depthNearLs) << where;
      ASSERT_EQ(fr.cascades[c].depthFarLs, was.depthFarLs) << where;
      const glm::mat4 m = csm::cameraRelativeViewProj(shownBasis[c], cam.positionWs, was);
      ASSERT_TRUE(rig.views_[0].view->renderer().uniforms().cascades[c].viewProjCr == m) << where;
      if (!dynamic) {
        ASSERT_TRUE(layer == shownLayer[c]) << where << ": a deferred layer changed";
      }
    }
    EXPECT_LE(capped, budget) << path << " frame " << f << ": over the budget";
    if (f >= moving && allExact && convergedAt < 0) convergedAt = f - moving;
    if (f >= moving && convergedAt >= 0) {
      std::string first;
      ASSERT_EQ(rig.differences(0, 1, &first), 0u)
          << path << " still frame " << f - moving << ": " << first;
    }
  }
  std::printf(
      "[cache budget] %s: %llu cascade-frames deferred (%llu across a change of light, %llu "
      "whose cull in the new light's basis would differ), largest lag %u frames, exact %d "
      "frames after the camera stopped\n",
      path.c_str(), static_cast<unsigned long long>(deferredFrames),
      static_cast<unsigned long long>(oldBasisFrames),
      static_cast<unsigned long long>(basisMattered), maxLag, convergedAt);
  EXPECT_GT(deferredFrames, 0u) << "the budget never deferred anything: the test tests nothing";
  if (path == "sun") {
    EXPECT_GT(oldBasisFrames, 0u) << "no cascade deferred across a change of light";
    EXPECT_GT(basisMattered, 0u) << "the light's step never changed a deferred cascade's cull: "
                                    "culling in the wrong basis would go unseen";
  }
  ASSERT_GE(convergedAt, 0) << "never converged after the camera stopped";
  EXPECT_LE(convergedAt, int(kCascades) - 1) << "one frame per lagging cascade at most";
  EXPECT_EQ(engine::validationMessageCount(), 0u);
}

TEST(ShadowCache, BudgetOptionsAreValidated) {
  CacheRig rig;
  rig.addView();
  csm::ShadowSettings settings = rig.views_[0].view->settings();
  csm::vk::RendererOptions options = rig.views_[0].view->options();
  options.cacheBudgetTexels = std::uint64_t(kResolution) * kResolution - 1;
  csm::vk::Status s = rig.views_[0].view->setSettings(settings, options);
  EXPECT_EQ(s.code(), csm::vk::ErrorCode::kInvalidArgument);
  EXPECT_NE(s.message().find("cacheBudgetTexels = 262143"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("262144"), std::string::npos) << s.message();
  options.cacheBudgetTexels = 0;
  options.cacheExactCascades = 0;
  s = rig.views_[0].view->setSettings(settings, options);
  EXPECT_NE(s.message().find("cacheExactCascades = 0 is invalid: allowed [1, 8]"),
            std::string::npos)
      << s.message();
  options.cacheExactCascades = 2;
  options.cacheBudgetTexels = std::uint64_t(kResolution) * kResolution;
  EXPECT_TRUE(rig.views_[0].view->setSettings(settings, options).ok());
  // The tile budget: at least one tile, (resolution / 16)^2 = 1,024 texels at 512^2.
  options.tileBudgetTexels = 1023;
  s = rig.views_[0].view->setSettings(settings, options);
  EXPECT_EQ(s.code(), csm::vk::ErrorCode::kInvalidArgument);
  EXPECT_NE(s.message().find("options.tileBudgetTexels = 1023 is invalid: allowed 0 (no cap) or "
                             "at least one tile, (settings.resolution / 16)^2 = 1024"),
            std::string::npos)
      << s.message();
  options.tileBudgetTexels = 1024;
  EXPECT_TRUE(rig.views_[0].view->setSettings(settings, options).ok());
}

double medianOf(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Not a test (timings decide nothing): what restoring the sampled layers costs with whole-layer
// copies and with the changed rectangles, cache on, the two views recorded alternately in one
// run (each frame in the other order). By hand, for the docs (CSM_CACHE_TIMING_B=shadercopy,
// the default, redraw or copyrects: how the second view restores its rectangles):
//   CSM_CACHE_TIMING_RES=4096 shadow_cache_tests --gtest_also_run_disabled_tests
//       --gtest_filter='*CopyRectsVsWholeLayer*'
TEST(ShadowCacheTiming, DISABLED_CopyRectsVsWholeLayer) {
  CacheRig rig;
  const char* resEnv = std::getenv("CSM_CACHE_TIMING_RES");
  const std::uint32_t res = resEnv != nullptr ? std::uint32_t(std::atoi(resEnv)) : 4096u;
  const int frames = std::max(4, flightFrames() / 4);
  const char* bEnv = std::getenv("CSM_CACHE_TIMING_B");
  const std::string bName = bEnv != nullptr ? bEnv : "shadercopy";
  csm::CacheRestore restoreB = csm::CacheRestore::kShaderCopy;
  if (bName == "copyrects") restoreB = csm::CacheRestore::kCopyRects;
  if (bName == "redraw") restoreB = csm::CacheRestore::kRedraw;
  std::array<std::unique_ptr<csm::vk::ShadowView>, 2> views;
  for (std::size_t v = 0; v < 2; ++v) {
    views[v] = glue::createShadowView(*rig.ctx_);
    csm::ShadowSettings settings;
    settings.cascadeCount = kCascades;
    settings.resolution = res;
    settings.shadowDistanceM = 120.0;
    csm::vk::RendererOptions options;
    options.cache = true;
    options.renderMode = csm::vk::RenderMode::kPerLayer;
    settings.diagnostics.cacheRestore = v == 0 ? csm::CacheRestore::kWholeLayer : restoreB;
    ASSERT_TRUE(views[v]->setSettings(settings, options).ok());
    const csm::AabbWs scene{{-200, -1, -200}, {200, 20, 200}};
    ASSERT_TRUE(views[v]->setSceneBounds(&scene).ok());
  }
  std::array<std::vector<double>, 2> ms;
  std::vector<double> ratio;
  std::array<std::uint64_t, 2> copied{};
  for (int f = 0; f < frames; ++f) {
    const csm::Camera cam = pathCamera("walk", f);
    const csm::DirectionalLight light = pathLight("walk", f);
    rig.setDynamic(f);
    std::array<double, 2> t{};
    for (int k = 0; k < 2; ++k) {
      const std::size_t v = std::size_t((f + k) % 2);
      ASSERT_TRUE(views[v]->setCasters(rig.meshDraws_, rig.instances_, rig.bounds_).ok());
      const auto start = std::chrono::steady_clock::now();
      rig.ctx_->submitAndWait([&](VkCommandBuffer cmd) {
        const csm::vk::Status s = views[v]->record(cmd, cam, light);
        ASSERT_TRUE(s.ok()) << s.message();
      });
      t[v] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                 .count();
      for (std::uint32_t c = 0; c < kCascades; ++c) {
        copied[v] += views[v]->renderer().cacheStats()[c].restoredTexels;
      }
    }
    if (f < 2) continue;  // the first frames render everything
    ms[0].push_back(t[0]);
    ms[1].push_back(t[1]);
    ratio.push_back(t[0] / t[1]);
  }
  std::printf(
      "[cache copy] %ux%u^2, %d frames (walk, 2 dynamic casters): shadow pass median "
      "%.2f ms whole-layer copies, %.2f ms %s; median per-frame ratio %.2fx; "
      "texels copied %.3g vs %.3g\n",
      kCascades, res, frames - 2, medianOf(ms[0]), medianOf(ms[1]),
      restoreB == csm::CacheRestore::kCopyRects ? "rectangle copies"
      : restoreB == csm::CacheRestore::kRedraw  ? "redrawn rectangles"
                                                : "shader-copied rectangles",
      medianOf(ratio), double(copied[0]), double(copied[1]));
  EXPECT_EQ(engine::validationMessageCount(), 0u);
}

// Closed casters (CasterInstance::closed): culling their faces turned away from the light keeps
// every texel's depth up to float rounding (per-layer, layered and cached, with a mirrored box,
// moving dynamic casters and a moving sun): culling only removes candidates, so no texel may get
// nearer, and where one gets deeper it is by rounding only (a back face's depth plane evaluated
// at a silhouette texel can come out a few ulps nearer than the front face's). An inside-out box
// flagged closed then shows its far faces' depth: the culling happens, in the stated winding.
TEST(ClosedCasters, CullingKeepsEveryTexelsDepth) {
  CacheRig rig;
  // A mirrored box (negative determinant: its winding turns), then every box flagged closed.
  rig.addStatic(1, {5.0, 1.5, -10.0}, {2.0, 3.0, 1.5}, 0.4);
  rig.instances_.back().linearWs[0] *= -1.0f;
  rig.staticCount_ = rig.instances_.size();
  for (std::size_t i = 1; i < rig.staticCount_; ++i) rig.instances_[i].closed = true;
  // Views in pairs, culling on then off: per-layer, cached, and layered where the device can.
  std::vector<std::string> names = {"per-layer", "cached"};
  for (int pair = 0; pair < 3; ++pair) {
    csm::vk::RendererOptions options;
    options.renderMode = csm::vk::RenderMode::kPerLayer;
    options.cache = pair == 1;
    if (pair == 2) {
      if (!rig.ctx_->features().shaderOutputLayer) break;
      options.renderMode = csm::vk::RenderMode::kLayered;
      names.push_back("layered");
    }
    for (bool cull : {true, false}) {
      csm::ShadowDiagnostics diagnostics;
      diagnostics.cullClosedCasters = cull;
      rig.addView(options, diagnostics);
    }
  }
  const std::size_t views = rig.views_.size();
  const int frames = std::min(flightFrames(), 48);
  std::uint64_t compared = 0, differing = 0, nearer = 0;
  float largest = 0.0f;  // largest depth difference, in units of the depth range
  for (const char* path : {"fast", "sun"}) {
    for (int f = 0; f < frames; ++f) {
      rig.setDynamic(f);
      for (std::size_t i = rig.staticCount_; i < rig.instances_.size(); ++i) {
        rig.instances_[i].closed = true;
      }
      for (ViewRig& v : rig.views_) {
        const csm::vk::Status s = v.view->setCasters(rig.meshDraws_, rig.instances_, rig.bounds_);
        ASSERT_TRUE(s.ok()) << s.message();
      }
      rig.frame(pathCamera(path, f), pathLight(path, f), std::vector<bool>(views, false));
      if (HasFailure()) return;
      for (std::size_t v = 0; v < views; v += 2) {
        for (std::uint32_t c = 0; c < kCascades; ++c) {
          if (rig.views_[v].view->frame().cascades[c].empty) continue;
          const std::vector<std::uint32_t> culled = layerOf(rig, v, c),
                                           whole = layerOf(rig, v + 1, c);
          compared += culled.size();
          for (std::size_t t = 0; t < culled.size(); ++t) {
            if (culled[t] == whole[t]) continue;
            float a, b;
            std::memcpy(&a, &culled[t], 4);
            std::memcpy(&b, &whole[t], 4);
            ++differing;
            nearer += a < b ? 1 : 0;
            largest = std::max(largest, std::abs(a - b));
          }
        }
      }
    }
  }
  std::printf(
      "[closed] %zu render modes x 2 paths x %d frames: %llu of %llu texels differ "
      "(largest by %.3g of the depth range), %llu nearer\n",
      names.size(), frames, static_cast<unsigned long long>(differing),
      static_cast<unsigned long long>(compared), double(largest),
      static_cast<unsigned long long>(nearer));
  EXPECT_EQ(nearer, 0u) << "culling made a texel nearer: it cannot add a surface";
  EXPECT_LE(largest, 1e-5f) << "a texel lost its nearest surface (a face culled wrongly)";
  EXPECT_LE(differing * 100000, compared) << "more texels differ than rounding at silhouettes";

  // An inside-out box flagged closed: culled as if it were wound outward, it keeps its faces
  // turned away from the light, so the map is deeper under it, nowhere nearer.
  std::vector<engine::Vertex> v;
  std::vector<std::uint32_t> idx;
  engine::makeCube(v, idx);
  for (std::size_t t = 0; t + 2 < idx.size(); t += 3) std::swap(idx[t + 1], idx[t + 2]);
  const engine::MeshRange inverted = rig.meshes_->upload(v, idx);
  csm::vk::MeshDraw draw = rig.meshDraws_[1];
  draw.firstIndex = inverted.firstIndex;
  draw.vertexOffset = inverted.vertexOffset;
  rig.meshDraws_.push_back(draw);
  rig.addStatic(2, {-3.0, 2.0, -12.0}, {3.0, 4.0, 3.0}, 0.2);
  rig.instances_.back().closed = true;
  for (std::size_t k = 0; k < 2; ++k) {
    const csm::vk::Status s =
        rig.views_[k].view->setCasters(rig.meshDraws_, rig.instances_, rig.bounds_);
    ASSERT_TRUE(s.ok()) << s.message();
  }
  rig.frame(pathCamera("walk", 0), pathLight("walk", 0), std::vector<bool>(views, false));
  std::uint64_t deeper = 0, shallower = 0;
  for (std::uint32_t c = 0; c < kCascades; ++c) {
    const std::vector<std::uint32_t> culled = layerOf(rig, 0, c), whole = layerOf(rig, 1, c);
    for (std::size_t t = 0; t < culled.size(); ++t) {
      float a, b;
      std::memcpy(&a, &culled[t], 4);
      std::memcpy(&b, &whole[t], 4);
      deeper += a > b + 1e-4f ? 1 : 0;
      shallower += a < b ? 1 : 0;
    }
  }
  std::printf("[closed] an inside-out box flagged closed: %llu texels deeper\n",
              static_cast<unsigned long long>(deeper));
  EXPECT_GT(deeper, 100u) << "an inside-out closed box changed no texel: nothing was culled";
  EXPECT_EQ(shallower, 0u);
  EXPECT_EQ(engine::validationMessageCount(), 0u);
}

/// Every level of every layer of `view`'s moment image, level after level (tightly packed,
/// `texelBytes` a texel), copied into `buffer` by `cmd` (the image back in its sampled layout).
void copyMoments(VkCommandBuffer cmd, const csm::vk::ShadowView& view, std::uint32_t texelBytes,
                 engine::Buffer& buffer) {
  const csm::vk::ShadowRenderer& r = view.renderer();
  const std::uint32_t levels = r.momentLevels();
  std::vector<VkBufferImageCopy> regions;
  VkDeviceSize offset = 0;
  for (std::uint32_t level = 0; level < levels; ++level) {
    const std::uint32_t side = std::max(kResolution >> level, 1u);
    VkBufferImageCopy region{};
    region.bufferOffset = offset;
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, 0, kCascades};
    region.imageExtent = {side, side, 1};
    regions.push_back(region);
    offset += VkDeviceSize(side) * side * texelBytes * kCascades;
  }
  copyToBuffer(cmd, r.momentImage(), VK_IMAGE_ASPECT_COLOR_BIT, regions, buffer.handle());
}

/// A cached view of the moment-format tests (kCascades layers of kResolution², 120 m, `kernel`,
/// RendererOptions `options` over the cache in per-layer mode) and a buffer its moment image is
/// read back into.
struct MomentView {
  std::unique_ptr<csm::vk::ShadowView> view;
  std::unique_ptr<engine::Buffer> readback;
};

csm::ShadowSettings momentSettings(csm::PcfKernel kernel) {
  csm::ShadowSettings settings;
  settings.cascadeCount = kCascades;
  settings.resolution = kResolution;
  settings.shadowDistanceM = 120.0;
  settings.kernel = kernel;
  return settings;
}

csm::vk::RendererOptions momentOptions() {
  csm::vk::RendererOptions options;
  options.cache = true;
  options.renderMode = csm::vk::RenderMode::kPerLayer;
  return options;
}

void makeMomentView(CacheRig& rig, const csm::vk::DeviceInfo& info,
                    const csm::ShadowSettings& settings, const csm::vk::RendererOptions& options,
                    MomentView& out) {
  csm::vk::VertexLayout layout;
  layout.stride = sizeof(engine::Vertex);
  layout.positionOffset = offsetof(engine::Vertex, position);
  csm::vk::Status s;
  out.view = csm::vk::ShadowView::create(info, layout, &s);
  ASSERT_TRUE(out.view != nullptr) << s.message();
  ASSERT_TRUE(out.view->setSettings(settings, options).ok());
  const csm::AabbWs scene{{-200, -1, -200}, {200, 20, 200}};
  ASSERT_TRUE(out.view->setSceneBounds(&scene).ok());
  out.readback = std::make_unique<engine::Buffer>(*rig.ctx_, out.view->renderer().momentBytes(),
                                                  VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                                  engine::MemoryUsage::Readback, "moment readback");
}

/// Frame `f` of `walk` with the rig's moving casters, recorded by every view, each moment image
/// copied into its readback (`texelBytes[k]` a texel).
void flyMomentFrame(CacheRig& rig, std::span<MomentView> views,
                    std::span<const std::uint32_t> texelBytes, int f) {
  rig.setDynamic(f);
  for (MomentView& v : views) {
    ASSERT_TRUE(v.view->setCasters(rig.meshDraws_, rig.instances_, rig.bounds_).ok());
  }
  rig.ctx_->submitAndWait([&](VkCommandBuffer cmd) {
    for (std::size_t k = 0; k < views.size(); ++k) {
      const csm::vk::Status s =
          views[k].view->record(cmd, pathCamera("walk", f), pathLight("walk", f));
      ASSERT_TRUE(s.ok()) << s.message();
      copyMoments(cmd, *views[k].view, texelBytes[k], *views[k].readback);
    }
  });
}

// VSM keeps its two moments in an RG32F image where the host enabled
// shaderStorageImageExtendedFormats (DeviceInfo::storageImageExtendedFormatsEnabled; the engine
// does where the device has it). At every level of every layer, frame after frame of a cached
// flight with moving casters (partial resolves included), its two channels hold exactly the
// bits of the first two channels of the RGBA32F image a host without the feature gets, whose
// other two are 0 (csm.glsl reads only x and y for vsm): the same shadows at half the memory.
// evsm and msm keep RGBA32F either way.
TEST(VsmMoments, TwoChannelImageHoldsTheSameBitsAtHalfTheMemory) {
  CacheRig rig;
  csm::vk::DeviceInfo info = glue::shadowDeviceInfo(*rig.ctx_);
  if (!info.storageImageExtendedFormatsEnabled) {
    GTEST_SKIP() << "the device lacks shaderStorageImageExtendedFormats";
  }
  csm::ShadowSettings settings = momentSettings(csm::PcfKernel::kVsm);
  const csm::vk::RendererOptions options = momentOptions();
  std::array<MomentView, 2> views;  // two channels, four channels
  for (int k = 0; k < 2; ++k) {
    info.storageImageExtendedFormatsEnabled = k == 0;
    makeMomentView(rig, info, settings, options, views[k]);
    if (HasFatalFailure()) return;
  }
  const csm::vk::ShadowRenderer& twoR = views[0].view->renderer();
  const csm::vk::ShadowRenderer& fourR = views[1].view->renderer();
  ASSERT_EQ(twoR.momentFormat(), VK_FORMAT_R32G32_SFLOAT);
  ASSERT_EQ(fourR.momentFormat(), VK_FORMAT_R32G32B32A32_SFLOAT);
  EXPECT_EQ(twoR.momentBytes(), csm::momentImageBytes(settings, true));
  EXPECT_EQ(fourR.momentBytes(), csm::momentImageBytes(settings, false));
  EXPECT_EQ(2 * twoR.momentBytes(), fourR.momentBytes());
  const int frames = std::min(flightFrames(), 24);
  std::uint64_t compared = 0, differing = 0, nonZeroExtra = 0;
  const std::uint32_t texelBytes[2] = {8, 16};
  for (int f = 0; f < frames; ++f) {
    flyMomentFrame(rig, views, texelBytes, f);
    if (HasFailure()) return;
    const auto* two = static_cast<const std::uint32_t*>(views[0].readback->mapped());
    const auto* four = static_cast<const std::uint32_t*>(views[1].readback->mapped());
    const std::size_t texels = twoR.momentBytes() / 8;
    for (std::size_t t = 0; t < texels; ++t) {
      compared += 2;
      differing +=
          (two[2 * t] != four[4 * t] ? 1 : 0) + (two[2 * t + 1] != four[4 * t + 1] ? 1 : 0);
      nonZeroExtra += (four[4 * t + 2] != 0 ? 1 : 0) + (four[4 * t + 3] != 0 ? 1 : 0);
    }
  }
  std::printf("[vsm rg32f] %d frames: %llu of %llu moments differ, %llu extra channels not 0\n",
              frames, static_cast<unsigned long long>(differing),
              static_cast<unsigned long long>(compared),
              static_cast<unsigned long long>(nonZeroExtra));
  EXPECT_EQ(differing, 0u);
  EXPECT_EQ(nonZeroExtra, 0u);
  // The other prefiltered filters keep four channels on the same device.
  for (csm::PcfKernel k : {csm::PcfKernel::kEvsm, csm::PcfKernel::kMsm}) {
    settings.kernel = k;
    ASSERT_TRUE(views[0].view->setSettings(settings, options).ok());
    EXPECT_EQ(views[0].view->renderer().momentFormat(), VK_FORMAT_R32G32B32A32_SFLOAT);
    EXPECT_EQ(views[0].view->renderer().momentBytes(), csm::momentImageBytes(settings, false));
  }
  settings.kernel = csm::PcfKernel::kTent3;
  ASSERT_TRUE(views[0].view->setSettings(settings, options).ok());
  EXPECT_EQ(views[0].view->renderer().momentFormat(), VK_FORMAT_UNDEFINED);
  EXPECT_EQ(views[0].view->renderer().momentBytes(), 0u);
  rig.ctx_->waitIdle();
  views = {};
  EXPECT_EQ(engine::validationMessageCount(), 0u);
}

// MSM's moments at 64 bits (RendererOptions::msmMomentBits = 64; needs the same feature as vsm's
// RG32F): RGBA16_UNORM holding Peters and Klein's quantisation (csm::msmQuantize) of the moments
// the 128-bit image holds. Two cached views, 64 and 128 bits, fly frames of `walk` with moving
// casters (partial resolves included). At level 0 of every layer each quantised channel is the
// 128-bit image's moments quantised, to within one step of the format; each mip (the mean of the
// four quantised texels below, rounded) to within a step more per level. Half the memory, the
// uniform block tells csm.glsl to decode, the other filters ignore the option, and a value other
// than 64 or 128 is refused naming the field.
TEST(MsmMoments, SixtyFourBitImageHoldsTheQuantisedMomentsAtHalfTheMemory) {
  CacheRig rig;
  const csm::vk::DeviceInfo info = glue::shadowDeviceInfo(*rig.ctx_);
  if (!info.storageImageExtendedFormatsEnabled) {
    GTEST_SKIP() << "the device lacks shaderStorageImageExtendedFormats";
  }
  csm::ShadowSettings settings = momentSettings(csm::PcfKernel::kMsm);
  csm::vk::RendererOptions options = momentOptions();
  std::array<MomentView, 2> views;  // 64 bits, 128 bits
  for (int k = 0; k < 2; ++k) {
    options.msmMomentBits = k == 0 ? 64 : 128;
    makeMomentView(rig, info, settings, options, views[k]);
    if (HasFatalFailure()) return;
  }
  const csm::vk::ShadowRenderer& r64 = views[0].view->renderer();
  const csm::vk::ShadowRenderer& r128 = views[1].view->renderer();
  ASSERT_EQ(r64.momentFormat(), VK_FORMAT_R16G16B16A16_UNORM);
  ASSERT_EQ(r128.momentFormat(), VK_FORMAT_R32G32B32A32_SFLOAT);
  EXPECT_EQ(r64.momentBytes(), csm::momentImageBytes(settings, true));
  EXPECT_EQ(2 * r64.momentBytes(), r128.momentBytes());
  const std::uint32_t levels = r64.momentLevels();
  const int frames = std::min(flightFrames(), 24);
  std::uint64_t compared = 0;
  std::vector<std::uint64_t> beyond(levels, 0);  // channels off by more than the level allows
  std::vector<float> worstSteps(levels, 0.0f);
  const std::uint32_t texelBytes[2] = {8, 16};
  for (int f = 0; f < frames; ++f) {
    flyMomentFrame(rig, views, texelBytes, f);
    if (HasFailure()) return;
    EXPECT_EQ(r64.uniforms().momentQuantized, 1u);
    EXPECT_EQ(r128.uniforms().momentQuantized, 0u);
    EXPECT_EQ(r64.uniforms().moments.y, csm::kMsmQuantizedMinMomentBias);
    const auto* q = static_cast<const std::uint16_t*>(views[0].readback->mapped());
    const auto* m = static_cast<const glm::vec4*>(views[1].readback->mapped());
    std::size_t at = 0;
    for (std::uint32_t level = 0; level < levels; ++level) {
      const std::size_t side = std::max(kResolution >> level, 1u);
      const float allowed = 1.0f + float(level);  // steps of 1/65535
      for (std::size_t t = 0; t < side * side * kCascades; ++t, ++at) {
        const glm::vec4 want = csm::msmQuantize(m[at]) * 65535.0f;
        for (int c = 0; c < 4; ++c) {
          const float steps = std::abs(float(q[4 * at + std::size_t(c)]) - want[c]);
          worstSteps[level] = std::max(worstSteps[level], steps);
          beyond[level] += steps > allowed ? 1 : 0;
          ++compared;
        }
      }
    }
  }
  for (std::uint32_t level = 0; level < levels; ++level) {
    std::printf("[msm 64-bit] level %u: worst %.3f steps of 1/65535\n", level,
                double(worstSteps[level]));
    EXPECT_EQ(beyond[level], 0u) << "level " << level << ": worst " << worstSteps[level];
  }
  std::printf("[msm 64-bit] %d frames, %llu channels compared\n", frames,
              static_cast<unsigned long long>(compared));
  EXPECT_GT(compared, 0u);
  // evsm keeps four 32-bit exponentials and vsm its RG32F whatever msmMomentBits says.
  options.msmMomentBits = 64;
  settings.kernel = csm::PcfKernel::kEvsm;
  ASSERT_TRUE(views[0].view->setSettings(settings, options).ok());
  EXPECT_EQ(views[0].view->renderer().momentFormat(), VK_FORMAT_R32G32B32A32_SFLOAT);
  settings.kernel = csm::PcfKernel::kVsm;
  ASSERT_TRUE(views[0].view->setSettings(settings, options).ok());
  EXPECT_EQ(views[0].view->renderer().momentFormat(), VK_FORMAT_R32G32_SFLOAT);
  // msm again at 128 bits through the same view: the image is rebuilt.
  settings.kernel = csm::PcfKernel::kMsm;
  ASSERT_TRUE(views[0].view->setSettings(settings, options).ok());
  EXPECT_EQ(views[0].view->renderer().momentFormat(), VK_FORMAT_R16G16B16A16_UNORM);
  options.msmMomentBits = 128;
  ASSERT_TRUE(views[0].view->setSettings(settings, options).ok());
  EXPECT_EQ(views[0].view->renderer().momentFormat(), VK_FORMAT_R32G32B32A32_SFLOAT);
  options.msmMomentBits = 96;
  const csm::vk::Status refused = views[0].view->setSettings(settings, options);
  EXPECT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("options.msmMomentBits = 96"), std::string::npos)
      << refused.message();
  EXPECT_NE(refused.message().find("64 or 128"), std::string::npos) << refused.message();
  EXPECT_EQ(views[0].view->renderer().momentFormat(), VK_FORMAT_R32G32B32A32_SFLOAT);  // unchanged
  rig.ctx_->waitIdle();
  views = {};
  EXPECT_EQ(engine::validationMessageCount(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Paths, CacheBudget, ::testing::Values("fast", "sun", "sun_dynamic"),
                         [](const auto& info) { return info.param; });

INSTANTIATE_TEST_SUITE_P(Paths, CacheFlight,
                         ::testing::Values("walk", "fast", "turn", "sun", "walk_redraw",
                                           "walk_copyrects", "fast_wholelayer"),
                         [](const auto& info) { return info.param; });

// The callback form of recordShadowPass on stabilised per-layer cascades without the cache: the
// renderer calls it once per block of the layer that a cascade's box covers, viewport and scissor
// set, and CascadeDrawContext::setTransform projects about that block. Drawn by a host through
// it, every texel of every non-empty layer is bit-identical to the caster-list form's, on a
// flight whose boxes cross block boundaries.
TEST(ShadowCallbackForm, WindowedBlocksDrawTheSameDepthAsTheCasterList) {
  CacheRig rig;
  csm::vk::RendererOptions options;
  options.cache = false;
  options.renderMode = csm::vk::RenderMode::kPerLayer;
  rig.addView(options);  // the caster-list form (ShadowView::record)
  ViewRig& host = rig.addView(options);
  std::array<int, kCascades> calls{};
  int blockedCascades = 0;  // cascade-frames drawn in more than one block
  csm::vk::ShadowView* view = host.view.get();
  host.record = [&](VkCommandBuffer cmd, const csm::Camera& camera,
                    const csm::DirectionalLight& light) {
    csm::vk::Status s = view->compute(camera, light);
    if (!s.ok()) return s;
    calls.fill(0);
    s = view->renderer().recordShadowPass(
        cmd, view->frame(),
        [&](const csm::vk::CascadeDrawContext& ctx) {
          ++calls[ctx.cascade];
          EXPECT_TRUE(ctx.anchored) << "cascade " << ctx.cascade;
          VkDeviceSize offset = 0;
          VkBuffer vb = rig.meshDraws_[0].vertexBuffer;
          vkCmdBindVertexBuffers(ctx.cmd, 0, 1, &vb, &offset);
          vkCmdBindIndexBuffer(ctx.cmd, rig.meshDraws_[0].indexBuffer, 0, VK_INDEX_TYPE_UINT32);
          for (std::uint32_t i : *ctx.visible) {
            const csm::vk::CasterInstance& inst = rig.instances_[i];
            const csm::vk::MeshDraw& mesh = rig.meshDraws_[inst.mesh];
            ctx.setTransform(inst.translationWs, inst.linearWs);
            vkCmdDrawIndexed(ctx.cmd, mesh.indexCount, 1, mesh.firstIndex, mesh.vertexOffset, 0);
          }
        },
        &view->cull());
    for (int c : calls) blockedCascades += c > 1 ? 1 : 0;
    return s;
  };
  for (int f = 0; f < 60; ++f) {
    const csm::Camera cam = pathCamera("fast", f);
    const csm::DirectionalLight light = pathLight("fast", f);
    rig.setDynamic(f);
    for (ViewRig& v : rig.views_) {
      const csm::vk::Status s = v.view->setCasters(rig.meshDraws_, rig.instances_, rig.bounds_);
      ASSERT_TRUE(s.ok()) << s.message();
    }
    rig.frame(cam, light, {false, false});
    if (HasFailure()) return;
    std::string first;
    const std::uint64_t diff = rig.differences(0, 1, &first);
    ASSERT_EQ(diff, 0u) << "frame " << f << ": " << diff
                        << " texels differ between the forms, first at " << first;
  }
  std::printf("cascade-frames drawn in more than one block: %d of %d\n", blockedCascades,
              60 * int(kCascades));
  EXPECT_GT(blockedCascades, 0) << "no box crossed a block boundary: the test shows nothing";
  EXPECT_EQ(engine::validationMessageCount(), 0u);
}

}  // namespace
