// Draws the sample world: the cascades (csm::core), the shadow pass (csm::vk::ShadowRenderer,
// far cascades drawing simplified caster clusters), the instanced lit pass through csm.glsl
// (deferred: a G-buffer pass and a lighting pass over the view; or forward, after a depth
// pre-pass) and the cascade-visualisation overlay (tint and texel checker in the shading;
// shadow-map thumbnails and the top-down map as 2D geometry). Composes engine/ and shadows/.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "csm/cascades.hpp"
#include "csm/culling.hpp"
#include "csm/vulkan/depth_range.hpp"
#include "csm/vulkan/shadow_renderer.hpp"
#include "csm/vulkan/shadow_view.hpp"
#include "engine/camera.hpp"
#include "engine/context.hpp"
#include "engine/gpu_timer.hpp"
#include "engine/memory.hpp"
#include "engine/mesh_store.hpp"
#include "engine/pipeline.hpp"
#include "engine/render_target.hpp"
#include "glue/shadow_host.hpp"
#include "sample_world/paths.hpp"
#include "sample_world/settings.hpp"
#include "sample_world/world.hpp"

namespace world {

/// What one frame cost and drew.
struct FrameStats {
  double cpuSetupMs = 0.0;   ///< ShadowView::compute: cascades + caster culling (all cascades)
  double cpuCullMs = 0.0;    ///< view culling of the lit pass
  double cpuRecordMs = 0.0;  ///< recording the command buffer
  std::uint32_t cascadeCount = 0;
  std::array<std::uint32_t, csm::kMaxCascades> casters{};
  std::array<std::uint64_t, csm::kMaxCascades> triangles{};  ///< drawn this frame
  /// Shadow-map texels re-rendered this frame (the whole layer without the cache).
  std::array<std::uint64_t, csm::kMaxCascades> texelsRendered{};
  /// Prefiltered filters: moment texels (level 0) resolved this frame (the whole layer without
  /// the cache; with it, the tiles the pass changed); 0 with a percentage-closer kernel.
  std::array<std::uint64_t, csm::kMaxCascades> momentTexels{};
  /// Frames the cascade's content lags the camera (the cache's texel budget deferred it).
  std::array<std::uint32_t, csm::kMaxCascades> lagFrames{};
  /// settings.tileMarks: the tiles marked per cascade by the reduction of the depth buffer of
  /// engine::kFramesInFlight frames ago (tilesMarkedFrom: that frame's cascade count; 0 when no
  /// result was ready: the first frames, an empty view).
  std::array<std::uint32_t, csm::kMaxCascades> tilesMarked{};
  std::uint32_t tilesMarkedFrom = 0;
  /// settings.shadowTiles (with the cache): bit c when cascade c drew only marked tiles this
  /// frame, and per cascade the tiles it drew something in and the tiles its layer holds
  /// (csm::vk::CascadeCacheStats).
  std::uint32_t tilesPartialMask = 0;
  std::array<std::uint32_t, csm::kMaxCascades> tilesDrawn{};
  std::array<std::uint32_t, csm::kMaxCascades> tilesHeld{};
  /// Device memory of the static-depth cache (0 without it).
  std::uint64_t cacheBytes = 0;
  /// The LODs a cascade drew its caster clusters with: the finest and the coarsest, and how many
  /// clusters (0: an empty cascade, or one that drew only dynamic casters; finest = coarsest = 0).
  struct LodRange {
    std::uint32_t finest = 0;
    std::uint32_t coarsest = 0;
    std::uint32_t clusters = 0;
  };
  std::array<LodRange, csm::kMaxCascades> lod{};
  std::uint32_t litInstances = 0;
  std::uint64_t litTriangles = 0;
  csm::CascadeFrame cascades{};
  /// Device memory of the prefiltered filters' moment image with its mips (0 with a
  /// percentage-closer kernel): 8 bytes a texel for vsm and 64-bit msm where the device stores
  /// the compact formats, else 16.
  std::uint64_t momentBytes = 0;
  /// settings.tileBudgetTexels: per cascade, the marked tiles the budget left for a later frame.
  std::array<std::uint32_t, csm::kMaxCascades> tilesDeferred{};
};

class WorldRenderer {
 public:
  /// Uploads the world's meshes, creates the shadow renderer and the pipelines for targets of
  /// `colorFormat` / `depthFormat`. `momentAnisotropy`: the moment sampler's anisotropy cap
  /// (glue::shadowDeviceInfo: 1 = trilinear; nothing = glue::defaultMomentAnisotropy). Throws
  /// std::runtime_error on failure.
  WorldRenderer(engine::Context& ctx, const World& world, VkFormat colorFormat,
                VkFormat depthFormat, std::optional<float> momentAnisotropy = std::nullopt);
  ~WorldRenderer();
  WorldRenderer(const WorldRenderer&) = delete;
  WorldRenderer& operator=(const WorldRenderer&) = delete;

