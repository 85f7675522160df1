// The cache as the fly-through runs it: the sample world's own renderer (world::WorldRenderer)
// with the fly-through's default settings (movers, caster clusters, LODs by error, closed-caster
// culling, thin casters), flown along every path, once with the cache and once without, in
// lockstep. Every frame, the sampled depth layers of every non-empty cascade, the uniform block
// the lighting pass reads and the lit image must be bit-identical: turning the cache on changes
// the cost, never the image. Also with a texel budget (a deferred cascade lags by design: it is
// compared on the frames it refreshes, and its lag is bounded), with receiver-driven splits,
// with PCSS and with the prefiltered filters, whose moment images (every mip level) must be
// bit-identical too: the cached side resolves only the tiles its passes changed, the uncached
// side every texel. Validation (with synchronization) stays silent.
//
// The test that would have caught the lost shadows of the fly-through (cached blocks drawn with
// a viewport off the attachment): on that code, forest frame 2 already differs in thousands of
// texels.
#include <gtest/gtest.h>

#include <csm/moments.hpp>
#include <csm/names.hpp>
#include <csm/vulkan/shadow_view.hpp>
#include <engine/context.hpp>
#include <engine/debug.hpp>
#include <engine/gpu_timer.hpp>
#include <engine/headless_target.hpp>
#include <engine/image_io.hpp>
#include <engine/memory.hpp>
#include <sample_world/paths.hpp>
#include <sample_world/settings.hpp>
#include <sample_world/world.hpp>
#include <sample_world/world_renderer.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace {

constexpr std::uint32_t kWidth = 160, kHeight = 90;
constexpr std::uint32_t kResolution = 512;

/// Frames per flight: CSM_CACHE_WORLD_FRAMES, else 36 (each flight spans its whole path, so a
/// cascade moves tens to hundreds of texels a frame: every frame exposes rows and columns, wraps,
/// and new blocks; the day path steps the sun, the cut path cuts 5 times; 11 flights, 396 frames
/// in all).
int flightFrames() {
  const char* env = std::getenv("CSM_CACHE_WORLD_FRAMES");
  return env != nullptr ? std::max(2, std::atoi(env)) : 36;
}

/// One renderer of the world and the buffer its shadow layers are read back into.
struct Side {
  std::unique_ptr<world::WorldRenderer> renderer;
  std::unique_ptr<engine::Buffer> layers;
  std::unique_ptr<engine::Buffer> moments;  // prefiltered kernels: every level of every layer
  std::vector<std::uint8_t> image;          // the lit frame (RGBA8)
};

class WorldRig {
 public:
  /// Side 0 cached, side 1 not (or both cached with `bothCached`); side k's moment sampler
  /// capped at `anisotropy[k]`.
  /// With `fullSettings`, side 1 takes those settings instead (as they are); with
  /// `thirdSettings`, a third side (2) flies along with those.
  WorldRig(const std::string& pathName, const world::AppSettings& settings,
           std::array<std::optional<float>, 2> anisotropy = {}, bool bothCached = false,
           const std::optional<world::AppSettings>& fullSettings = std::nullopt,
           const std::optional<world::AppSettings>& thirdSettings = std::nullopt)
      : settings_(settings), sides_(thirdSettings ? 3 : 2) {
    engine::resetValidationCounts();
    engine::ContextDesc desc;
    desc.appName = "csm cache world tests";
    desc.validation = true;
    ctx_ = std::make_unique<engine::Context>(desc);
    world::WorldDesc wd = settings.world;
    wd.originWs = world::pathWorldOrigin(pathName, wd.sizeM);
    world::WorldError err;
    std::optional<world::World> w = world::generateWorld(wd, &err);
    if (!w) throw std::runtime_error(err.message);
    world_ = std::make_unique<world::World>(std::move(*w));
    path_ = world::FlightPath::make(pathName, *world_, settings.fovDeg, settings.clock);
    if (!path_) throw std::runtime_error("no path " + pathName);
    target_ = std::make_unique<engine::HeadlessTarget>(
        *ctx_, engine::HeadlessDesc{{kWidth, kHeight}, VK_FORMAT_D32_SFLOAT});
    timer_ = std::make_unique<engine::GpuTimer>(*ctx_, 32);
    for (std::size_t k = 0; k < sides_.size(); ++k) {
      world::AppSettings s = settings;
      s.shadowCache = k == 0 || bothCached;
      if (k == 1 && fullSettings) s = *fullSettings;
      if (k == 2) s = *thirdSettings;
      Side& side = sides_[k];
      side.renderer = std::make_unique<world::WorldRenderer>(*ctx_, *world_, target_->colorFormat(),
                                                             target_->depthFormat(),
                                                             k < 2 ? anisotropy[k] : std::nullopt);
      if (auto e = side.renderer->apply(s)) throw std::runtime_error(*e);
      const VkDeviceSize bytes =
          VkDeviceSize(kResolution) * kResolution * 4 * settings.shadow.cascadeCount;
      side.layers =
          std::make_unique<engine::Buffer>(*ctx_, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                           engine::MemoryUsage::Readback, "cache world readback");
      if (csm::isPrefiltered(settings.shadow.kernel)) {
        side.moments = std::make_unique<engine::Buffer>(
            *ctx_, side.renderer->shadowRenderer().momentBytes(), VK_BUFFER_USAGE_TRANSFER_DST_BIT,
            engine::MemoryUsage::Readback, "cache world moment readback");
      }
    }
  }

  /// Bytes of every level of every moment layer, level after level (both sides' format: RG32F
  /// for vsm on a device with extended storage formats, else RGBA32F).
  VkDeviceSize momentBytes() const { return sides_[0].renderer->shadowRenderer().momentBytes(); }

