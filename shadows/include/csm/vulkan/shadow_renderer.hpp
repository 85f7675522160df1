// The Vulkan renderer of the cascades: one depth image with a layer per cascade, the depth pass
// that fills it, and what a host's lighting shader needs to sample it through csm.glsl.
//
// Per frame, in order:
//   renderer.update(settings, options)           // once, and whenever settings change; the
//                                                // image is then cleared to lit and sampleable
//   frame = csm::computeCascades(...)            // the pure math
//   csm::cullCasters(casterSet, frame, ..., cull)
//   renderer.recordShadowPass(cmd, frame, casters, &cull)   // or the callback form
//   ... host's lighting pass: bind lightingSet() (or its own set) and include csm.glsl
//
// The renderer takes the host's Vulkan handles and allocates its own memory (one allocation per
// resource); it depends on nothing but Vulkan, GLM and csm::core. Not thread-safe: one thread
// records at a time.
//
// Lifetime (see shadows/README.md, "Lifetime"):
//  - After a successful update() the image is cleared to depth 1 ("lit") and in sampledLayout(),
//    so a lighting pass may sample lightingSet() before any shadow pass. With DeviceInfo::queue
//    update() submits that clear itself; without it the host records it with prepare(cmd).
//  - update() never waits for the GPU: what it replaces (image, views, lighting set, pipelines)
//    is retired and destroyed only after DeviceInfo::framesInFlight further recordShadowPass
//    calls (the host has waited for those frames by then) or at destruction. Command buffers
//    recorded before update() stay valid to submit.
//  - The destructor waits for DeviceInfo::queue to be idle (when given) before destroying, so a
//    renderer can be dropped with frames in flight on that queue.
#pragma once

#include <vulkan/vulkan.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "csm/cache_plan.hpp"
#include "csm/cascades.hpp"
#include "csm/culling.hpp"
#include "csm/gpu_layout.hpp"
#include "csm/types.hpp"
#include "csm/vulkan/status.hpp"