  /// Applies settings (shadow resources are recreated only when needed). Returns the error and
  /// keeps the previous settings when they are refused.
  std::optional<std::string> apply(const AppSettings& settings);

  /// Moves the sun (AppSettings::lightAzimuthDeg / lightElevationDeg) without touching any other
  /// setting: what a time of day changes every frame. Returns the error (naming the field, the
  /// value and its range) and keeps the sun when refused.
  std::optional<std::string> setSun(const SunPose& sun);
  /// Tells the renderer the camera has cut to an unrelated place: the receivers' depth range of
  /// earlier frames (receiver-driven splits) is dropped instead of being applied to the new view,
  /// and the cascades' history is reset (csm::vk::ShadowView::resetHistory).
  void cameraCut();
  /// The frame after a cut, with receiver-marked tiles or the receiver fit: true when the host
  /// should wait for the GPU (the cut's frame complete) and call takeLatestReceivers() before
  /// prepare(), so that this frame draws the cut's marks (and fits its range) instead of what the
  /// frustum can sample.
  [[nodiscard]] bool wantsLatestReceivers() const noexcept { return latestAfterCut_; }
  /// After the host waited for every submitted frame: the results of the last recorded
  /// reductions (the cut's frame) go to the next prepare().
  void takeLatestReceivers();

  /// CPU side of a frame: cascades, caster culling, lit-pass culling and instance lists.
  /// Returns the error of computeCascades (invalid camera) instead of throwing.
  std::optional<std::string> prepare(const engine::Camera& camera, FrameStats& stats);

  /// Records the frame prepared last into `frame`: shadow pass, lit pass, overlay 2D geometry
  /// when `overlay`. GPU scopes: "shadow", "shadow c<i>", "prepass" (settings.depthPrepass),
  /// "gbuffer" (settings.deferred), "lit" (the deferred lighting pass there), "overlay".
  void record(const engine::Frame& frame, engine::GpuTimer& timer, bool overlay, FrameStats& stats);

  const csm::CascadeFrame& cascades() const { return shadow_->frame(); }
  const csm::CullResult& cull() const { return shadow_->cull(); }
  const World& world() const { return *world_; }
  const AppSettings& settings() const { return settings_; }
  csm::vk::ShadowRenderer& shadowRenderer() { return shadow_->renderer(); }
  csm::vk::ShadowView& shadowView() { return *shadow_; }
  /// Total triangles of the clusters' LOD l (for statistics).
  std::uint64_t clusterTriangles(std::uint32_t lod) const;

