// ShadowRenderer's settings: update() checks them, builds what they need (image, views, lighting
// set, pipelines, static image, thin pipelines: may fail, installs nothing), then installs it all
// (cannot fail); the one-time clear of a new image; retiring what was replaced.
#include "csm/vulkan/shadow_renderer.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <string>

#include "shadow_renderer_impl.hpp"
#include "vk_util.hpp"

namespace csm::vk {

// ---------------------------------------------------------------------------------------------
// Settings

Status ShadowRenderer::Impl::checkFormat(VkFormat format) const {
  if (format != VK_FORMAT_D32_SFLOAT && format != VK_FORMAT_D16_UNORM) {
    return Status(ErrorCode::kUnsupportedFormat,
                  fmt("options.depthFormat = %d is invalid: allowed VK_FORMAT_D32_SFLOAT (%d) or "
                      "VK_FORMAT_D16_UNORM (%d)",
                      int(format), int(VK_FORMAT_D32_SFLOAT), int(VK_FORMAT_D16_UNORM)));
  }
  auto props3 = vkInit<VkFormatProperties3>(VK_STRUCTURE_TYPE_FORMAT_PROPERTIES_3);
  auto props = vkInit<VkFormatProperties2>(VK_STRUCTURE_TYPE_FORMAT_PROPERTIES_2, &props3);
  vkGetPhysicalDeviceFormatProperties2(device_.physicalDevice, format, &props);
  // Linear filtering of a comparison sampler needs only SAMPLED_IMAGE_DEPTH_COMPARISON
  // (FILTER_LINEAR governs non-comparison sampling; lavapipe does not report it for depth).
  const VkFormatFeatureFlags2 need = VK_FORMAT_FEATURE_2_DEPTH_STENCIL_ATTACHMENT_BIT |
                                     VK_FORMAT_FEATURE_2_SAMPLED_IMAGE_BIT |
                                     VK_FORMAT_FEATURE_2_SAMPLED_IMAGE_DEPTH_COMPARISON_BIT;
  if ((props3.optimalTilingFeatures & need) != need) {
    return Status(ErrorCode::kUnsupportedFormat,
                  fmt("options.depthFormat = %d is not supported by this device for depth "
                      "attachment + linear comparison sampling",
                      int(format)));
  }
  return {};
}

// update()'s checks of settings and options against each other and the device; fills the
// render mode the renderer will use (kAuto resolved).
Status ShadowRenderer::Impl::resolveOptions(const ShadowSettings& settings,
                                            const RendererOptions& options,
                                            RenderMode* resolved) const {
  if (auto e = csm::validate(settings)) {
    return Status(ErrorCode::kInvalidArgument, e->message());
  }
  Status s = checkFormat(options.depthFormat);
  if (!s.ok()) return s;
  const VkPhysicalDeviceLimits& lim = properties_.limits;
  const std::uint32_t deviceSide =
      std::min({lim.maxImageDimension2D, lim.maxFramebufferWidth, lim.maxFramebufferHeight,
                lim.maxViewportDimensions[0], lim.maxViewportDimensions[1]});
  const std::uint32_t maxSide =
      device_.maxResolution != 0 ? std::min(deviceSide, device_.maxResolution) : deviceSide;
  if (settings.resolution > maxSide) {
    return Status(
        ErrorCode::kDeviceLimit,
        fmt("settings.resolution = %u is invalid: allowed at most %u (%s)", settings.resolution,
            maxSide, maxSide < deviceSide ? "DeviceInfo::maxResolution" : "the device's limit"));
  }
  if (settings.cascadeCount > lim.maxImageArrayLayers) {
    return Status(ErrorCode::kDeviceLimit,
                  fmt("settings.cascadeCount = %u is invalid: this device allows at most %u layers",
                      settings.cascadeCount, lim.maxImageArrayLayers));
  }
  if (options.msmMomentBits != 64 && options.msmMomentBits != 128) {
    return Status(
        ErrorCode::kInvalidArgument,
        fmt("options.msmMomentBits = %u is invalid: allowed 64 or 128", options.msmMomentBits));
  }
  if (options.renderMode != RenderMode::kPerLayer && options.renderMode != RenderMode::kLayered &&
      options.renderMode != RenderMode::kAuto) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("options.renderMode = %d is invalid: allowed kPerLayer (0), kLayered (1), "
                      "kAuto (2)",
                      int(options.renderMode)));
  }
  RenderMode mode = options.renderMode;
  if (mode == RenderMode::kAuto) {
    // Stabilised cascades: per-layer, drawn in world-anchored windows, so the depth is the same
    // with the cache on or off and under sub-texel camera motion (the layered pass composes its
    // transform about the camera: on a GPU it differed from the cached layers in 0.02% of the
    // pixels; shadows/docs/cache.md). On an NVIDIA H200 both modes cost the same (0.91-1.03x,
    // README). Unstabilised: layered on a GPU; CPU rasterisers pay per draw, not per pass, so
    // per-layer there (measured faster on lavapipe).
    const bool gpu = properties_.deviceType != VK_PHYSICAL_DEVICE_TYPE_CPU;
    mode = !settings.diagnostics.stabilize && gpu && device_.shaderOutputLayerEnabled &&
                   settings.cascadeCount <= lim.maxFramebufferLayers
               ? RenderMode::kLayered
               : RenderMode::kPerLayer;
  }
  if (mode == RenderMode::kLayered) {
    if (!device_.shaderOutputLayerEnabled) {
      return Status(ErrorCode::kInvalidArgument,
                    "options.renderMode = kLayered needs shaderOutputLayer "
                    "(DeviceInfo::shaderOutputLayerEnabled)");
    }
    if (settings.cascadeCount > lim.maxFramebufferLayers) {
      return Status(ErrorCode::kDeviceLimit,
                    fmt("settings.cascadeCount = %u is invalid for kLayered: this device allows "
                        "at most %u framebuffer layers",
                        settings.cascadeCount, lim.maxFramebufferLayers));
    }
  }
  for (std::uint32_t c = 0; c < kMaxCascades; ++c) {
    if (options.cascadeLod[c] >= kMaxCasterLods) {
      return Status(ErrorCode::kInvalidArgument,
                    fmt("options.cascadeLod[%u] = %u is invalid: allowed [0, %u)", c,
                        options.cascadeLod[c], kMaxCasterLods));
    }
  }
  if (!(options.lodMaxErrorTexels >= 0.0f && options.lodMaxErrorTexels <= 64.0f)) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("options.lodMaxErrorTexels = %g is invalid: allowed [0, 64] (0 = off)",
                      double(options.lodMaxErrorTexels)));
  }
  if (s = checkThinOptions(options); !s.ok()) return s;
  if ((options.cullMode & ~VkCullModeFlags(VK_CULL_MODE_FRONT_AND_BACK)) != 0) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("options.cullMode = %u is invalid: allowed VK_CULL_MODE_* flags",
                      unsigned(options.cullMode)));
  }

  if (s = checkCacheOptions(settings, options); !s.ok()) return s;
  if (options.cache && !settings.diagnostics.stabilize) {
    return Status(
        ErrorCode::kInvalidArgument,
        "options.cache = true needs settings.diagnostics.stabilize = true (cached texels must be "
        "fixed in the world: boxes snapped to whole texels)");
  }
  if (options.cache && mode != RenderMode::kPerLayer) {
    if (options.renderMode == RenderMode::kAuto) {
      mode = RenderMode::kPerLayer;  // the cache renders scissored regions per layer
    } else {
      return Status(ErrorCode::kInvalidArgument,
                    "options.cache = true needs options.renderMode = kPerLayer or kAuto");
    }
  }
  *resolved = mode;
  return {};
}