namespace csm::vk {

/// What the host's device is and which of its optional features it enabled (the renderer cannot
/// query enabled features from a VkDevice, so the host states them).
struct DeviceInfo {
  VkPhysicalDevice physicalDevice = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  /// Queue family whose command buffers record the shadow pass (graphics): the one-time clear
  /// update() submits is recorded from a command pool of this family.
  std::uint32_t queueFamily = 0;
  /// A queue of `queueFamily` the host submits its frames to. When given, update() submits the
  /// one-time clear of a new image there (and waits for that submission's own fence), and the
  /// destructor waits for the queue to be idle. The host must not submit to it from another
  /// thread during those calls. VK_NULL_HANDLE: the host calls prepare(cmd) after update().
  VkQueue queue = VK_NULL_HANDLE;
  /// How many frames the host may have in flight, [1, 16]: when it records frame N it has
  /// waited for frame N - framesInFlight. Resources replaced by update() are destroyed after
  /// this many further recordShadowPass calls.
  std::uint32_t framesInFlight = 2;
  /// Optional pipeline cache the depth pipelines are created through.
  VkPipelineCache pipelineCache = VK_NULL_HANDLE;
  /// VkPhysicalDeviceFeatures::depthClamp enabled: casters in front of the light box's near
  /// plane still write depth (clamped). Without it they are clipped.
  bool depthClampEnabled = false;
  /// VkPhysicalDeviceVulkan12Features::shaderOutputLayer enabled: allows RenderMode::kLayered.
  bool shaderOutputLayerEnabled = false;
  /// VkPhysicalDeviceFeatures::geometryShader enabled: casters flagged CasterInstance::thin are
  /// widened in the depth pass (RendererOptions::thinCasterWidenTexels). Without it (and without
  /// conservativeRasterizationEnabled) they are drawn like any other caster.
  bool geometryShaderEnabled = false;
  /// VK_EXT_conservative_rasterization enabled on the device: thin casters are widened by
  /// overestimating conservative rasterisation instead (no geometry stage; preferred).
  bool conservativeRasterizationEnabled = false;
  /// VK_EXT_debug_utils is enabled on the instance: objects get names, the pass gets labels.
  bool debugUtilsEnabled = false;
  /// The most anisotropy the moment sampler of the prefiltered filters (vsm, evsm, msm) may use,
  /// in [1, VkPhysicalDeviceLimits::maxSamplerAnisotropy]; above 1 it needs
  /// VkPhysicalDeviceFeatures::samplerAnisotropy enabled. 1 (the default): trilinear. Far and
  /// grazing receivers then read moments filtered along their footprint's long axis instead of
  /// a coarser mip (sharper far shadows at the same smoothness).
  float maxSamplerAnisotropy = 1.0f;
  /// The host's own cap on the shadow-map side in texels (a memory budget, a console's limit);
  /// 0 = only the device's limits. update() refuses a larger resolution with kDeviceLimit.
  std::uint32_t maxResolution = 0;
  /// VkPhysicalDeviceFeatures::shaderStorageImageExtendedFormats is enabled on the device. The
  /// vsm filter then keeps its two moments as R32G32_SFLOAT, 64 bits a texel, where the device
  /// stores and linearly filters that format; otherwise (and for evsm, which keeps four) as
  /// R32G32B32A32_SFLOAT, 128 bits (ShadowRenderer::momentFormat()). The shadows are the same
  /// either way: the two channels hold the same bits. msm keeps 128 bits unless
  /// RendererOptions::msmMomentBits asks for 64 (quantised, R16G16B16A16_UNORM, which also needs
  /// this feature).
  bool storageImageExtendedFormatsEnabled = false;
};

/// Most LODs a caster instance may name (LOD 0 = its full-detail mesh).
inline constexpr std::uint32_t kMaxCasterLods = 4;
/// "No mesh" in CasterInstance::lodMeshes.
inline constexpr std::uint32_t kNoMesh = UINT32_MAX;

/// "Error not known" in CasterInstance::lodErrorM.
inline constexpr float kUnknownLodError = std::numeric_limits<float>::infinity();

/// How the vertex buffers of casters are laid out: the depth pass reads a float3 position.
struct VertexLayout {
  /// Bytes from one vertex to the next.
  std::uint32_t stride = 12;
  /// Byte offset of the position within a vertex.
  std::uint32_t positionOffset = 0;
  /// Format of the position: VK_FORMAT_R32G32B32_SFLOAT (or R32G32B32A32_SFLOAT, w ignored).
  VkFormat positionFormat = VK_FORMAT_R32G32B32_SFLOAT;
  /// VK_INDEX_TYPE_UINT32 or VK_INDEX_TYPE_UINT16.
  VkIndexType indexType = VK_INDEX_TYPE_UINT32;
};

/// How the cascades are drawn.
enum class RenderMode {
  /// One dynamic-rendering pass per non-empty cascade into its layer view.
  kPerLayer,
  /// One pass over every layer; each caster is drawn once, instanced into the cascades it was
  /// culled into, the layer chosen by gl_Layer in the vertex shader. Needs shaderOutputLayer.
  kLayered,
  /// Chosen by settings and device: kPerLayer for stabilised cascades (world-anchored windows:
  /// the same depth with the cache on or off, measured the same cost as layered on an NVIDIA
  /// H200) and on CPU implementations (lavapipe: per-layer measured faster by csm_gpu_bench, see
  /// README); kLayered for unstabilised cascades on other devices when shaderOutputLayer is
  /// enabled (one pass instead of one per cascade). renderMode() tells the choice.
  kAuto,
};

/// The receiver fit of a ShadowView (RendererOptions::receiverFit): from the host's depth buffer
/// (ShadowView::recordReceiverDepth), the view reduces the visible receivers on the GPU and fits
/// the next frames' cascades to them (sample-distribution shadow maps).
enum class ReceiverFit : std::uint8_t {
  /// No reduction: the splits cover the camera's near plane to the shadow distance (or what a
  /// host's own ShadowView::setReceiverDepthRange gives).
  kOff,
  /// The splits cover the receivers' view-depth range (ShadowSettings::receiverDepthMargin,
  /// receiverSplitScheme: the histogram scheme places the interior splits).
  kSplits,
  /// kSplits, and each cascade's box fits the receivers' light-space bounds within it
  /// (ShadowSettings::receiverBoundsMargin).
  kSplitsAndBoxes,
};

/// What the renderer builds its resources from (besides csm::ShadowSettings).
struct RendererOptions {
  /// VK_FORMAT_D32_SFLOAT (default) or VK_FORMAT_D16_UNORM.
  VkFormat depthFormat = VK_FORMAT_D32_SFLOAT;
  /// Face culling of the depth pass (none by default: thin and open casters still cast).
  VkCullModeFlags cullMode = VK_CULL_MODE_NONE;
  /// Front face for cullMode.
  VkFrontFace frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  /// See RenderMode.
  RenderMode renderMode = RenderMode::kAuto;
  /// Pipeline stages of the host that sample the shadow map and read the uniform block after the
  /// pass (the destination of the pass's final barrier, the source of its first one).
  VkPipelineStageFlags2 consumerStages =
      VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  /// The caster LOD each cascade draws at least, [0, kMaxCasterLods): an instance without that
  /// LOD draws its nearest coarser-or-equal one it has (see CasterInstance::lodMeshes). An
  /// explicit schedule; all 0 (the default) leaves the choice to lodMaxErrorTexels.
  std::array<std::uint32_t, kMaxCascades> cascadeLod{};
  /// LODs by the error they make in the cascade's texels: cascade c draws an instance with its
  /// coarsest LOD k whose CasterInstance::lodErrorM[k - 1] is at most lodMaxErrorTexels times
  /// the cascade's texel size (the coarser of that and cascadeLod[c]). 0 = off (the cascadeLod
  /// schedule alone); [0, 64]. Default half a texel: a simplified silhouette moves the shadow's
  /// edge by less than the depth test's own half-texel quantisation (see README).
  float lodMaxErrorTexels = 0.5f;
  /// Cached cascades (kPerLayer only): static casters' depth is kept per cascade across frames
  /// in a second image and only newly exposed, invalidated or new-window texels are rendered;
  /// layers are addressed toroidally (texels fixed in the world, nothing is moved), each
  /// cascade's depth window is world-anchored; dynamic casters are drawn every frame over a copy
  /// of the static depth. csm.glsl reads the same world texels (wrap offsets in the uniforms).
  /// Costs one more depth image of the same size (cacheBytes()). Needs
  /// settings.diagnostics.stabilize. Stabilised per-layer cascades are drawn in the same
  /// world-anchored windows whether cached or not (uncached, every texel is drawn every frame), so
  /// turning the cache on changes the cost, never the depth: the layers are bit-identical either
  /// way (test CacheWorld.*).
  bool cache = false;
  /// Cached cascades: the most static texels re-rendered per frame in the cascades beyond the
  /// first cacheExactCascades (which are always exact and not counted). A cascade whose refresh
  /// does not fit keeps showing the depth, box and matrix it was last rendered with (its shadows
  /// lag, consistently) and is refreshed in a later frame, the one lagging most first (a cascade
  /// whose box no longer covers its slice before all). 0 (default) = no cap; else at least
  /// resolution^2 (one whole layer, so the most stale cascade always fits).
  std::uint64_t cacheBudgetTexels = 0;
  /// Cached cascades with a budget: how many cascades from the camera out are refreshed every
  /// frame whatever they cost, [1, kMaxCascades].
  std::uint32_t cacheExactCascades = 1;
  /// Casters flagged CasterInstance::thin are widened by this many texels on each side in the
  /// depth pass (a geometry shader; see csm_depth_thin.geom); [0, 4], 0 = off. Each texel of
  /// widening adds two texels of full shadow across the caster wherever it passes, whatever its
  /// true width: where a texel is about a pixel, half a texel makes a 3 cm cable's shadow up to
  /// 4 px darker than the truth (measured: shadows/docs/thin_casters.md). The default, a
  /// sixteenth of a texel, keeps it within one pixel on the sample world's cables and halves the
  /// gaps of an unwidened sub-texel caster; half a texel makes any caster at least one texel
  /// wide (continuous), at that price.
  float thinCasterWidenTexels = 0.0625f;
  /// ShadowView only (the renderer ignores it): the receiver fit, see ReceiverFit. Off by default;
  /// on, the host calls ShadowView::recordReceiverDepth once a frame after drawing its depth.
  ReceiverFit receiverFit = ReceiverFit::kOff;
  /// The msm filter's moment image: 128 (default) keeps the four moments as 32-bit floats
  /// (RGBA32F); 64 quantises them to 16 bits (RGBA16_UNORM, Peters and Klein's optimised
  /// quantisation, csm::msmQuantize) where DeviceInfo::storageImageExtendedFormatsEnabled and the
  /// device allow it (else 128; momentFormat() says which), at half the memory. 64 bits leak more
  /// light right behind an occluder (measured: shadows/docs/prefiltered.md). 64 or 128.
  std::uint32_t msmMomentBits = 128;
  /// Receiver-marked tiles, on top of the cache (needs `cache` and a depth-comparison kernel:
  /// the PCF kernels or PCSS). Each frame the host passes the tiles its visible pixels sampled
  /// a few frames earlier (ShadowRenderer::setReceiverTiles; ShadowView does it itself with
  /// ReceiverFit or takes them from the host). The last cascade is drawn whole and refreshed
  /// every frame; every other cascade whose slice lies inside it draws only the stale texels of
  /// marked tiles, and csm.glsl samples it only where every tile under the filter's reach is
  /// drawn, else falls back to the next cascade that holds the receiver (never to garbage, never
  /// to lit). What is sampled is bit-identical to a full render wherever it is drawn. See
  /// shadows/docs/receiver_tiles.md.
  bool tiles = false;
  /// With `tiles`: the most static texels the partial cascades (all but the last) draw in one
  /// frame, so that a light step or a camera cut spreads over frames instead of spiking. Their
  /// held tiles' stale texels go first, then the marked tiles they do not hold, from the camera
  /// out, cascade 0 first; what does not fit waits for a later frame and its pixels fall back to
  /// a coarser cascade meanwhile (CascadeCacheStats::tilesDeferred). The last cascade and
  /// cascades drawn whole are not counted. 0 (default) = no cap; else at least one tile,
  /// (resolution / 16)^2 texels.
  std::uint64_t tileBudgetTexels = 0;
};

/// A range of an index buffer drawn as one caster mesh.
struct MeshDraw {
  VkBuffer vertexBuffer = VK_NULL_HANDLE;
  VkDeviceSize vertexBufferOffset = 0;
  VkBuffer indexBuffer = VK_NULL_HANDLE;
  VkDeviceSize indexBufferOffset = 0;
  std::uint32_t firstIndex = 0;
  std::uint32_t indexCount = 0;
  std::int32_t vertexOffset = 0;
};

/// One shadow caster: a mesh placed in the world. The model transform is `linearWs` (rotation,
/// scale) then a translation to `translationWs` in double precision; the renderer makes it
/// camera-relative itself. Its index in the caster list is its index in csm::CasterSet.
struct CasterInstance {
  /// Index into the mesh list given with the casters (LOD 0, the full detail).
  std::uint32_t mesh = 0;
  glm::dvec3 translationWs{0.0};
  glm::mat3 linearWs{1.0f};
  /// Coarser LODs: lodMeshes[k - 1] is the mesh of LOD k, or kNoMesh when the instance has none
  /// (a cascade asking for LOD k then draws the highest LOD below k that the instance has).
  std::array<std::uint32_t, kMaxCasterLods - 1> lodMeshes{kNoMesh, kNoMesh, kNoMesh};
  /// Geometric error of each coarser LOD, metres in the world (after linearWs): lodErrorM[k - 1]
  /// bounds how far LOD k's surface lies from LOD 0's (a Hausdorff distance), >= 0. +infinity
  /// (the default) = unknown: LOD k is then drawn only where RendererOptions::cascadeLod asks.
  std::array<float, kMaxCasterLods - 1> lodErrorM{kUnknownLodError, kUnknownLodError,
                                                  kUnknownLodError};
  /// A caster that moves (or changes) every frame: with RendererOptions::cache it is drawn
  /// every frame over the cached static depth. Static casters (the default) are cached: when
  /// one is added, removed or moved, the host invalidates its old and new bounds
  /// (ShadowView::setCasters does it for instances whose index, mesh, transform or bounds
  /// changed; ShadowRenderer::invalidate for a world box).
  bool dynamic = false;
  /// A caster thinner than a shadow texel (a cable, an antenna, a fence wire): drawn with its
  /// triangles widened by RendererOptions::thinCasterWidenTexels in light space, so that its
  /// shadow does not break up where it covers no texel centre. Needs
  /// DeviceInfo::conservativeRasterizationEnabled or geometryShaderEnabled (else drawn as is);
  /// every render mode (per-layer, layered, the cache's passes). Flag what is under about a
  /// texel wide in the cascades it casts into (a cable's diameter against the texel size).
  bool thin = false;
  /// Every LOD mesh of this caster is closed: each connected part watertight, its triangles
  /// wound counter-clockwise seen from outside (the outward normal by the right-hand rule). The
  /// depth pass then culls its faces turned away from the light (ShadowDiagnostics::
  /// cullClosedCasters): a light ray enters a closed part through a face that looks at the
  /// light, and leaves through one that does not, so those never hold the nearest depth. A
  /// mirroring linearWs (negative determinant) is accounted for. Leave false (the default) for
  /// open surfaces (terrain, a one-sided wall, leaf cards), whose back faces cast shadows too,
  /// and for casters whose parts may cross the light's near plane on a device without
  /// depthClamp. Thin casters are never culled.
  bool closed = false;
  /// A thin caster's true width where it is narrowest, metres (a pole's top diameter, a cable's
  /// diameter); 0 (the default) = not known; [0, 1000]. Where it is at least half a cascade's
  /// texel, the geometry stage widens it in that cascade to one full texel (csm::
  /// thinCasterWidenTexels: at most a quarter texel each side, a shadow at most twice its true
  /// width), so that it draws as a continuous line instead of dashes; elsewhere, and when not
  /// known, by RendererOptions::thinCasterWidenTexels. Not read for casters that are not thin,
  /// nor where conservative rasterisation widens (by half a texel already).
  float thinWidthM = 0.0f;