 private:
  struct Bucket {
    std::uint32_t mesh = 0, lod = 0;
    std::uint32_t first = 0, count = 0;
    bool cullBack = false;  // a closed mesh drawn with its back faces culled
  };
  struct Instance {
    glm::vec4 rows[3];
    glm::vec4 color;
  };
  struct OverlayVertex {
    glm::vec2 pixel;
    glm::vec2 uv;
    glm::vec4 color;
    // Thumbnails (overlay_2d.frag): x cascade (< 0: solid colour), y world height (m, above the
    // bounding sphere's centre) of box texel (0, 0) at depth 0, z the sphere's radius, w side px;
    // relief: world height per box texel along x, y and per unit of stored depth.
    glm::vec4 thumb;
    glm::vec3 relief;
  };
  struct Slot {
    engine::Buffer frameUniforms;
    engine::Buffer instances;
    engine::Buffer overlay;
    VkDescriptorSet frameSet = VK_NULL_HANDLE;
    // The G-buffer (settings.deferred), sized for the frame this slot last drew; its set
    // (binding 0 albedo, 1 normals, 2 view depth) is written when the images are (re)created.
    engine::Image gAlbedo, gNormals, gViewDepth;
    VkDescriptorSet gbufferSet = VK_NULL_HANDLE;
    VkExtent2D gbufferExtent{0, 0};
  };
  // The constructor's stages, in order.
  void uploadMeshes(const World& world);     // every asset and caster-cluster LOD, one store
  void buildViewGroups(const World& world);  // per-chunk culling groups, the dynamic casters
  void setUpShadowView(const World& world,
                       std::optional<float> momentAnisotropy);  // the view, its casters
  void createFrameResources();  // per-frame uniforms, instances, overlay vertices
  void createPipelines();       // shader modules and the overlay pipelines
  void buildLitPipeline();
  void recordDepthRange(const engine::Frame& f, engine::GpuTimer& timer, FrameStats& stats);
  void recordTileMarks(const engine::Frame& f, engine::GpuTimer& timer, FrameStats& stats);
  // The tile-marking reduction runs (measured, or driving the receiver-marked tiles).
  [[nodiscard]] bool marking() const noexcept {
    return settings_.tileMarks || settings_.shadowTiles;
  }
  // record()'s passes: the shadow pass (with its statistics), then inside one rendering the lit
  // pass and the overlay.
  void recordShadowPass(VkCommandBuffer cmd, engine::GpuTimer& timer, FrameStats& stats);
  void recordLitPass(const engine::Frame& f, Slot& slot, engine::GpuTimer& timer, bool overlay);
  // The depth pre-pass (settings.depthPrepass): the visible instances depth-only, in a rendering
  // of its own, so that the lit pass shades each pixel once (depth test EQUAL, no writes).
  void recordDepthPrepass(const engine::Frame& f, Slot& slot, engine::GpuTimer& timer);
  // Deferred shading (settings.deferred): the G-buffer pass in a rendering of its own, then the
  // lighting pass (one triangle over the view) opening the rendering the overlay draws into.
  void createGBufferResources();  // set layout, pool, sampler and one set per slot
  void ensureGBuffer(Slot& slot, VkExtent2D extent);
  void recordGBufferPass(const engine::Frame& f, Slot& slot, engine::GpuTimer& timer);
  void recordDeferredLighting(const engine::Frame& f, Slot& slot, engine::GpuTimer& timer);
  void bindWorldGeometry(VkCommandBuffer cmd, Slot& slot) const;
  // Draws every bucket; binds `cullBack` or `both` (each bound with `layout`'s sets) as the
  // buckets' back-face culling changes.
  void drawBuckets(VkCommandBuffer cmd, const engine::GraphicsPipeline& both,
                   const engine::GraphicsPipeline& cullBack) const;
  void recordOverlay(const engine::Frame& f, Slot& slot, engine::GpuTimer& timer);
  void buildOverlay(VkExtent2D extent, std::vector<OverlayVertex>& tris,
                    std::vector<OverlayVertex>& lines) const;

  engine::Context* ctx_;
  const World* world_;
  VkFormat colorFormat_, depthFormat_;
  AppSettings settings_{};
  bool applied_ = false;

