// The renderer's state and steps behind csm::vk::ShadowRenderer's public interface (private to
// the module: shadow_renderer.cpp, shadow_cache.cpp, thin_casters.cpp and shadow_view.cpp, which
// culls each cascade in the light basis of the cache's plan). The public methods of
// ShadowRenderer forward here one to one; their documentation is in shadow_renderer.hpp.
#pragma once

#include "csm/cache_plan.hpp"
#include "csm/vulkan/shadow_renderer.hpp"

namespace csm::vk {

class ShadowRenderer::Impl {
 public:
  // ShadowRenderer's interface (documented in shadow_renderer.hpp), then the view's cache
  // queries.
  ~Impl();
  Impl() = default;
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  Status update(const ShadowSettings& settings, const RendererOptions& options);
  Status update(const ShadowSettings& settings) { return update(settings, options_); }

  void failNextUpdateAt(UpdateStep step) noexcept { failAt_ = step; }

  Status prepare(VkCommandBuffer cmd);
  [[nodiscard]] bool needsPrepare() const noexcept { return pendingClear_; }

  void setDebugMode(DebugMode mode) noexcept { debugMode_ = mode; }
  [[nodiscard]] DebugMode debugMode() const noexcept { return debugMode_; }
  void setCascadeHook(CascadeHook hook) { cascadeHook_ = std::move(hook); }

  Status recordShadowPass(VkCommandBuffer cmd, const CascadeFrame& frame, const CasterList& casters,
                          const CullResult* visible);

  Status recordShadowPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                          const CascadeDrawCallback& draw, const CullResult* visible = nullptr);

  [[nodiscard]] bool ready() const noexcept { return image_ != VK_NULL_HANDLE; }
  [[nodiscard]] VkImageView arrayView() const noexcept { return arrayView_; }
  [[nodiscard]] VkSampler comparisonSampler() const noexcept { return compareSampler_; }
  [[nodiscard]] VkSampler depthSampler() const noexcept { return depthSampler_; }
  [[nodiscard]] float thinMarginTexels() const noexcept;
  [[nodiscard]] static constexpr VkImageLayout sampledLayout() noexcept {
    return VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  }
  [[nodiscard]] VkImage image() const noexcept { return image_; }
  [[nodiscard]] VkFormat depthFormat() const noexcept { return options_.depthFormat; }
  [[nodiscard]] RenderMode renderMode() const noexcept { return resolvedMode_; }
  [[nodiscard]] const CsmUniforms& uniforms() const noexcept { return uniforms_; }
  [[nodiscard]] VkBuffer uniformBuffer() const noexcept { return uniformBuffer_; }

  // --- Cached cascades (RendererOptions::cache) -------------------------------------------------
  void applyCacheWindows(CascadeFrame& frame);
  Status invalidate(const AabbWs& boxWs);
  void invalidateAll() noexcept;
  void setReceiverTiles(std::optional<ReceiverTileMarks> marks) noexcept {
    tileMarks_ = std::move(marks);
  }
  [[nodiscard]] const std::array<CascadeCacheStats, kMaxCascades>& cacheStats() const noexcept {
    return cacheStats_;
  }
  /// The plan of the frame last windowed (applyCacheWindows; empty when not windowed):
  /// ShadowView culls each cascade in the light basis it gives.
  [[nodiscard]] const CachePlan& cachePlan() const noexcept { return plan_; }
  [[nodiscard]] VkDeviceSize cacheBytes() const noexcept { return cacheBytes_; }
  [[nodiscard]] VkImage staticImage() const noexcept { return staticImage_; }

  [[nodiscard]] VkDescriptorSetLayout lightingSetLayout() const noexcept { return lightingLayout_; }
  [[nodiscard]] VkDescriptorSet lightingSet() const noexcept { return lightingSet_; }
  Status writeLightingSet(VkDescriptorSet set) const;