  /// The mesh drawn for `lod`.
  [[nodiscard]] std::uint32_t meshForLod(std::uint32_t lod) const noexcept {
    for (std::uint32_t k = std::min(lod, kMaxCasterLods - 1); k > 0; --k) {
      if (lodMeshes[k - 1] != kNoMesh) return lodMeshes[k - 1];
    }
    return mesh;
  }
};

/// The LOD a cascade with texels of `texelSizeM` metres draws `instance` with: the coarsest LOD
/// the instance has whose lodErrorM is at most maxErrorTexels * texelSizeM, or `scheduledLod`
/// when that is coarser (RendererOptions::cascadeLod, lodMaxErrorTexels). Draw
/// instance.meshForLod() of the result.
[[nodiscard]] inline std::uint32_t casterLod(const CasterInstance& instance,
                                             std::uint32_t scheduledLod, double texelSizeM,
                                             float maxErrorTexels) noexcept {
  std::uint32_t lod = std::min(scheduledLod, kMaxCasterLods - 1);
  if (maxErrorTexels > 0.0f) {
    const double budgetM = static_cast<double>(maxErrorTexels) * texelSizeM;
    for (std::uint32_t k = kMaxCasterLods - 1; k > lod; --k) {
      if (instance.lodMeshes[k - 1] != kNoMesh &&
          static_cast<double>(instance.lodErrorM[k - 1]) <= budgetM) {
        return k;
      }
    }
  }
  return lod;
}

/// The caster list of one frame: meshes and their instances.
struct CasterList {
  std::span<const MeshDraw> meshes;
  std::span<const CasterInstance> instances;
  /// World bounds of each instance (boundsWs[i] belongs to instances[i]): needed with
  /// RendererOptions::cache (a scissored region draws only the casters over it), else unused.
  std::span<const AabbWs> boundsWs{};
};

/// Checks a caster list's instances: mesh and LOD indices in range, LOD errors >= 0 (or
/// unknown), translations within +-kMaxWorldCoordinateM and every entry of linearWs finite.
/// The first failure names the instance and field ("casters.instances[7].translationWs.y = nan
/// is invalid: ..."). recordShadowPass and ShadowView::setCasters call it.
[[nodiscard]] Status validateCasters(std::span<const MeshDraw> meshes,
                                     std::span<const CasterInstance> instances);

/// What the cached pass did in one cascade in its last record (RendererOptions::cache).
struct CascadeCacheStats {
  /// Static texels re-rendered (newly exposed, invalidated, or the whole layer on a new window).
  std::uint64_t staticTexels = 0;
  /// Triangles drawn into the static layer and, over it, of dynamic casters.
  std::uint64_t staticTriangles = 0;
  std::uint64_t dynamicTriangles = 0;
  /// The layer was copied from the static cache (something changed under it).
  bool copied = false;
  /// The cascade's window was new (first frame, or a change of size, light, depth range,
  /// resolution or format): the whole layer was re-rendered.
  bool newWindow = false;
  /// RendererOptions::cacheBudgetTexels: the cascade's refresh did not fit this frame; it shows
  /// what it showed lagFrames frames ago (box, matrix, static depth; dynamic casters are drawn
  /// at their current place). lagFrames = 0: the cascade is exact this frame.
  bool deferred = false;
  std::uint32_t lagFrames = 0;
  /// Static texels that a refresh would have re-rendered (= staticTexels when not deferred).
  std::uint64_t wantedTexels = 0;
  /// Texels of the sampled layer restored to the static depth (copied, or redrawn with
  /// CacheRestore::kRedraw), and the static triangles redrawn for it.
  std::uint64_t restoredTexels = 0;
  std::uint64_t restoreTriangles = 0;
  /// Draws saved by drawing a caster over several stale rectangles of one block once, scissored
  /// to the bounding rectangle of its parts (where that is no larger than the parts together).
  std::uint64_t mergedDraws = 0;
  /// Prefiltered kernels: texels of level 0 of the cascade's moment layer that the resolve after
  /// the pass recomputed (converted, blurred, re-mipped): the rectangles the pass changed, widened
  /// by the blur and rounded out to 32-texel tiles (the whole layer on a new window); 0 where
  /// nothing changed.
  std::uint64_t momentTexels = 0;
  /// RendererOptions::tiles: the cascade drew only marked tiles (partial), how many tiles the
  /// marks asked for in it, of how many something was drawn, and how many its layer holds.
  bool partial = false;
  std::uint32_t tilesMarked = 0;
  std::uint32_t tilesDrawn = 0;
  std::uint32_t tilesHeld = 0;
  /// RendererOptions::tileBudgetTexels: marked tiles the budget left for a later frame (their
  /// pixels fall back this frame).
  std::uint32_t tilesDeferred = 0;
};

/// What a draw callback gets for one cascade: the command buffer inside the cascade's render
/// pass with the depth pipeline, its descriptor set and the vertex layout bound, ready for the
/// host's vertex/index buffers and draws.
struct CascadeDrawContext {
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  std::uint32_t cascade = 0;
  /// The cascade's list from the CullResult passed in (or nullptr when none was).
  const std::vector<std::uint32_t>* visible = nullptr;
  VkPipelineLayout pipelineLayout = VK_NULL_HANDLE;
  /// Camera position of the frame (the origin of camera-relative space).
  glm::dvec3 cameraPositionWs{0.0};
  /// The frame being recorded (its cascade `cascade` gives the transform setTransform pushes).
  const CascadeFrame* frame = nullptr;
  /// Windowed cascades (stabilised, per-layer: see RendererOptions::cache): the light-space
  /// point the draws are projected about and the scale to clip space, set by the renderer for
  /// each block of the layer it calls the callback for. Unused (anchored false) otherwise.
  bool anchored = false;
  glm::dvec3 originLs{0.0};
  glm::dvec3 clipPerMetre{1.0};