// update() builds every object the new settings need before installing any (all-or-nothing):
// the builds may fail (out of memory, a pipeline the driver refuses), the installs cannot.
Status ShadowRenderer::Impl::update(const ShadowSettings& settings,
                                    const RendererOptions& options) {
  RenderMode mode = RenderMode::kPerLayer;
  Status s = resolveOptions(settings, options, &mode);
  if (!s.ok()) return s;
  // Windowed addressing (stabilised, per-layer) samples through the REPEAT samplers.
  const bool wrap = windowedFor(settings, options, mode);
  const bool newImage =
      image_ == VK_NULL_HANDLE || settings.resolution != resolution_ ||
      settings.cascadeCount != layerCount_ || options.depthFormat != options_.depthFormat ||
      options.cache != options_.cache || wrap != wrapSampling_ ||
      // the moment image and the lighting set's binding follow the filter
      ((isPrefiltered(settings.kernel) || isPrefiltered(settings_.kernel)) &&
       settings.kernel != settings_.kernel) ||
      (settings.kernel == PcfKernel::kMsm && options.msmMomentBits != options_.msmMomentBits);
  const bool newPipelines = !pipelinesBuilt_ || options.depthFormat != options_.depthFormat;
  const ThinPlan thin = planThinPipeline(settings.resolution, options);

  // Build.
  Retired pipelines, image, staticImage, thinPipelines;
  VkDescriptorSet lightingSet = VK_NULL_HANDLE;
  VkDeviceSize staticBytes = 0;
  const UpdateStep failAt = failAt_;
  failAt_ = UpdateStep::kNone;
  auto build = [&](UpdateStep step, auto&& make) -> Status {
    if (failAt == step) {
      return Status(ErrorCode::kVulkan,
                    fmt("update: failure injected at step %d (failNextUpdateAt)", int(step)),
                    VK_ERROR_OUT_OF_DEVICE_MEMORY);
    }
    return make();
  };
  if (newPipelines) {
    s = build(UpdateStep::kPipelines,
              [&] { return buildPipelines(options.depthFormat, pipelines); });
  }
  if (s.ok() && newImage) {
    s = build(UpdateStep::kImage,
              [&] { return buildImage(settings, options, image, lightingSet); });
  }
  if (s.ok() && newImage && options.cache) {
    s = build(UpdateStep::kStaticImage, [&] {
      return buildStaticImage(settings, options.depthFormat, staticImage, staticBytes);
    });
  }
  if (s.ok() && thin.build) {
    s = build(UpdateStep::kThinPipelines, [&] {
      return buildThinPipelines(settings.resolution, options, thin.conservative, thinPipelines);
    });
  }
  if (!s.ok()) {
    // Nothing was installed and nothing built was ever recorded: destroyed now.
    for (Retired* r : {&pipelines, &image, &staticImage, &thinPipelines}) destroyNow(*r);
    return s;
  }

  // Install (nothing below fails). What is replaced is retired: nothing waits for the GPU.
  if (newPipelines) installPipelines(pipelines);
  // Cached cascades: what changes the static depth without a new image re-renders it.
  if (!newImage && options.cache &&
      (settings.depthBiasConstant != settings_.depthBiasConstant ||
       settings.depthBiasSlope != settings_.depthBiasSlope ||
       settings.minCasterTexels != settings_.minCasterTexels ||
       options.cullMode != options_.cullMode || options.frontFace != options_.frontFace ||
       settings.diagnostics.cullClosedCasters != settings_.diagnostics.cullClosedCasters ||
       options.cascadeLod != options_.cascadeLod ||
       options.lodMaxErrorTexels != options_.lodMaxErrorTexels ||
       options.thinCasterWidenTexels != options_.thinCasterWidenTexels)) {
    invalidateAll();
  }
  if (newImage) {
    wrapSampling_ = wrap;
    installImage(image, lightingSet, settings);
    pendingClear_ = true;
    // A new image (resolution, count, format, cache) invalidates every cached cascade.
    retireStaticImage();
    cache_ = {};
    plan_ = {};
    dynamicDrawn_ = {};
    if (options.cache) installStaticImage(staticImage, staticBytes);
  }
  installThinPipelines(thin, thinPipelines, settings.resolution, options);
  settings_ = settings;
  options_ = options;
  resolvedMode_ = mode;
  // The clear of a new image: on failure it stays pending (prepare() or the next shadow pass
  // records it) and the error is returned with the new settings installed.
  if (pendingClear_ && device_.queue != VK_NULL_HANDLE) return submitClear();
  return {};
}