  /// Bytes of a moment texel.
  std::uint32_t momentTexelBytes() const {
    return sides_[0].renderer->shadowRenderer().momentFormat() == VK_FORMAT_R32G32_SFLOAT ? 8u
                                                                                          : 16u;
  }

  ~WorldRig() {
    if (ctx_) ctx_->waitIdle();
    for (Side& s : sides_) {
      s.renderer.reset();
      s.layers.reset();
      s.moments.reset();
    }
    timer_.reset();
    target_.reset();
    if (ctx_) ctx_->shutdown();
  }

  Side& side(int k) { return sides_[k]; }

  /// Renders frame i of n with both renderers and reads their layers and images back.
  void frame(int i, int n) {
    const double t = n > 1 ? double(i) / double(n - 1) : 0.0;
    // The day and cut paths run in the headless flight's simulated time.
    const double seconds = i * world::kHeadlessFrameS;
    const std::optional<world::SunPose> sun = path_->sunAt(seconds);
    const bool cut =
        i > 0 && path_->shotAt(seconds) != path_->shotAt(seconds - world::kHeadlessFrameS);
    lastCut_ = cut;
    const engine::Camera cam = world::poseCamera(
        path_->at(t, seconds), double(kWidth) / double(kHeight), 0.5, settings_.farM);
    for (Side& side : sides_) {
      if (sun) {
        if (auto e = side.renderer->setSun(*sun)) throw std::runtime_error(*e);
      }
      if (cut) side.renderer->cameraCut();
      // As the fly-through does: the frame after a cut takes the cut's marks at once.
      if (side.renderer->wantsLatestReceivers()) {
        target_->waitIdle();
        side.renderer->takeLatestReceivers();
      }
      world::FrameStats stats;
      if (auto e = side.renderer->prepare(cam, stats)) throw std::runtime_error(*e);
      std::optional<engine::Frame> f = target_->beginFrame();
      if (!f) throw std::runtime_error("no frame");
      timer_->beginFrame(f->cmd, f->slot);
      side.renderer->record(*f, *timer_, false, stats);
      target_->endFrame();
      const engine::CpuImage img = target_->readback();
      side.image = img.rgba;
      readLayers(side);
      if (side.moments) readMoments(side);
    }
  }

  /// Moment texels (any level, any channel: 32-bit words) where the two renderers differ
  /// bitwise; the first in `first`. The cached side resolved only what its passes changed, the
  /// uncached side everything.
  std::uint64_t momentDifferences(std::uint32_t layerMask, std::string* first) {
    const auto* a = static_cast<const std::uint32_t*>(sides_[0].moments->mapped());
    const auto* b = static_cast<const std::uint32_t*>(sides_[1].moments->mapped());
    const std::size_t words = momentBytes() / 4;
    std::uint64_t n = 0;
    for (std::size_t t = 0; t < words; ++t) {
      if (a[t] == b[t]) continue;
      // Which level, layer and texel.
      std::size_t rest = t / 4, level = 0;
      std::uint32_t side = kResolution;
      while (rest >= std::size_t(side) * side * settings_.shadow.cascadeCount) {
        rest -= std::size_t(side) * side * settings_.shadow.cascadeCount;
        side /= 2;
        ++level;
      }
      const std::size_t layer = rest / (std::size_t(side) * side);
      if (((layerMask >> layer) & 1u) == 0) continue;
      if (n++ == 0 && first != nullptr) {
        const std::size_t texel = rest % (std::size_t(side) * side);
        float x, y;
        std::memcpy(&x, &a[t], 4);
        std::memcpy(&y, &b[t], 4);
        *first = "level " + std::to_string(level) + " layer " + std::to_string(layer) + " texel (" +
                 std::to_string(texel % side) + ", " + std::to_string(texel / side) + ") channel " +
                 std::to_string(t % 4) + ": cached " + std::to_string(x) + ", full " +
                 std::to_string(y);
      }
    }
    return n;
  }

  const engine::Context& context() const { return *ctx_; }

  /// Whether the last frame() was a camera cut.
  bool lastCut() const { return lastCut_; }

  /// Texels of cascade c inside the tiles that side 0's layer holds (its cache plan: box, wrap
  /// offset, held tiles) where the two renderers' layers differ bitwise; the first in `first`,
  /// how many were compared in `compared`.
  std::uint64_t heldTileDifferences(std::uint32_t c, const csm::CacheCascadePlan& p,
                                    std::uint64_t& compared, std::string* first) {
    const auto* a = static_cast<const std::uint32_t*>(sides_[0].layers->mapped());
    const auto* b = static_cast<const std::uint32_t*>(sides_[1].layers->mapped());
    const std::int64_t res = kResolution, tile = res / csm::kTilesPerSide;
    const std::size_t layer = std::size_t(res) * std::size_t(res);
    std::uint64_t n = 0;
    for (std::int64_t ly = 0; ly < res; ++ly) {
      // The world texel at layer texel (lx, ly): the box's first texel sits at the wrap offset.
      const std::int64_t wy = p.box.y0 + csm::floorMod(ly - p.wrapY, res);
      const std::int64_t ty = csm::floorDiv(wy, tile) - p.tiles.origin.y;
      for (std::int64_t lx = 0; lx < res; ++lx) {
        const std::int64_t wx = p.box.x0 + csm::floorMod(lx - p.wrapX, res);
        if (!p.tiles.test(csm::floorDiv(wx, tile) - p.tiles.origin.x, ty)) continue;
        ++compared;
        const std::size_t t = c * layer + std::size_t(ly * res + lx);
        if (a[t] == b[t]) continue;
        if (n++ == 0 && first != nullptr) {
          float x, y;
          std::memcpy(&x, &a[t], 4);
          std::memcpy(&y, &b[t], 4);
          *first = "layer texel (" + std::to_string(lx) + ", " + std::to_string(ly) +
                   "), world texel (" + std::to_string(wx) + ", " + std::to_string(wy) +
                   "): tiled " + std::to_string(x) + ", full " + std::to_string(y);
        }
      }
    }
    return n;
  }