  /// Sets the model transform of the following draws: pushes model -> the cascade's shadow clip
  /// space, composed in double about the cascade's snapped box centre, or the block's anchor
  /// when windowed (camera-independent, so sub-texel camera motion re-renders a bit-identical
  /// map).
  void setTransform(const glm::dvec3& translationWs, const glm::mat3& linearWs) const;
};

/// Called by the callback form of recordShadowPass once per non-empty cascade, or with windowed
/// cascades once per block of the layer the cascade's box covers (up to four; viewport and
/// scissor already set): draw the same casters each time, with setTransform.
using CascadeDrawCallback = std::function<void(const CascadeDrawContext&)>;

/// The `cascade` a CascadeHook gets after the pass's last render pass ended.
inline constexpr std::uint32_t kCascadeHookEnd = UINT32_MAX;
/// Called by recordShadowPass (both forms) outside any render pass: with the cascade index just
/// before each non-empty cascade's render pass begins (per-layer; layered: once, with the first
/// non-empty cascade), and with kCascadeHookEnd after the last one ended. For per-cascade GPU
/// timestamps and labels; it must not touch the shadow image.
using CascadeHook = std::function<void(VkCommandBuffer cmd, std::uint32_t cascade)>;

/// The shadow renderer. Create with create(); then update() before the first record.
class ShadowRenderer {
 public:
  /// Creates the renderer's device objects that do not depend on settings (pipeline layout,
  /// descriptor layouts, samplers, uniform buffer). Returns nullptr and fills `status` on error.
  [[nodiscard]] static std::unique_ptr<ShadowRenderer> create(const DeviceInfo& device,
                                                              const VertexLayout& layout,
                                                              Status* status = nullptr);
  /// Destroys every object, including retired ones. Waits for DeviceInfo::queue to be idle
  /// first when one was given; otherwise the host must have waited for the GPU.
  ~ShadowRenderer();
  ShadowRenderer(const ShadowRenderer&) = delete;
  ShadowRenderer& operator=(const ShadowRenderer&) = delete;