  std::unique_ptr<engine::MeshStore> meshes_;
  std::vector<std::array<engine::MeshRange, kLodCount>> assetRanges_;
  std::vector<std::array<engine::MeshRange, kLodCount>> clusterRanges_;
  // The shadows of this view: clusters as instances with one mesh per LOD (cluster k's LOD l
  // is mesh k * kLodCount + l).
  std::unique_ptr<csm::vk::ShadowView> shadow_;
  engine::Camera camera_{};
  // settings.tileMarks: the reduction that marks the tiles visible pixels sample (one slot per
  // frame in flight, the frame's slot), and the camera of the frame prepare() computed.
  std::unique_ptr<csm::vk::DepthRangeReducer> tileReducer_;
  csm::Camera frameCamera_{};
  // After a cut: the reductions were recorded since (the slot tileReducer_ filled last), and
  // the next frame may take their results at once (wantsLatestReceivers).
  bool cutPending_ = true;  // the start is a cut
  bool latestAfterCut_ = false;
  std::uint32_t lastTileSlot_ = 0;

  // Per chunk: the bounds of everything in it (view culling of the lit pass).
  std::vector<csm::AabbWs> chunkBounds_;
  std::vector<std::vector<std::uint32_t>> chunkObjects_;

  engine::DeviceHandle<VkDescriptorSetLayout> frameLayout_;
  engine::DeviceHandle<VkDescriptorPool> pool_;
  std::array<Slot, engine::kFramesInFlight> slots_;
  engine::DeviceHandle<VkShaderModule> worldVert_, worldFrag_, overlayVert_, overlayFrag_;
  // By the view's specialization (specKey) | kLitAfterPrepass: the lit pipeline, with depth LESS
  // and writes, or after the depth pre-pass (EQUAL, no writes).
  std::map<std::uint32_t, engine::GraphicsPipeline> litPipelines_;
  static constexpr std::uint32_t kLitAfterPrepass = 1u << 16;
  static constexpr std::uint32_t kLitCullBack = 1u << 17;
  engine::GraphicsPipeline depthPrepass_, depthPrepassCullBack_;  // world.vert only
  // Deferred shading: the G-buffer pipelines (world.vert + world_gbuffer.frag, both faces and
  // back faces culled) and, by kernel, the lighting pipeline (world_deferred.vert/.frag).
  engine::DeviceHandle<VkShaderModule> gbufferFrag_, deferredVert_, deferredFrag_;
  engine::GraphicsPipeline gbuffer_, gbufferCullBack_;
  std::map<std::uint32_t, engine::GraphicsPipeline> deferredPipelines_;
  engine::DeviceHandle<VkDescriptorSetLayout> gbufferLayout_;
  engine::DeviceHandle<VkDescriptorPool> gbufferPool_;
  engine::DeviceHandle<VkSampler> gbufferSampler_;
  // Per mesh asset: every LOD is closed and outward (settings.cullBackFaces culls its back faces).
  std::vector<bool> closedMesh_;
  void buildClosedMeshes(const World& world);
  const engine::GraphicsPipeline& litPipeline(bool prepass, bool cullBack) const;
  engine::GraphicsPipeline overlayTris_, overlayLines_;

  // Dynamic shadow casters (vehicles, a swinging crane jib): unit cubes moved every frame,
  // drawn by the shadow view over its cached static depth and by the lit pass.
  struct Mover {
    double radiusM;  // vehicles: circle about the camera's ground point; crane: jib length
    double speed;    // radians per frame
    double phase;
    glm::dvec3 sizeM;  // full extents
    bool crane;
  };
  void moveDynamicCasters();
  std::vector<Mover> movers_;
  std::uint32_t cubeMesh_ = 0;  // index into assetRanges_ (after the world's meshes)
  std::uint64_t frameCounter_ = 0;
  std::vector<csm::vk::CasterInstance> casterInstances_;
  std::vector<csm::AabbWs> casterBounds_;
  std::size_t staticCasters_ = 0;
  std::vector<Instance> moverInstances_;

  std::vector<Instance> instances_;
  std::vector<Bucket> buckets_;
  std::vector<std::uint32_t> bucketOrder_;
  std::vector<std::vector<std::uint32_t>> bucketObjects_;  // per mesh * kLodCount + lod
  std::uint32_t maxInstances_ = 0;
  static constexpr std::uint32_t kMaxOverlayVertices = 1u << 16;
};

}  // namespace world