void ShadowRenderer::Impl::destroyNow(Retired& objects) noexcept {
  VkDevice dev = device_.device;
  destroyMomentImages(objects.moments);
  for (VkImageView& v : objects.views) {
    vkDestroyImageView(dev, v, nullptr);
    v = VK_NULL_HANDLE;
  }
  vkDestroyImage(dev, objects.image, nullptr);
  vkFreeMemory(dev, objects.memory, nullptr);
  vkDestroyDescriptorPool(dev, objects.pool, nullptr);
  for (VkPipeline& p : objects.pipelines) {
    vkDestroyPipeline(dev, p, nullptr);
    p = VK_NULL_HANDLE;
  }
  objects.image = VK_NULL_HANDLE;
  objects.memory = VK_NULL_HANDLE;
  objects.pool = VK_NULL_HANDLE;
}

// The one-time clear of a new image: depth 1 (lit) in every layer, then the sampled layout, so
// a lighting pass can sample it before the first shadow pass. The first time, the uniform block
// is zeroed too (no cascades: csm.glsl reads every receiver as lit).
void ShadowRenderer::Impl::recordClear(VkCommandBuffer cmd) {
  VkImageMemoryBarrier2 b[2] = {
      vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2),
      vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2)};
  b[0].srcStageMask = VK_PIPELINE_STAGE_2_NONE;
  b[0].dstStageMask = VK_PIPELINE_STAGE_2_CLEAR_BIT;
  b[0].dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  b[0].oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  b[0].newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  b[0].srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b[0].dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b[0].image = image_;
  b[0].subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, layerCount_};
  b[1] = b[0];
  b[1].srcStageMask = VK_PIPELINE_STAGE_2_CLEAR_BIT;
  b[1].srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  b[1].dstStageMask = options_.consumerStages;
  b[1].dstAccessMask = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  b[1].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  b[1].newLayout = sampledLayout();
  auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &b[0];
  vkCmdPipelineBarrier2(cmd, &dep);
  const VkClearDepthStencilValue one{1.0f, 0};
  const VkImageSubresourceRange range{VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, layerCount_};
  vkCmdClearDepthStencilImage(cmd, image_, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &one, 1, &range);
  recordMomentClear(cmd);
  auto buf = vkInit<VkBufferMemoryBarrier2>(VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2);
  if (!uniformsCleared_) {
    vkCmdFillBuffer(cmd, uniformBuffer_, 0, VK_WHOLE_SIZE, 0u);
    buf.srcStageMask = VK_PIPELINE_STAGE_2_CLEAR_BIT;
    buf.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    buf.dstStageMask = options_.consumerStages | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT;
    buf.dstAccessMask = VK_ACCESS_2_UNIFORM_READ_BIT;
    buf.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    buf.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    buf.buffer = uniformBuffer_;
    buf.size = VK_WHOLE_SIZE;
    dep.bufferMemoryBarrierCount = 1;
    dep.pBufferMemoryBarriers = &buf;
    uniformsCleared_ = true;
  }
  dep.pImageMemoryBarriers = &b[1];
  vkCmdPipelineBarrier2(cmd, &dep);
  pendingClear_ = false;
}