  /// Texels of cascade c where the two renderers' layers differ (bitwise); the first in `first`.
  std::uint64_t layerDifferences(std::uint32_t c, std::string* first) {
    const auto* a = static_cast<const std::uint32_t*>(sides_[0].layers->mapped());
    const auto* b = static_cast<const std::uint32_t*>(sides_[1].layers->mapped());
    const std::size_t layer = std::size_t(kResolution) * kResolution;
    std::uint64_t n = 0;
    for (std::size_t t = c * layer; t < (c + 1) * layer; ++t) {
      if (a[t] == b[t]) continue;
      if (n++ == 0 && first != nullptr) {
        float x, y;
        std::memcpy(&x, &a[t], 4);
        std::memcpy(&y, &b[t], 4);
        *first = "texel (" + std::to_string((t - c * layer) % kResolution) + ", " +
                 std::to_string((t - c * layer) / kResolution) + "): cached " + std::to_string(x) +
                 ", full " + std::to_string(y);
      }
    }
    return n;
  }

 private:
  void readLayers(Side& side) {
    csm::vk::ShadowRenderer& r = side.renderer->shadowRenderer();
    const std::uint32_t layers = settings_.shadow.cascadeCount;
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 0, layers};
    region.imageExtent = {kResolution, kResolution, 1};
    readImage(r.image(), VK_IMAGE_ASPECT_DEPTH_BIT, {&region, 1}, *side.layers);
  }

  /// Every level of every moment layer, level after level (momentBytes()).
  void readMoments(Side& side) {
    csm::vk::ShadowRenderer& r = side.renderer->shadowRenderer();
    const std::uint32_t layers = settings_.shadow.cascadeCount;
    const std::uint32_t levels = r.momentLevels();
    ASSERT_NE(r.momentImage(), VK_NULL_HANDLE);
    std::vector<VkBufferImageCopy> regions;
    VkDeviceSize offset = 0;
    for (std::uint32_t level = 0; level < levels; ++level) {
      const std::uint32_t side = std::max(kResolution >> level, 1u);
      VkBufferImageCopy region{};
      region.bufferOffset = offset;
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, 0, layers};
      region.imageExtent = {side, side, 1};
      regions.push_back(region);
      offset += VkDeviceSize(side) * side * momentTexelBytes() * layers;
    }
    readImage(r.momentImage(), VK_IMAGE_ASPECT_COLOR_BIT, regions, *side.moments);
  }

  /// Copies `regions` of an image (`aspect`) in the sampled layout into `buffer`, and back to
  /// that layout.
  void readImage(VkImage image, VkImageAspectFlags aspect,
                 std::span<const VkBufferImageCopy> regions, engine::Buffer& buffer) {
    ctx_->submitAndWait([&](VkCommandBuffer cmd) {
      const VkImageLayout sampled = csm::vk::ShadowRenderer::sampledLayout();
      engine::imageBarrier(cmd, image, aspect, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                           VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COPY_BIT,
                           VK_ACCESS_2_TRANSFER_READ_BIT, sampled,
                           VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
      vkCmdCopyImageToBuffer(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buffer.handle(),
                             static_cast<std::uint32_t>(regions.size()), regions.data());
      engine::imageBarrier(cmd, image, aspect, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE,
                           VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_NONE,
                           VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, sampled);
    });
  }

  world::AppSettings settings_;
  std::unique_ptr<engine::Context> ctx_;
  std::unique_ptr<world::World> world_;
  std::optional<world::FlightPath> path_;
  std::unique_ptr<engine::HeadlessTarget> target_;
  std::unique_ptr<engine::GpuTimer> timer_;
  std::vector<Side> sides_;
  bool lastCut_ = false;
};

struct Flight {
  std::string path;
  std::string config;  // default, budget, receivers, pcss
};

// Test names and failure messages show the flight, not its bytes.
void PrintTo(const Flight& f, std::ostream* os) {
  *os << f.path << "/" << f.config;
}

std::string flightName(const ::testing::TestParamInfo<Flight>& info) {
  return info.param.path + "_" + info.param.config;
}

/// The fly-through's defaults at the test's small sizes, with the flight's variation. The day
/// and cut paths run fast: a 20 s day (the held sun steps by 0.25° every second frame) and a
/// cut every 6 frames.
world::AppSettings flightSettings(const std::string& config) {
  world::AppSettings s;
  s.clock.dayLengthS = 20.0;
  s.clock.cutEveryS = 0.1;
  s.width = kWidth;
  s.height = kHeight;
  s.shadow.resolution = kResolution;
  if (config == "budget") s.cacheBudgetTexels = std::uint64_t(kResolution) * kResolution;
  if (config == "receivers") s.receiverSplits = true;
  // The tile budget: a quarter of a layer a frame for the partial cascades, with a light step
  // every 20 frames (a 200 s day) and a cut every 24 frames. (A step every second frame, as
  // above, asks for more than the budget every frame: the budget is for spikes.)
  if (config == "tilebudget") {
    s.tileBudgetTexels = std::uint64_t(kResolution) * kResolution / 4;
    s.clock.dayLengthS = 200.0;
    s.clock.cutEveryS = 0.4;
  }
  if (config == "pcss") s.shadow.kernel = csm::PcfKernel::kPcss;
  if (config == "vsm") s.shadow.kernel = csm::PcfKernel::kVsm;
  if (config == "evsm") s.shadow.kernel = csm::PcfKernel::kEvsm;
  if (config == "msm") s.shadow.kernel = csm::PcfKernel::kMsm;
  // A blur wide enough at these resolutions (512^2 texels of 0.1 m to metres) to reach across
  // the partial resolve's 32-texel tiles in every cascade.
  if (csm::isPrefiltered(s.shadow.kernel)) s.shadow.momentBlurM = 1.5;
  return s;
}