  // ---- Below: not part of ShadowRenderer's interface ----
  // recordShadowPass with the instances already validated by the caller (ShadowView validates
  // each caster when it is given, so its frames do not pay O(casters) for it).
  Status recordValidatedPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                             const CasterList& casters, const CullResult* visible);
  Status recordCasterListPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                              const CasterList& casters, const CullResult* visible,
                              bool instancesValidated);
  Status init(const DeviceInfo& device, const VertexLayout& layout);
  // init()'s steps, in order: debug-utils entry points, the depth and lighting set layouts,
  // the depth pipeline layout, the depth pass's descriptor set, the one-time clear's pool and
  // fence, the samplers, the uniform buffer, the vertex shader modules.
  void loadDebugUtils();
  Status createSetLayouts();
  Status createPipelineLayout();
  Status createDepthSet();
  Status createClearResources();
  Status createSamplers();
  Status createUniformBuffer();
  Status createShaderModules();
  Status allocate(const VkMemoryRequirements& req, VkDeviceMemory* memory, const char* name) const;
  Status checkFormat(VkFormat format) const;
  Status resolveOptions(const ShadowSettings& settings, const RendererOptions& options,
                        RenderMode* resolved) const;
  // update() builds what new settings need (build*: may fail, installs nothing), then installs
  // it all (install*: cannot fail, retires what it replaces). Objects travel in a Retired.
  struct Retired;
  Status buildImage(const ShadowSettings& settings, const RendererOptions& options, Retired& out,
                    VkDescriptorSet& lightingSet);
  void installImage(Retired& built, VkDescriptorSet lightingSet,
                    const ShadowSettings& settings) noexcept;
  Status buildPipelines(VkFormat format, Retired& out);
  void installPipelines(Retired& built) noexcept;
  /// Destroys objects at once (never recorded, or retired long enough ago).
  void destroyNow(Retired& objects) noexcept;
  // Thin casters (thin_casters.cpp).
  static Status checkThinOptions(const RendererOptions& options);
  struct ThinPlan {
    bool wanted = false;        // the options and device call for a thin pipeline
    bool conservative = false;  // overestimating rasterisation, no geometry stage
    bool keep = false;          // the current one fits
    bool build = false;         // a new one is needed
  };
  [[nodiscard]] ThinPlan planThinPipeline(std::uint32_t resolution,
                                          const RendererOptions& options) const;
  Status buildThinPipelines(std::uint32_t resolution, const RendererOptions& options,
                            bool conservative, Retired& out);
  void installThinPipelines(const ThinPlan& plan, Retired& built, std::uint32_t resolution,
                            const RendererOptions& options) noexcept;
  void destroyThinPipeline() noexcept;
  /// The texel size (metres) of the cascade drawn into each layer of the bound view (per-layer:
  /// [0]; layered: [cascade]), for the thin casters' widening.
  using LayerTexels = std::array<double, kMaxCascades>;
  void drawIndexedCaster(VkCommandBuffer cmd, const CasterInstance& instance, const MeshDraw& mesh,
                         std::uint32_t copies, const LayerTexels& layerTexelM);
  void setCasterCull(VkCommandBuffer cmd, const CasterInstance& instance);
  void destroyImage() noexcept;
  void destroyPipelines() noexcept;
  Status checkFrame(const CascadeFrame& frame) const;
  Status submitClear();
  void recordClear(VkCommandBuffer cmd);
  void collectRetired(bool all) noexcept;
  bool countRecord();
  [[nodiscard]] UniformOptions uniformOptions() const noexcept;
  CsmUniforms packFrameUniforms(const CascadeFrame& frame) const;
  void recordPassStart(VkCommandBuffer cmd, const char* label,
                       std::span<const VkImageMemoryBarrier2> images);
  void recordBegin(VkCommandBuffer cmd, const CascadeFrame& frame);
  void recordDiscardingStart(VkCommandBuffer cmd, const char* label);
  void recordEnd(VkCommandBuffer cmd);
  void beginDepthRendering(VkCommandBuffer cmd, VkImageView view, std::uint32_t layers, bool clear,
                           const std::string& label, VkPipeline pipeline);
  void beginLayer(VkCommandBuffer cmd, std::uint32_t cascade, bool layered);
  void endLayer(VkCommandBuffer cmd);
  void setName(std::uint64_t handle, VkObjectType type, const char* name) const;
  Status buildStaticImage(const ShadowSettings& settings, VkFormat format, Retired& out,
                          VkDeviceSize& bytes);
  void installStaticImage(Retired& built, VkDeviceSize bytes) noexcept;
  void retireStaticImage() noexcept;
  // Windowed addressing (shadow_cache.cpp): stabilised per-layer cascades are drawn about
  // world-anchored windows, cached or not, so that the cache changes the cost, never the depth.
  [[nodiscard]] static bool windowedFor(const ShadowSettings& settings,
                                        const RendererOptions& options, RenderMode mode) noexcept;
  [[nodiscard]] bool windowed() const noexcept {
    return windowedFor(settings_, options_, resolvedMode_);
  }
  Status recordCachedPass(VkCommandBuffer cmd, const CascadeFrame& frame, const CasterList& casters,
                          const CullResult* visible);
  Status recordWindowedCallbackPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                                    const CascadeDrawCallback& draw, const CullResult* visible);
  /// What the callback form hands the host for cascade `cascade` of `frame` (not anchored).
  CascadeDrawContext drawContext(VkCommandBuffer cmd, const CascadeFrame& frame,
                                 std::uint32_t cascade, const CullResult* visible) const;
  const CascadeFrame* windowedFrame(const CascadeFrame& frame, CascadeFrame& own);
  // recordCachedPass()'s steps (shadow_cache.cpp). CachedPass: the pass's drawing state.
  struct CachedPass;
  Status checkCacheWindows(const CascadeFrame& frame) const;
  void packCachedUniforms(const CascadeFrame& frame, CachedPass& pass);
  void recordCachedBegin(VkCommandBuffer cmd, bool wasUndefined);
  void recordFullCascade(CachedPass& pass, std::uint32_t cascade,
                         const std::vector<std::uint32_t>& list);
  bool recordCachedCascade(CachedPass& pass, std::uint32_t cascade,
                           const std::vector<std::uint32_t>& list);
  void recordStaticRects(CachedPass& pass, std::uint32_t cascade,
                         const std::vector<std::uint32_t>& list, bool full);
  bool planRestore(CachedPass& pass, std::uint32_t cascade, bool full);
  void rememberDynamicRects(CachedPass& pass, std::uint32_t cascade,
                            const std::vector<std::uint32_t>& list);
  void recordStaticCopy(VkCommandBuffer cmd, std::uint32_t cascade,
                        std::span<const VkImageCopy> regions, bool whole, bool readStatic);
  void recordShaderCopy(CachedPass& pass, std::uint32_t cascade);
  void recordStaticLayerBack(VkCommandBuffer cmd, std::uint32_t cascade);
  /// CacheRestore::kShaderCopy where the depth format keeps the float it is given (D32).
  [[nodiscard]] bool shaderCopyRestore() const noexcept;
  void recordDynamicPass(CachedPass& pass, std::uint32_t cascade,
                         const std::vector<std::uint32_t>& list);
  void recordCachedEnd(VkCommandBuffer cmd, std::uint32_t copiedMask);

  DeviceInfo device_{};
  VertexLayout layout_{};
  VkPhysicalDeviceProperties properties_{};
  VkPhysicalDeviceMemoryProperties memory_{};
  PFN_vkSetDebugUtilsObjectNameEXT setObjectName_ = nullptr;
  PFN_vkCmdBeginDebugUtilsLabelEXT beginLabel_ = nullptr;
  PFN_vkCmdEndDebugUtilsLabelEXT endLabel_ = nullptr;

  ShadowSettings settings_{};
  RendererOptions options_{};
  RenderMode resolvedMode_ = RenderMode::kPerLayer;
  // The cull mode and front face set in the command buffer being recorded (closed casters
  // change them per draw; beginDepthRendering sets the options' again).
  VkCullModeFlags drawCull_ = VK_CULL_MODE_NONE;
  VkFrontFace drawFront_ = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  DebugMode debugMode_ = DebugMode::kNone;
  CascadeHook cascadeHook_;
  CsmUniforms uniforms_{};
  bool pipelinesBuilt_ = false;
  UpdateStep failAt_ = UpdateStep::kNone;  // failNextUpdateAt

  // Settings-independent objects.
  VkDescriptorSetLayout depthSetLayout_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout lightingLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout pipelineLayout_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSet depthSet_ = VK_NULL_HANDLE;
  VkDescriptorSet lightingSet_ = VK_NULL_HANDLE;
  VkSampler compareSampler_ = VK_NULL_HANDLE;
  VkSampler depthSampler_ = VK_NULL_HANDLE;
  VkBuffer uniformBuffer_ = VK_NULL_HANDLE;
  VkDeviceMemory uniformMemory_ = VK_NULL_HANDLE;
  VkShaderModule vertexModule_ = VK_NULL_HANDLE;
  VkShaderModule layeredModule_ = VK_NULL_HANDLE;
  VkShaderModule thinGeometryModule_ = VK_NULL_HANDLE;  // csm_depth_thin.geom
  // CacheRestore::kShaderCopy: csm_cache_restore.vert/.frag, one sampled static layer a set.
  VkShaderModule restoreVertexModule_ = VK_NULL_HANDLE;
  VkShaderModule restoreFragmentModule_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout restoreSetLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout restoreLayout_ = VK_NULL_HANDLE;
  VkPipeline restorePipeline_ = VK_NULL_HANDLE;
  VkPipeline thinPipeline_ = VK_NULL_HANDLE;         // per-layer, widening thin casters
  VkPipeline thinLayeredPipeline_ = VK_NULL_HANDLE;  // layered, widening thin casters
  std::uint32_t thinResolution_ = 0;
  float thinWidenTexels_ = 0.0f;
  VkFormat thinFormat_ = VK_FORMAT_UNDEFINED;
  bool thinConservative_ = false;  // overestimating rasterisation, no geometry stage

  // Lifetime: the one-time clear and what update() replaced, destroyed after framesInFlight
  // further records (afterRecord = records_ when retired).
  VkCommandPool clearPool_ = VK_NULL_HANDLE;
  VkFence clearFence_ = VK_NULL_HANDLE;
  bool pendingClear_ = false;
  bool uniformsCleared_ = false;
  std::uint64_t records_ = 0;
  // The prefiltered filters' moment image and the resolve's sets (moments.cpp);
  // all null with a percentage-closer kernel.
  static constexpr std::uint32_t kMaxMomentLevels = 15;  // bit_width(kMaxResolution)
  struct MomentImages {
    VkImage image = VK_NULL_HANDLE;  // `format`, mip-mapped, one layer per cascade
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkImageView sampledView = VK_NULL_HANDLE;  // every level (the lighting set)
    VkImageView storageView = VK_NULL_HANDLE;  // level 0 (the resolve writes it)
    VkDescriptorSet set = VK_NULL_HANDLE;      // the resolve's, in the lighting pool
    // Storage views of levels 1.. (levelViews[0] unused: storageView) and the sets that build
    // level k from level k - 1 (mipSets[k]: binding 2 level k - 1, binding 3 level k).
    std::array<VkImageView, kMaxMomentLevels> levelViews{};
    std::array<VkDescriptorSet, kMaxMomentLevels> mipSets{};
    std::uint32_t levels = 0;
    PcfKernel kernel = PcfKernel::kTent3;
    // RG32F (vsm where the device stores it) or RGBA32F; the resolve's pipeline follows it.
    VkFormat format = VK_FORMAT_UNDEFINED;
    // What the last resolve recorded into this image was computed with: a partial resolve
    // (recordMomentResolve after a cached pass) is exact only where nothing else changed.
    bool resolved = false;
    float blurM = 0.0f, evsmPositive = 0.0f, evsmNegative = 0.0f;
    std::array<float, kMaxCascades> texelM{};
    std::array<glm::vec2, kMaxCascades> wrapOffset{};
  };
  // The layer rectangles ([x0, y0, x1, y1) texels) of the sampled depth layers the cached pass
  // changed this record, per cascade, and the cascades it changed whole: what the moment
  // resolve after it recomputes (with the blur's margin). momentPartial_: the pass filled them.
  using LayerRects = std::vector<std::array<std::int32_t, 4>>;
  std::array<LayerRects, kMaxCascades> momentRects_{};
  std::uint32_t momentWholeMask_ = 0;
  bool momentPartial_ = false;
  Status createMomentResources();
  void destroyMomentResources() noexcept;
  Status buildMomentImages(const ShadowSettings& settings, std::uint32_t msmMomentBits,
                           VkDescriptorPool pool, MomentImages& out);
  void destroyMomentImages(MomentImages& m) noexcept;
  void writeMomentSet() const;
  void recordMomentClear(VkCommandBuffer cmd);
  void recordMomentResolve(VkCommandBuffer cmd);
  // The resolve's per-layer regions (tile rectangles) when only part of it changed.
  struct MomentRegions;
  bool planMomentRegions(MomentRegions& plan) const;
  void recordMomentDispatches(VkCommandBuffer cmd, const MomentRegions* plan);
  void recordMomentMips(VkCommandBuffer cmd, const MomentRegions* plan);
  MomentImages moments_{};
  VkDescriptorSetLayout momentSetLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout momentPipelineLayout_ = VK_NULL_HANDLE;
  VkPipeline momentPipeline_ = VK_NULL_HANDLE;     // writes RGBA32F
  VkPipeline momentPipelineRg_ = VK_NULL_HANDLE;   // writes RG32F (extended formats enabled)
  VkPipeline momentPipelineQ16_ = VK_NULL_HANDLE;  // writes RGBA16_UNORM, msm quantised (same)
  [[nodiscard]] VkFormat momentFormatFor(PcfKernel kernel, std::uint32_t msmMomentBits) const;
  [[nodiscard]] VkPipeline momentPipelineFor(VkFormat format) const noexcept;
  VkSampler momentSampler_ = VK_NULL_HANDLE;
  VkSampler wrapMomentSampler_ = VK_NULL_HANDLE;

  struct Retired {
    std::uint64_t afterRecord = 0;
    MomentImages moments{};
    VkImage image = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkImageView views[kMaxCascades + 1] = {};
    VkDescriptorPool pool = VK_NULL_HANDLE;
    VkPipeline pipelines[3] = {};  // per-layer, layered, restore (buildPipelines)
    std::array<VkDescriptorSet, kMaxCascades> sets{};  // in `pool` (the static image's)
  };
  std::vector<Retired> retired_;

  // Settings-dependent objects.
  VkDescriptorPool lightingPool_ = VK_NULL_HANDLE;  // holds lightingSet_
  VkImage image_ = VK_NULL_HANDLE;
  VkDeviceMemory imageMemory_ = VK_NULL_HANDLE;
  VkImageView arrayView_ = VK_NULL_HANDLE;
  VkImageView layerViews_[kMaxCascades] = {};
  std::uint32_t layerCount_ = 0;
  std::uint32_t resolution_ = 0;
  VkPipeline pipeline_ = VK_NULL_HANDLE;         // per-layer
  VkPipeline layeredPipeline_ = VK_NULL_HANDLE;  // layered (when supported)

  // Cached cascades: the static-depth image and the cache's state (csm::CacheState: each
  // static layer's window and what each sampled layer shows), the plan of the frame being
  // recorded (csm::planCacheFrame, made by applyCacheWindows) and, per cascade, where dynamic
  // casters were drawn into the sampled layer last time (restored the next).
  struct DynamicDrawn {
    bool last = false;  // dynamic casters were drawn into the sampled layer last time
    // Layer rectangles ([x0, y0, x1, y1) texels) they were drawn into.
    std::vector<std::array<std::int32_t, 4>> rects;
  };
  static Status checkCacheOptions(const ShadowSettings& settings, const RendererOptions& options);
  CacheState cache_{};
  CachePlan plan_{};
  // RendererOptions::tiles: the host's latest marks (absent: none since the last cut) and each
  // cascade's filter reach of the frame planned (texels).
  std::optional<ReceiverTileMarks> tileMarks_;
  std::array<double, kMaxCascades> tileReach_{};
  std::array<DynamicDrawn, kMaxCascades> dynamicDrawn_{};
  std::array<CascadeCacheStats, kMaxCascades> cacheStats_{};
  VkImage staticImage_ = VK_NULL_HANDLE;
  VkDeviceMemory staticMemory_ = VK_NULL_HANDLE;
  VkImageView staticViews_[kMaxCascades] = {};
  VkDescriptorPool staticPool_ = VK_NULL_HANDLE;  // the restore's sets, one a static layer
  std::array<VkDescriptorSet, kMaxCascades> staticSets_{};
  bool staticInitialised_ = false;
  VkDeviceSize cacheBytes_ = 0;
  bool wrapSampling_ = false;  // the lighting set uses the REPEAT samplers (cache on)
  VkSampler wrapCompareSampler_ = VK_NULL_HANDLE;
  VkSampler wrapDepthSampler_ = VK_NULL_HANDLE;

  // Scratch for the layered mode (cascade mask per caster), reused across frames.
  std::vector<std::uint32_t> casterMasks_;
};

}  // namespace csm::vk