Status ShadowRenderer::Impl::submitClear() {
  VkDevice dev = device_.device;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  auto ai = vkInit<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
  ai.commandPool = clearPool_;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  CSM_VK_TRY(vkAllocateCommandBuffers(dev, &ai, &cmd));
  auto bi = vkInit<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  VkResult r = vkBeginCommandBuffer(cmd, &bi);
  if (r == VK_SUCCESS) {
    recordClear(cmd);
    r = vkEndCommandBuffer(cmd);
  }
  if (r == VK_SUCCESS) {
    auto si = vkInit<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
    r = vkQueueSubmit(device_.queue, 1, &si, clearFence_);
    if (r == VK_SUCCESS) r = vkWaitForFences(dev, 1, &clearFence_, VK_TRUE, UINT64_MAX);
    if (r == VK_SUCCESS) r = vkResetFences(dev, 1, &clearFence_);
  }
  vkFreeCommandBuffers(dev, clearPool_, 1, &cmd);
  if (r != VK_SUCCESS) {
    pendingClear_ = true;  // prepare() can still record it
    return vkError(r, "the one-time clear of the shadow map (DeviceInfo::queue)");
  }
  return {};
}

Status ShadowRenderer::Impl::prepare(VkCommandBuffer cmd) {
  if (image_ == VK_NULL_HANDLE) {
    return Status(ErrorCode::kWrongOrder, "prepare before a successful update()");
  }
  if (cmd == VK_NULL_HANDLE) return Status(ErrorCode::kInvalidArgument, "cmd is VK_NULL_HANDLE");
  if (pendingClear_) recordClear(cmd);
  return {};
}