class CacheWorld : public ::testing::TestWithParam<Flight> {};

TEST_P(CacheWorld, EveryFrameSampledLayersBitIdenticalToFullRender) {
  const Flight& flight = GetParam();
  const world::AppSettings settings = flightSettings(flight.config);
  WorldRig rig(flight.path, settings);
  const int frames = flightFrames();
  const bool budget = settings.cacheBudgetTexels != 0;
  const bool prefiltered = csm::isPrefiltered(settings.shadow.kernel);
  std::uint64_t momentTexels = 0, momentFullTexels = 0;
  std::uint64_t compared = 0, deferredFrames = 0, cachedTexels = 0, fullTexels = 0;
  std::uint32_t maxLag = 0;
  for (int i = 0; i < frames; ++i) {
    rig.frame(i, frames);
    world::WorldRenderer& cached = *rig.side(0).renderer;
    world::WorldRenderer& full = *rig.side(1).renderer;
    ASSERT_FALSE(full.shadowView().options().cache);
    ASSERT_TRUE(cached.shadowView().options().cache);
    const csm::CascadeFrame& fc = cached.cascades();
    const csm::CascadeFrame& ff = full.cascades();
    ASSERT_EQ(fc.cascadeCount, ff.cascadeCount);
    const csm::CsmUniforms& uc = cached.shadowRenderer().uniforms();
    const csm::CsmUniforms& uf = full.shadowRenderer().uniforms();
    bool anyDeferred = false;
    for (std::uint32_t c = 0; c < fc.cascadeCount; ++c) {
      ASSERT_EQ(fc.cascades[c].empty, ff.cascades[c].empty) << "frame " << i << " cascade " << c;
      if (fc.cascades[c].empty) continue;
      const csm::vk::CascadeCacheStats& st = cached.shadowRenderer().cacheStats()[c];
      cachedTexels += st.staticTexels;
      fullTexels += std::uint64_t(kResolution) * kResolution;
      maxLag = std::max(maxLag, st.lagFrames);
      momentTexels += st.momentTexels;
      momentFullTexels += std::uint64_t(kResolution) * kResolution;
      if (st.deferred) {
        // A deferred cascade shows its last refresh by design; compared when it refreshes.
        ASSERT_TRUE(budget) << "frame " << i << " cascade " << c << " deferred without a budget";
        anyDeferred = true;
        continue;
      }
      std::string first;
      const std::uint64_t n = rig.layerDifferences(c, &first);
      ASSERT_EQ(n, 0u) << flight.path << "/" << flight.config << " frame " << i << " cascade " << c
                       << ": " << n << " texels differ, first " << first;
      ASSERT_EQ(std::memcmp(&uc.cascades[c], &uf.cascades[c], sizeof(uc.cascades[c])), 0)
          << "frame " << i << " cascade " << c << ": the uniform blocks differ";
      ++compared;
    }
    deferredFrames += anyDeferred ? 1 : 0;
    if (prefiltered) {
      // The cached side's partial resolves against the full ones, every level.
      std::string first;
      std::uint32_t layers = 0;  // empty cascades' layers are not drawn, sampled nor compared
      for (std::uint32_t c = 0; c < fc.cascadeCount; ++c) {
        if (!fc.cascades[c].empty) layers |= 1u << c;
      }
      const std::uint64_t n = rig.momentDifferences(layers, &first);
      ASSERT_EQ(n, 0u) << flight.path << "/" << flight.config << " frame " << i << ": " << n
                       << " moment words differ, first " << first;
    }
    if (!anyDeferred) {
      ASSERT_EQ(std::memcmp(&uc, &uf, sizeof(uc)), 0) << "frame " << i << ": uniforms differ";
      ASSERT_TRUE(rig.side(0).image == rig.side(1).image)
          << flight.path << "/" << flight.config << " frame " << i << ": the lit images differ";
    }
  }
  EXPECT_GT(compared, std::uint64_t(frames));
  if (prefiltered) {
    // The partial resolve must be partial somewhere (else the case tests nothing) and never
    // more than the full one.
    EXPECT_LT(momentTexels, momentFullTexels);
    EXPECT_GT(momentTexels, 0u);
    std::printf("[cache world] %s/%s: moment texels resolved cached %.2f%% of full\n",
                flight.path.c_str(), flight.config.c_str(),
                100.0 * double(momentTexels) / double(momentFullTexels));
  }
  if (budget) {
    // The far cascades wait their turn, but not for long (the most stale refreshes first).
    EXPECT_LE(maxLag, 8u);
    EXPECT_GT(deferredFrames, 0u) << "the budget never deferred: the case tests nothing";
  } else {
    EXPECT_EQ(maxLag, 0u);
  }
  std::printf(
      "[cache world] %s/%s: %d frames, %llu cascades compared, static texels rendered "
      "cached %.2f%% of full, %llu frames with a deferred cascade (lag <= %u)\n",
      flight.path.c_str(), flight.config.c_str(), frames, static_cast<unsigned long long>(compared),
      fullTexels ? 100.0 * double(cachedTexels) / double(fullTexels) : 0.0,
      static_cast<unsigned long long>(deferredFrames), maxLag);
  EXPECT_EQ(engine::validationMessageCount(), 0u);
}