  /// Applies settings and options: validates them, checks them against the device's limits and
  /// formats, and recreates only what changed (the depth image and its views on resolution,
  /// cascade count or format; the pipelines on format). It does not wait for the GPU: replaced
  /// objects are retired (see "Lifetime" above). A new image is cleared to lit and left in
  /// sampledLayout() before update() returns (DeviceInfo::queue) or by prepare(). Errors name
  /// the field: invalid settings, out-of-range options (renderMode, cullMode, depthFormat), the
  /// device's limits, a Vulkan failure while creating objects. All or nothing: every object the
  /// change needs (pipelines, image, lighting set, static cache image, thin-caster pipelines) is
  /// created before any is installed, so on error the renderer keeps its settings, options,
  /// image and pipelines, and nothing changes. The one exception is the clear of a new image
  /// submitted on DeviceInfo::queue: if that submission fails, the error is returned with the
  /// new settings installed and the clear pending (prepare() or the next shadow pass records
  /// it).
  Status update(const ShadowSettings& settings, const RendererOptions& options);
  /// The same with the current options() kept (the defaults before the first update).
  Status update(const ShadowSettings& settings);

  /// The steps of update() that create Vulkan objects, for fault injection.
  enum class UpdateStep : std::uint8_t {
    kNone = 0,
    kPipelines = 1,      // the depth pipelines (first update, new depth format)
    kImage = 2,          // the shadow map, its views and lighting set (new size, format, cache)
    kStaticImage = 3,    // the cache's static image (with a new image, cache on)
    kThinPipelines = 4,  // the thin casters' pipelines (new resolution, widening or format)
  };
  /// For tests: the next update() fails at `step` as if Vulkan had run out of device memory
  /// there, after the steps before it succeeded (when the change needs that step; otherwise it
  /// succeeds). Used once.
  void failNextUpdateAt(UpdateStep step) noexcept;