Status ShadowRenderer::Impl::buildImage(const ShadowSettings& settings,
                                        const RendererOptions& options, Retired& out,
                                        VkDescriptorSet& lightingSet) {
  const VkFormat format = options.depthFormat;
  VkDevice dev = device_.device;
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView arrayView = VK_NULL_HANDLE;
  VkImageView layerViews[kMaxCascades] = {};
  auto cleanup = [&] {
    for (VkImageView v : layerViews) vkDestroyImageView(dev, v, nullptr);
    vkDestroyImageView(dev, arrayView, nullptr);
    vkDestroyImage(dev, image, nullptr);
    vkFreeMemory(dev, memory, nullptr);
  };
  auto fail = [&](Status st) {
    cleanup();
    return st;
  };

  auto ci = vkInit<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
  ci.imageType = VK_IMAGE_TYPE_2D;
  ci.format = format;
  ci.extent = {settings.resolution, settings.resolution, 1};
  ci.mipLevels = 1;
  ci.arrayLayers = settings.cascadeCount;
  ci.samples = VK_SAMPLE_COUNT_1_BIT;
  ci.tiling = VK_IMAGE_TILING_OPTIMAL;
  ci.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
             VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  ci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  ci.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkResult r = vkCreateImage(dev, &ci, nullptr, &image);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImage(shadow map)"));
  setName(handleBits(image), VK_OBJECT_TYPE_IMAGE, "csm shadow map");
  VkMemoryRequirements req{};
  vkGetImageMemoryRequirements(dev, image, &req);
  Status s = allocate(req, &memory, "csm shadow map memory");
  if (!s.ok()) return fail(s);
  r = vkBindImageMemory(dev, image, memory, 0);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkBindImageMemory(shadow map)"));

  auto vi = vkInit<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
  vi.image = image;
  vi.viewType = VK_IMAGE_VIEW_TYPE_2D_ARRAY;
  vi.format = format;
  vi.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, settings.cascadeCount};
  r = vkCreateImageView(dev, &vi, nullptr, &arrayView);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImageView(shadow map array)"));
  setName(handleBits(arrayView), VK_OBJECT_TYPE_IMAGE_VIEW, "csm shadow map array view");
  for (std::uint32_t i = 0; i < settings.cascadeCount; ++i) {
    vi.viewType = VK_IMAGE_VIEW_TYPE_2D;
    vi.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, i, 1};
    r = vkCreateImageView(dev, &vi, nullptr, &layerViews[i]);
    if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImageView(shadow map layer)"));
    const std::string name = "csm shadow map layer " + std::to_string(i);
    setName(handleBits(layerViews[i]), VK_OBJECT_TYPE_IMAGE_VIEW, name.c_str());
  }
  // The lighting set lives with the image: command buffers recorded with the old set stay valid.
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
  {
    // The lighting set, and the moment resolve's (prefiltered kernels).
    // The lighting set, the moment resolve's and its mip sets (one per level below 0).
    constexpr std::uint32_t kMips = kMaxMomentLevels - 1;
    VkDescriptorPoolSize sizes[3] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 2 + kMips},
                                     {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 4 + kMips},
                                     {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 2 + 2 * kMips}};
    auto pci = vkInit<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
    pci.maxSets = 2 + kMips;
    pci.poolSizeCount = 3;
    pci.pPoolSizes = sizes;
    r = vkCreateDescriptorPool(dev, &pci, nullptr, &pool);
    if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateDescriptorPool(csm lighting)"));
    setName(handleBits(pool), VK_OBJECT_TYPE_DESCRIPTOR_POOL, "csm lighting pool");
    auto ai = vkInit<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
    ai.descriptorPool = pool;
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &lightingLayout_;
    r = vkAllocateDescriptorSets(dev, &ai, &set);
    if (r != VK_SUCCESS) {
      vkDestroyDescriptorPool(dev, pool, nullptr);
      return fail(vkError(r, "vkAllocateDescriptorSets(csm lighting)"));
    }
    setName(handleBits(set), VK_OBJECT_TYPE_DESCRIPTOR_SET, "csm lighting set");
    if (isPrefiltered(settings.kernel)) {
      Status ms = buildMomentImages(settings, options.msmMomentBits, pool, out.moments);
      if (!ms.ok()) {
        vkDestroyDescriptorPool(dev, pool, nullptr);
        return fail(ms);
      }
    }
  }

  out.image = image;
  out.memory = memory;
  out.views[0] = arrayView;
  std::copy(std::begin(layerViews), std::end(layerViews), out.views + 1);
  out.pool = pool;
  lightingSet = set;
  return {};
}