/// The eight paths at the fly-through's defaults, then `extra`.
std::vector<Flight> everyPathAnd(std::vector<Flight> extra) {
  std::vector<Flight> flights;
  for (const char* path : {"forest", "fast", "rotate", "zoom", "far", "cables", "day", "cut"}) {
    flights.push_back({path, "default"});
  }
  flights.insert(flights.end(), extra.begin(), extra.end());
  return flights;
}

INSTANTIATE_TEST_SUITE_P(Paths, CacheWorld,
                         ::testing::ValuesIn(everyPathAnd({{"fast", "budget"},
                                                           {"forest", "receivers"},
                                                           {"fast", "pcss"},
                                                           {"forest", "msm"},
                                                           {"fast", "evsm"},
                                                           {"day", "vsm"},
                                                           {"cut", "msm"}})),
                         flightName);

// Receiver-marked tiles (RendererOptions::tiles, the fly-through's shadow.tiles) as the
// fly-through runs them: the sample world's renderer with its defaults and tiles on (side 0,
// cached, the lighting in the tiles debug mode: green where a pixel was sampled in its own
// cascades, red where it fell back) against a full render (side 1, no cache), in lockstep. Every
// frame, in every partial cascade, every texel of every tile its layer holds is bit-identical to
// the full render's; a cascade drawn whole is bit-identical everywhere. Pixels that fell back
// are counted: after the start and after a cut, until the first marks arrive
// (engine::kFramesInFlight + 1 frames) most do; on every other frame at most kMaxFallback of the
// shaded pixels, and kMeanFallback over the flight (these flights cross a whole path in 48
// frames: the marks, three frames old, trail a camera that moves tens of metres a frame).
// Validation stays silent.
constexpr double kMaxFallback = 0.10;
constexpr double kMeanFallback = 0.01;
// With a tile budget (the "tilebudget" flights, a quarter of a layer a frame, at the
// fly-through's pace): the tiles the budget leaves for later frames fall back too. On day a
// light step's frame draws the first quarter layer of tiles from the camera out and most of its
// pixels fall back (measured: worst 61%, mean 4.3%); on cut the frames after a cut (measured:
// worst 30%, mean 0.7%).
struct FallbackBound {
  double worst, mean;
};
FallbackBound budgetFallbackBound(const std::string& path) {
  return path == "cut" ? FallbackBound{0.40, 0.02} : FallbackBound{0.70, 0.06};
}

/// Frames per tile flight: CSM_TILE_WORLD_FRAMES, else 48.
int tileFlightFrames() {
  const char* env = std::getenv("CSM_TILE_WORLD_FRAMES");
  return env != nullptr ? std::max(2, std::atoi(env)) : 48;
}

class TileWorld : public ::testing::TestWithParam<Flight> {};