  /// Records the pending one-time clear of a new image (depth 1, then sampledLayout()) into
  /// `cmd`, for hosts without DeviceInfo::queue; a no-op when nothing is pending. Record it
  /// before any command buffer that samples the lighting set (a shadow pass clears it too).
  Status prepare(VkCommandBuffer cmd);
  /// Whether a new image still waits for its clear (prepare() or a shadow pass).
  [[nodiscard]] bool needsPrepare() const noexcept;

  /// The run-time debug output of the lighting shader that recordShadowPass packs into the
  /// uniform block (the depth format's bits, the block's other per-frame choice, are the
  /// renderer's own). Checked and applied at the next record.
  void setDebugMode(DebugMode mode) noexcept;
  [[nodiscard]] DebugMode debugMode() const noexcept;
  /// Sets (or clears, with an empty function) the per-cascade hook of the following records.
  void setCascadeHook(CascadeHook hook);

  /// Records the shadow pass of `frame` into `cmd` (a primary command buffer of the queue family,
  /// outside any render pass): uploads the uniform block, then for each non-empty cascade draws
  /// the casters of `visible->visible[c]` (every caster when `visible` is null), then leaves the
  /// image in sampledLayout() for `options.consumerStages`. Each call counts one host frame for
  /// retiring (DeviceInfo::framesInFlight). Errors: kWrongOrder before update(),
  /// kInvalidArgument when the frame was computed with other settings than update()'s (cascade
  /// count, resolution, blend band, normal offset: the field is named) or the uniform options
  /// hold an out-of-range debug mode, kIndexOutOfRange for a visible index or mesh index out of
  /// range (nothing is recorded).
  Status recordShadowPass(VkCommandBuffer cmd, const CascadeFrame& frame, const CasterList& casters,
                          const CullResult* visible);