void ShadowRenderer::Impl::installImage(Retired& built, VkDescriptorSet lightingSet,
                                        const ShadowSettings& settings) noexcept {
  if (image_ != VK_NULL_HANDLE) {
    Retired old;
    old.afterRecord = records_;
    old.image = image_;
    old.memory = imageMemory_;
    old.views[0] = arrayView_;
    std::copy(std::begin(layerViews_), std::end(layerViews_), old.views + 1);
    old.pool = lightingPool_;
    old.moments = moments_;
    retired_.push_back(old);
  }
  moments_ = built.moments;
  lightingPool_ = built.pool;
  lightingSet_ = lightingSet;
  image_ = built.image;
  imageMemory_ = built.memory;
  arrayView_ = built.views[0];
  std::copy(built.views + 1, built.views + 1 + kMaxCascades, std::begin(layerViews_));
  layerCount_ = settings.cascadeCount;
  resolution_ = settings.resolution;
  built = Retired{};
  (void)writeLightingSet(lightingSet_);  // fails only without an image or set: both are here
  writeMomentSet();
}

Status ShadowRenderer::Impl::buildPipelines(VkFormat format, Retired& out) {
  VkPipeline pipes[2] = {VK_NULL_HANDLE, VK_NULL_HANDLE};
  for (int layered = 0; layered < 2; ++layered) {
    if (layered == 1 && layeredModule_ == VK_NULL_HANDLE) break;
    auto stage = vkInit<VkPipelineShaderStageCreateInfo>(
        VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
    stage.stage = VK_SHADER_STAGE_VERTEX_BIT;
    stage.module = layered ? layeredModule_ : vertexModule_;
    stage.pName = "main";
    DepthPipelineDesc desc;
    desc.stages = &stage;
    desc.stageCount = 1;
    desc.vertexLayout = layout_;
    desc.depthClamp = device_.depthClampEnabled;
    desc.layout = pipelineLayout_;
    desc.depthFormat = format;
    const VkResult r =
        createDepthPipeline(device_.device, device_.pipelineCache, desc, &pipes[layered]);
    if (r != VK_SUCCESS) {
      vkDestroyPipeline(device_.device, pipes[0], nullptr);
      return vkError(r, "vkCreateGraphicsPipelines(csm depth)");
    }
    setName(handleBits(pipes[layered]), VK_OBJECT_TYPE_PIPELINE,
            layered ? "csm depth pipeline (layered)" : "csm depth pipeline");
  }
  // The cache's shader copy (CacheRestore::kShaderCopy): a triangle over the layer, scissored.
  VkPipelineShaderStageCreateInfo stages[2] = {
      vkInit<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO),
      vkInit<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO)};
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = restoreVertexModule_;
  stages[0].pName = "main";
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  stages[1].module = restoreFragmentModule_;
  stages[1].pName = "main";
  DepthPipelineDesc desc;
  desc.stages = stages;
  desc.stageCount = 2;
  desc.vertexLayout = layout_;
  desc.depthClamp = device_.depthClampEnabled;
  desc.layout = restoreLayout_;
  desc.depthFormat = format;
  desc.restore = true;
  VkPipeline restore = VK_NULL_HANDLE;
  const VkResult r = createDepthPipeline(device_.device, device_.pipelineCache, desc, &restore);
  if (r != VK_SUCCESS) {
    vkDestroyPipeline(device_.device, pipes[0], nullptr);
    vkDestroyPipeline(device_.device, pipes[1], nullptr);
    return vkError(r, "vkCreateGraphicsPipelines(csm cache restore)");
  }
  setName(handleBits(restore), VK_OBJECT_TYPE_PIPELINE, "csm cache restore pipeline");
  out.pipelines[0] = pipes[0];
  out.pipelines[1] = pipes[1];
  out.pipelines[2] = restore;
  return {};
}