TEST_P(TileWorld, HeldTilesBitIdenticalToFullRenderAndFallbacksBounded) {
  const Flight& flight = GetParam();
  // "shadow": both sides show the shadow factor, and a third side, the same as side 0 but in
  // the tiles debug mode, says which pixels fell back (the same flight: the same marks, plans
  // and fallbacks). Every pixel that did not fall back must have the full render's shadow
  // factor, bit for bit (a shader that read a tile not drawn fails here).
  const bool factor = flight.config == "shadow";
  world::AppSettings tiled = flightSettings(factor ? "default" : flight.config);
  tiled.shadowTiles = true;
  tiled.debug = csm::DebugMode::kTileFallback;
  world::AppSettings full = flightSettings(factor ? "default" : flight.config);
  full.shadowCache = false;
  std::optional<world::AppSettings> third;
  if (factor) {
    third = tiled;
    tiled.debug = csm::DebugMode::kShadowFactor;
    full.debug = csm::DebugMode::kShadowFactor;
  }
  WorldRig rig(flight.path, tiled, {}, false, full, third);
  std::uint64_t factorCompared = 0;
  const int frames = tileFlightFrames();
  int sinceReset = 0;
  std::uint64_t compared = 0, partialCascades = 0, wholeCascades = 0;
  std::uint64_t tiledTexels = 0, fullTexels = 0, settlingFrames = 0, settledFrames = 0;
  std::uint64_t deferredTiles = 0;
  const std::uint64_t budget = tiled.tileBudgetTexels;
  double maxFallback = 0.0, sumFallback = 0.0;
  int worstFrame = -1;
  // The budget flights fly at the fly-through's pace (a path in 240 frames): a fifth of the path.
  // Crossing a whole path in 48 frames asks for more than a quarter layer every frame.
  const int pathFrames = budget != 0 ? 240 : frames;
  for (int i = 0; i < frames; ++i) {
    rig.frame(i, pathFrames);
    sinceReset = (i == 0 || rig.lastCut()) ? 0 : sinceReset + 1;
    world::WorldRenderer& t = *rig.side(0).renderer;
    ASSERT_TRUE(t.shadowView().options().tiles);
    ASSERT_FALSE(rig.side(1).renderer->shadowView().options().cache);
    const csm::CascadeFrame& ft = t.cascades();
    const csm::CachePlan& plan = t.shadowRenderer().cachePlan();
    std::uint32_t lastActive = 0;
    std::uint64_t budgeted = 0;
    for (std::uint32_t c = 0; c < ft.cascadeCount; ++c) {
      if (!ft.cascades[c].empty) lastActive = c;
    }
    for (std::uint32_t c = 0; c < ft.cascadeCount; ++c) {
      if (ft.cascades[c].empty) continue;
      const csm::CacheCascadePlan& p = plan.cascades[c];
      if (p.partial && c != lastActive) budgeted += t.shadowRenderer().cacheStats()[c].staticTexels;
      deferredTiles += t.shadowRenderer().cacheStats()[c].tilesDeferred;
      tiledTexels += t.shadowRenderer().cacheStats()[c].staticTexels;
      fullTexels += std::uint64_t(kResolution) * kResolution;
      std::string first;
      if (p.partial) {
        ++partialCascades;
        const std::uint64_t n = rig.heldTileDifferences(c, p, compared, &first);
        ASSERT_EQ(n, 0u) << flight.path << "/" << flight.config << " frame " << i << " cascade "
                         << c << ": " << n << " texels of held tiles differ, first " << first;
      } else {
        ++wholeCascades;
        const std::uint64_t n = rig.layerDifferences(c, &first);
        ASSERT_EQ(n, 0u) << flight.path << "/" << flight.config << " frame " << i << " cascade "
                         << c << " (whole): " << n << " texels differ, first " << first;
        compared += std::uint64_t(kResolution) * kResolution;
      }
    }
    if (budget != 0) {
      EXPECT_LE(budgeted, budget) << flight.path << " frame " << i
                                  << ": the partial cascades drew more than the tile budget";
    }
    // Pixels in their own cascades (green) and fallen back (red).
    std::uint64_t own = 0, fell = 0;
    const std::vector<std::uint8_t>& img = rig.side(factor ? 2 : 0).image;
    for (std::size_t k = 0; k + 3 < img.size(); k += 4) {
      const bool red = img[k] > 200 && img[k + 1] < 50 && img[k + 2] < 50;
      const bool green = img[k + 1] > 200 && img[k] < 50 && img[k + 2] < 50;
      fell += red ? 1u : 0u;
      own += green ? 1u : 0u;
      if (!factor || !green) continue;
      const std::vector<std::uint8_t>& a = rig.side(0).image;
      const std::vector<std::uint8_t>& b = rig.side(1).image;
      ++factorCompared;
      ASSERT_TRUE(a[k] == b[k] && a[k + 1] == b[k + 1] && a[k + 2] == b[k + 2])
          << flight.path << " frame " << i << " pixel " << (k / 4) % kWidth << ", "
          << (k / 4) / kWidth << ": shadow factor " << int(a[k]) << " with tiles, " << int(b[k])
          << " full, in its own cascade";
    }
    ASSERT_GT(own + fell, 0u) << "frame " << i << ": no shaded pixel";
    const double fraction = double(fell) / double(own + fell);
    // Only the first frame after the start or a cut falls back for want of marks: the next one
    // draws the marks of that frame (after a cut, taken at once) or, at the start, what the
    // view can sample.
    if (sinceReset == 0) {
      ++settlingFrames;
      continue;
    }
    ++settledFrames;
    sumFallback += fraction;
    if (fraction > maxFallback) {
      maxFallback = fraction;
      worstFrame = i;
    }
  }
  EXPECT_GT(partialCascades, 0u) << "no cascade drew only marked tiles: the case tests nothing";
  if (factor) {
    EXPECT_GT(factorCompared, std::uint64_t(frames) * kWidth * kHeight / 4);
  }
  EXPECT_LT(tiledTexels, fullTexels);
  // With a tile budget the frames after a cut or a light step leave tiles for later frames.
  const FallbackBound bound =
      budget != 0 ? budgetFallbackBound(flight.path) : FallbackBound{kMaxFallback, kMeanFallback};
  EXPECT_LE(maxFallback, bound.worst) << "frame " << worstFrame;
  EXPECT_LE(settledFrames ? sumFallback / double(settledFrames) : 0.0, bound.mean);
  if (budget != 0) {
    EXPECT_GT(deferredTiles, 0u) << "the budget deferred nothing: the case tests nothing";
  }
  std::printf(
      "[tile world] %s/%s: %d frames (%llu the first after the start or a cut), %llu partial and "
      "%llu whole cascade-frames, %llu texels compared; fallen back: mean %.3f%%, worst %.3f%% "
      "(frame %d); static texels drawn %.2f%% of a full render's; %llu tiles deferred\n",
      flight.path.c_str(), flight.config.c_str(), frames,
      static_cast<unsigned long long>(settlingFrames),
      static_cast<unsigned long long>(partialCascades),
      static_cast<unsigned long long>(wholeCascades), static_cast<unsigned long long>(compared),
      settledFrames ? 100.0 * sumFallback / double(settledFrames) : 0.0, 100.0 * maxFallback,
      worstFrame, fullTexels ? 100.0 * double(tiledTexels) / double(fullTexels) : 0.0,
      static_cast<unsigned long long>(deferredTiles));
  EXPECT_EQ(engine::validationMessageCount(), 0u);
}

// Every path; forest and day in the "shadow" configuration, whose tiled side is the default
// one plus the shadow factors compared (the default flights there would only repeat it).
std::vector<Flight> tileFlights() {
  std::vector<Flight> out;
  for (const Flight& f : everyPathAnd({{"fast", "pcss"},
                                       {"forest", "shadow"},
                                       {"day", "shadow"},
                                       {"day", "tilebudget"},
                                       {"cut", "tilebudget"}})) {
    if (f.config == "default" && (f.path == "forest" || f.path == "day")) continue;
    out.push_back(f);
  }
  return out;
}