  /// The callback form: the same pass, with `draw` called inside each non-empty cascade's render
  /// pass (always per-layer). `visible` is only handed through to the callback.
  Status recordShadowPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                          const CascadeDrawCallback& draw, const CullResult* visible = nullptr);

  /// Whether update() succeeded at least once (the renderer can record).
  [[nodiscard]] bool ready() const noexcept;
  /// The 2D-array view over every cascade layer (sampled by csm.glsl).
  [[nodiscard]] VkImageView arrayView() const noexcept;
  /// The comparison sampler (LESS_OR_EQUAL, linear, clamp to an opaque white border = lit).
  [[nodiscard]] VkSampler comparisonSampler() const noexcept;
  /// A plain nearest sampler for reading raw depth (debug outputs, thumbnails).
  [[nodiscard]] VkSampler depthSampler() const noexcept;
  /// The anisotropy of the moment sampler (DeviceInfo::maxSamplerAnisotropy; 1: trilinear).
  [[nodiscard]] float momentAnisotropy() const noexcept;
  /// How far, in texels of each cascade, a caster flagged CasterInstance::thin reaches beyond
  /// its bounds in the depth pass (through the geometry stage the most csm::
  /// thinCasterWidenTexels gives: RendererOptions::thinCasterWidenTexels, at least a quarter
  /// texel; with conservative rasterisation half a texel more than the option); 0 when thin
  /// casters are drawn as they are. ShadowView culls them with this margin
  /// (CasterSet::setMarginTexels).
  [[nodiscard]] float thinMarginTexels() const noexcept;
  /// The layout the image is in after a recorded pass.
  [[nodiscard]] static constexpr VkImageLayout sampledLayout() noexcept {
    return VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  }
  /// The depth image and its format.
  [[nodiscard]] VkImage image() const noexcept;
  [[nodiscard]] VkFormat depthFormat() const noexcept;
  /// The render mode in use (kAuto resolved).
  [[nodiscard]] RenderMode renderMode() const noexcept;
  /// The uniform block as packed by the last recordShadowPass (for hosts with their own buffer).
  [[nodiscard]] const CsmUniforms& uniforms() const noexcept;
  /// The renderer's uniform buffer holding that block (updated inside the recorded pass).
  [[nodiscard]] VkBuffer uniformBuffer() const noexcept;