void ShadowRenderer::Impl::installPipelines(Retired& built) noexcept {
  if (pipelinesBuilt_) {
    Retired old;
    old.afterRecord = records_;
    old.pipelines[0] = pipeline_;
    old.pipelines[1] = layeredPipeline_;
    old.pipelines[2] = restorePipeline_;
    retired_.push_back(old);
  }
  pipeline_ = built.pipelines[0];
  layeredPipeline_ = built.pipelines[1];
  restorePipeline_ = built.pipelines[2];
  pipelinesBuilt_ = true;
  built = Retired{};
}

Status ShadowRenderer::Impl::writeLightingSet(VkDescriptorSet set) const {
  if (image_ == VK_NULL_HANDLE) {
    return Status(ErrorCode::kWrongOrder, "writeLightingSet before a successful update()");
  }
  if (set == VK_NULL_HANDLE) return Status(ErrorCode::kInvalidArgument, "set is VK_NULL_HANDLE");
  VkDescriptorBufferInfo bi{uniformBuffer_, 0, sizeof(CsmUniforms)};
  VkDescriptorImageInfo compare{wrapSampling_ ? wrapCompareSampler_ : compareSampler_, arrayView_,
                                sampledLayout()};
  VkDescriptorImageInfo depth{wrapSampling_ ? wrapDepthSampler_ : depthSampler_, arrayView_,
                              sampledLayout()};
  // The moments (prefiltered kernels), else the depth map again: the binding is never read.
  VkDescriptorImageInfo moments =
      moments_.image != VK_NULL_HANDLE
          ? VkDescriptorImageInfo{wrapSampling_ ? wrapMomentSampler_ : momentSampler_,
                                  moments_.sampledView, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL}
          : depth;
  VkWriteDescriptorSet w[4]{};
  for (auto& x : w) {
    x.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    x.dstSet = set;
    x.descriptorCount = 1;
  }
  w[0].dstBinding = CSM_BINDING_UNIFORMS;
  w[0].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  w[0].pBufferInfo = &bi;
  w[1].dstBinding = CSM_BINDING_SHADOW_MAP;
  w[1].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  w[1].pImageInfo = &compare;
  w[2].dstBinding = CSM_BINDING_SHADOW_DEPTH;
  w[2].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  w[2].pImageInfo = &depth;
  w[3].dstBinding = CSM_BINDING_MOMENTS;
  w[3].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  w[3].pImageInfo = &moments;
  vkUpdateDescriptorSets(device_.device, 4, w, 0, nullptr);
  return {};
}

}  // namespace csm::vk