INSTANTIATE_TEST_SUITE_P(Paths, TileWorld, ::testing::ValuesIn(tileFlights()), flightName);

// What csm_moments.comp writes, against the CPU from the depths it read: level 0 of every moment
// layer is the separable Gaussian of the depths' moments (csm::depthMoments; radius
// momentBlurM / texel, capped at CSM_MOMENT_MAX_BLUR_TEXELS; texels beyond the box's edge read
// as the far plane; cached layers addressed through their wrap offsets), and every mip texel is
// the mean of the four below it, bit for bit. Both renderers of the rig (cached: wrapped layers,
// partial resolves; uncached: full resolves) over frames of `fast` with msm and evsm blurred by
// 1.5 m (no blur to 5 texels across the cascades at 512^2) and msm by 4 m (up to the cap).
// Exponentials differ between the device and libm in the last bits (EVSM's reach e^80): level 0 is
// held to 1e-4 of each value.
TEST(MomentResolve, Level0IsTheBlurOfTheDepthsMomentsAndEachMipTheMeanOfFour) {
  const std::pair<const char*, double> runs[] = {{"msm", 1.5}, {"evsm", 1.5}, {"msm", 4.0}};
  std::uint32_t radiiSeen = 0;  // bit n: a layer blurred with reach n
  for (const auto& [config, blurM] : runs) {
    SCOPED_TRACE(std::string(config) + " blur " + std::to_string(blurM));
    world::AppSettings settings = flightSettings(config);
    settings.shadow.momentBlurM = blurM;
    WorldRig rig("fast", settings);
    const std::uint32_t layers = settings.shadow.cascadeCount;
    const int res = int(kResolution);
    const std::size_t layerTexels = std::size_t(res) * std::size_t(res);
    for (int i = 0; i < 4; ++i) {
      rig.frame(i, 40);
      for (int k = 0; k < 2; ++k) {
        const Side& side = rig.side(k);
        const csm::CsmUniforms& u = side.renderer->shadowRenderer().uniforms();
        const auto* depth = static_cast<const float*>(side.layers->mapped());
        const auto* gpu = static_cast<const glm::vec4*>(side.moments->mapped());
        csm::ShadowSettings ms = settings.shadow;
        ms.evsmPositiveExponent = u.moments.z;
        ms.evsmNegativeExponent = u.moments.w;
        const glm::vec4 far = csm::depthMoments(ms.kernel, 1.0f, ms);
        std::vector<glm::vec4> own(layerTexels), alongX(layerTexels);
        std::uint64_t level0Off = 0, mipOff = 0;
        std::string first;
        for (std::uint32_t c = 0; c < layers; ++c) {
          const float radius =
              csm::momentBlurRadiusTexels(ms.momentBlurM, u.cascades[c].texelSizeM);
          const int n = radius >= 0.5f ? int(std::ceil(radius)) : 0;
          radiiSeen |= 1u << n;
          const float inv2Sigma2 = n > 0 ? 2.0f / (radius * radius) : 0.0f;
          std::vector<float> w(std::size_t(n) + 1);
          for (int t = 0; t <= n; ++t) w[std::size_t(t)] = std::exp(-float(t * t) * inv2Sigma2);
          int offset[2] = {0, 0};
          for (int a = 0; a < 2 && u.wrappedLayers != 0; ++a) {
            const int o = int(std::lround(u.cascades[c].wrapOffset[a]));
            offset[a] = ((o % res) + res) % res;
          }
          const float* d = depth + c * layerTexels;
          // One axis of the Gaussian at layer texel (x, y); `read` gives a texel's moments.
          auto blur = [&](int x, int y, int axis, auto&& read) {
            const int box = (((axis == 0 ? x : y) - offset[axis]) % res + res) % res;
            glm::vec4 sum(0.0f);
            float weights = 0.0f;
            for (int t = -n; t <= n; ++t) {
              const float wt = w[std::size_t(std::abs(t))];
              weights += wt;
              const int b = box + t;
              if (b < 0 || b >= res) {
                sum += wt * far;
                continue;
              }
              const int along = (b + offset[axis]) % res;
              sum += wt * (axis == 0 ? read(along, y) : read(x, along));
            }
            return sum / weights;
          };
          for (std::size_t t = 0; t < layerTexels; ++t) {
            own[t] = csm::depthMoments(ms.kernel, d[t], ms);
          }
          for (int y = 0; y < res; ++y) {
            for (int x = 0; x < res; ++x) {
              alongX[std::size_t(y) * res + x] =
                  blur(x, y, 0, [&](int tx, int ty) { return own[std::size_t(ty) * res + tx]; });
            }
          }
          for (int y = 0; y < res; ++y) {
            for (int x = 0; x < res; ++x) {
              const glm::vec4 want =
                  blur(x, y, 1, [&](int tx, int ty) { return alongX[std::size_t(ty) * res + tx]; });
              const glm::vec4 got = gpu[c * layerTexels + std::size_t(y) * res + x];
              bool off = false;
              for (int ch = 0; ch < 4; ++ch) {
                off |=
                    !(std::abs(got[ch] - want[ch]) <= 1e-4f * std::max(1.0f, std::abs(want[ch])));
              }
              if (off && level0Off++ == 0) {
                first = "layer " + std::to_string(c) + " texel (" + std::to_string(x) + ", " +
                        std::to_string(y) + "): " + std::to_string(got.x) + " against " +
                        std::to_string(want.x);
              }
            }
          }
        }
        // Each mip level from the one above: 0.25 ((a + b) + (c + d)), exactly as float.
        const glm::vec4* above = gpu;
        for (std::uint32_t level = 1; level < side.renderer->shadowRenderer().momentLevels();
             ++level) {
          const int up = std::max(res >> (level - 1), 1), side1 = std::max(res >> level, 1);
          const glm::vec4* here = above + std::size_t(up) * up * layers;
          for (std::uint32_t c = 0; c < layers; ++c) {
            for (int y = 0; y < side1; ++y) {
              for (int x = 0; x < side1; ++x) {
                auto at = [&](int tx, int ty) {
                  return above[std::size_t(c) * up * up + std::size_t(ty) * up + tx];
                };
                const glm::vec4 top = at(2 * x, 2 * y) + at(2 * x + 1, 2 * y);
                const glm::vec4 bottom = at(2 * x, 2 * y + 1) + at(2 * x + 1, 2 * y + 1);
                const glm::vec4 want = 0.25f * (top + bottom);
                const glm::vec4 got =
                    here[std::size_t(c) * side1 * side1 + std::size_t(y) * side1 + x];
                if (std::memcmp(&want, &got, sizeof(want)) != 0 && mipOff++ == 0 && first.empty()) {
                  first = "level " + std::to_string(level) + " layer " + std::to_string(c) +
                          " texel (" + std::to_string(x) + ", " + std::to_string(y) + ")";
                }
              }
            }
          }
          above = here;
        }
        EXPECT_EQ(level0Off, 0u) << "frame " << i << (k == 0 ? " cached: " : " full: ") << first;
        EXPECT_EQ(mipOff, 0u) << "frame " << i << (k == 0 ? " cached: " : " full: ") << first;
      }
    }
    EXPECT_EQ(engine::validationMessageCount(), 0u);  // each rig counts its own
  }
  // The layers were blurred with no reach, short ones and the cap (the shared tile's widest).
  EXPECT_NE(radiiSeen & 1u, 0u) << std::hex << radiiSeen;
  EXPECT_NE(radiiSeen & 0xffeu, 0u) << std::hex << radiiSeen;
  EXPECT_NE(radiiSeen & (1u << CSM_MOMENT_MAX_BLUR_TEXELS), 0u) << std::hex << radiiSeen;
}