  // --- Cached cascades (RendererOptions::cache) -------------------------------------------------
  /// Plans the frame's cache (csm::planCacheFrame): fits each non-empty cascade of `frame` into
  /// its cached depth window (world-anchored, quantised, with hysteresis; a new window when the
  /// texel size, the light, the needed depth range no longer fits), rewrites the cascade's depth
  /// range and viewProjCr to that window's, and picks what the budget refreshes (a deferred
  /// cascade becomes what its layer shows). The next record follows that plan, so call it once
  /// per frame, before culling (ShadowView does; a cascade deferred across a change of light is
  /// culled in the basis its layer shows, ShadowView culls it so); the cached
  /// recordShadowPass refuses a frame it was not applied to (uncached, it windows a copy of the
  /// frame itself). No-op unless the cascades are windowed (settings.diagnostics.stabilize,
  /// per-layer).
  void applyCacheWindows(CascadeFrame& frame);
  /// The plan applyCacheWindows() made for the frame last windowed (empty when the cascades are
  /// not windowed): per cascade, whether it is refreshed or deferred, its box and wrap offset,
  /// and the light basis it is drawn in. A host that culls itself culls cascade c in
  /// cachePlan().cascades[c].basis where that cascade is active (csm::cullCasters' per-cascade
  /// bases), as ShadowView does.
  [[nodiscard]] const CachePlan& cachePlan() const noexcept;
  /// Marks the static depth under a world box stale in every cascade (a static caster added,
  /// removed or moved; terrain streamed in): only the texels under it are re-rendered at the
  /// next record. Invalid boxes are refused.
  Status invalidate(const AabbWs& boxWs);
  /// Marks every cascade stale (the next record re-renders all static texels).
  void invalidateAll() noexcept;
  /// RendererOptions::tiles: the tiles the host's visible pixels sample (csm::ReceiverTileMarks,
  /// from DepthRangeReducer with ReceiverBoundsInputs::tiles, typically a few frames old),
  /// used by the frames computed after it until replaced. Absent (after a camera cut, or before
  /// the first marks): the partial cascades draw nothing more and their pixels fall back.
  void setReceiverTiles(std::optional<ReceiverTileMarks> marks) noexcept;
  /// What the last cached record did per cascade.
  [[nodiscard]] const std::array<CascadeCacheStats, kMaxCascades>& cacheStats() const noexcept;
  /// Device memory of the static-depth cache image (0 without the cache).
  [[nodiscard]] VkDeviceSize cacheBytes() const noexcept;
  /// The static-depth image (DEPTH_ATTACHMENT_OPTIMAL after a cached record; null without cache).
  [[nodiscard]] VkImage staticImage() const noexcept;
  /// Prefiltered kernels (vsm, evsm, msm): the moment image (momentFormat(), momentLevels()
  /// mips, one layer per cascade, addressed like the depth layers; SHADER_READ_ONLY_OPTIMAL
  /// after a record) that csm.glsl samples; null and 0 with a percentage-closer kernel.
  [[nodiscard]] VkImage momentImage() const noexcept;
  [[nodiscard]] std::uint32_t momentLevels() const noexcept;
  /// The moment image's format: R32G32_SFLOAT for vsm where
  /// DeviceInfo::storageImageExtendedFormatsEnabled allows it, R16G16B16A16_UNORM (quantised) for
  /// msm where RendererOptions::msmMomentBits = 64 and the same allow it, else
  /// R32G32B32A32_SFLOAT; VK_FORMAT_UNDEFINED with a percentage-closer kernel.
  [[nodiscard]] VkFormat momentFormat() const noexcept;
  /// Device memory of the moment image with its mips (0 with a percentage-closer kernel):
  /// csm::momentImageBytes of the settings and momentFormat()'s texel size.
  [[nodiscard]] VkDeviceSize momentBytes() const noexcept;

  /// Descriptor set layout of csm.glsl's resources: CSM_BINDING_UNIFORMS (uniform buffer),
  /// CSM_BINDING_SHADOW_MAP (comparison sampler + array view), CSM_BINDING_SHADOW_DEPTH (depth
  /// sampler + array view), visible to fragment and compute shaders.
  [[nodiscard]] VkDescriptorSetLayout lightingSetLayout() const noexcept;
  /// A descriptor set of that layout owned by the renderer, pointing at the current resources.
  /// A new set replaces it when update() recreates the image (the old one stays valid for
  /// command buffers already recorded, until retired): fetch it each frame.
  [[nodiscard]] VkDescriptorSet lightingSet() const noexcept;
  /// Writes the current resources into a host-allocated set of lightingSetLayout().
  Status writeLightingSet(VkDescriptorSet set) const;

 private:
  // The state and the steps (shadow_renderer_impl.hpp, private to the module); ShadowView reads
  // the cache's light bases there to cull deferred cascades.
  friend class ShadowView;
  class Impl;
  ShadowRenderer();
  std::unique_ptr<Impl> impl_;
};

}  // namespace csm::vk