// The moment sampler is anisotropic where the device allows it (glue::kMomentAnisotropy, 8x):
// the fly-through's msm frame, drawn by two renderers that differ only in that cap (8 and 1),
// has the same depth layers and moment images (every level), and differs in the lit image only
// where grazing ground reads its moments through an anisotropic footprint. With the sampler
// left trilinear (the cap ignored) the images would be identical.
TEST(MomentAnisotropy, TheSamplerFiltersAlongTheFootprintWhereTheDeviceAllows) {
  world::AppSettings settings = flightSettings("msm");
  settings.shadow.momentBlurM = 0.1;  // the default: mips, not the blur, filter the far field
  WorldRig rig("forest", settings, {glue::kMomentAnisotropy, 1.0f}, true);
  const float limit = rig.context().properties().limits.maxSamplerAnisotropy;
  if (!rig.context().features().samplerAnisotropy) GTEST_SKIP() << "no samplerAnisotropy";
  const csm::vk::ShadowRenderer& aniso = rig.side(0).renderer->shadowRenderer();
  const csm::vk::ShadowRenderer& trilinear = rig.side(1).renderer->shadowRenderer();
  EXPECT_EQ(aniso.momentAnisotropy(), std::min(glue::kMomentAnisotropy, limit));
  EXPECT_EQ(trilinear.momentAnisotropy(), 1.0f);
  std::uint64_t differing = 0, pixels = 0;
  for (int i = 0; i < 3; ++i) {
    rig.frame(i, 12);
    for (std::uint32_t c = 0; c < settings.shadow.cascadeCount; ++c) {
      std::string first;
      EXPECT_EQ(rig.layerDifferences(c, &first), 0u) << "frame " << i << " cascade " << c << first;
    }
    std::string first;
    EXPECT_EQ(rig.momentDifferences(0xffu, &first), 0u) << "frame " << i << ": " << first;
    const std::vector<std::uint8_t>& a = rig.side(0).image;
    const std::vector<std::uint8_t>& b = rig.side(1).image;
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t p = 0; p + 3 < a.size(); p += 4) {
      ++pixels;
      differing += std::memcmp(&a[p], &b[p], 3) != 0 ? 1 : 0;
    }
  }
  std::printf("[moment anisotropy] %.0fx against trilinear: %llu of %llu pixels differ\n",
              double(aniso.momentAnisotropy()), static_cast<unsigned long long>(differing),
              static_cast<unsigned long long>(pixels));
  EXPECT_GT(differing, 0u) << "the anisotropic sampler changed nothing";
  // The last frame side by side (anisotropic | trilinear), to look at.
  engine::CpuImage strip;
  strip.width = 2 * kWidth;
  strip.height = kHeight;
  strip.rgba.resize(std::size_t(strip.width) * kHeight * 4);
  for (std::uint32_t y = 0; y < kHeight; ++y) {
    for (int k = 0; k < 2; ++k) {
      std::memcpy(&strip.rgba[(std::size_t(y) * strip.width + k * kWidth) * 4],
                  &rig.side(k).image[std::size_t(y) * kWidth * 4], kWidth * 4);
    }
  }
  std::filesystem::create_directories(CSM_TEST_ARTEFACT_DIR);
  EXPECT_TRUE(
      engine::writePng(std::string(CSM_TEST_ARTEFACT_DIR) + "/moment_anisotropy.png", strip));
  EXPECT_EQ(engine::validationMessageCount(), 0u);
}

}  // namespace
