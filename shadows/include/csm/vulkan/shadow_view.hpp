// One view's shadows in one object: the settings, the caster set, the history, the frame, the
// cull lists and the renderer, set up once; then one call per frame that computes the cascades
// for the camera and the light, culls the casters and records the shadow pass.
//
//   auto view = csm::vk::ShadowView::create(deviceInfo, vertexLayout, &status);
//   view->setSettings(settings);                           // once, and when settings change
//   view->setCasters(meshes, instances, bounds);           // once, and when casters change
//   view->setSceneBounds(&sceneBounds);                    // optional (recommended)
//   each frame:  view->record(cmd, camera, light);         // then bind view->lightingSet()
//   the lighting pipeline: built with view->lightingSpecialization() (the kernel and blend of
//   the settings), rebuilt when that changes
//
// With the receiver fit on (RendererOptions::receiverFit), the host also hands the view its
// depth buffer once a frame, after drawing it, and the next frames' cascades fit the receivers
// it shows:
//                view->recordReceiverDepth(cmd, {depthView, layout, extent, projection});
//
// Built on the public free functions (csm::computeCascades, csm::cullCasters) and
// ShadowRenderer, which stay available to hosts that want their own loop. Settings are given in
// one place, so the frame, the culling and the recording cannot disagree.
//
// One object per view: split screen, a reflection view or a second camera each get their own
// ShadowView (own image, history and lighting set); they may record into the same command
// buffer. Lifetime and threading are those of ShadowRenderer (shadow_renderer.hpp).
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "csm/cascades.hpp"
#include "csm/culling.hpp"
#include "csm/vulkan/depth_range.hpp"
#include "csm/vulkan/shadow_renderer.hpp"

namespace csm::vk {

/// The host's depth buffer of this frame, for the receiver fit (ShadowView::recordReceiverDepth).
struct ReceiverDepthInput {
  /// A view of the depth aspect of the depth buffer, created with SAMPLED usage, in `layout`
  /// (DEPTH_READ_ONLY_OPTIMAL, DEPTH_STENCIL_READ_ONLY_OPTIMAL, READ_ONLY_OPTIMAL or
  /// SHADER_READ_ONLY_OPTIMAL), its writes made visible to the compute stage by the host's barrier.
  VkImageView depthView = VK_NULL_HANDLE;
  VkImageLayout layout = VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL;
  VkExtent2D extent{};
  /// The projection the buffer was drawn with (column-major, GLM indexing, Vulkan clip space:
  /// depth in [0, 1], pixel row 0 at ndc y = -1, so a projection showing +y up has P[1][1] < 0):
  /// any perspective one, standard or reversed depth, finite or infinite far.
  glm::mat4 projection{1.0f};
  /// What the buffer was cleared to: pixels still holding it (sky) are not receivers.
  float clearDepth = 1.0f;
};

/// The lighting pipeline's specialization constants (csm::lightingSpecConstants: kernel, blend,
/// PCSS taps) as Vulkan takes them. Copyable; info() points into this object, so keep it alive
/// until the pipeline is created:
///
///   fragmentStage.pSpecializationInfo = view->lightingSpecializationInfo();
///
/// or, from a copy that outlives the view's next setSettings():
///
///   const csm::vk::LightingSpecialization spec = view->lightingSpecialization();
///   const VkSpecializationInfo specInfo = spec.info();
///   fragmentStage.pSpecializationInfo = &specInfo;
///
/// Two equal specializations build the same pipeline (a host's pipeline cache key).
class LightingSpecialization {
 public:
  explicit LightingSpecialization(const ShadowSettings& settings) noexcept;
  [[nodiscard]] VkSpecializationInfo info() const noexcept;
  [[nodiscard]] const std::array<SpecConstant, kLightingSpecConstantCount>& constants()
      const noexcept {
    return constants_;
  }
  /// The value of constant `id` (CSM_SPEC_*), or `fallback` when it is not one of these.
  [[nodiscard]] std::uint32_t value(std::uint32_t id, std::uint32_t fallback = 0) const noexcept;
  friend bool operator==(const LightingSpecialization& a,
                         const LightingSpecialization& b) noexcept {
    return a.values_ == b.values_;
  }

 private:
  std::array<SpecConstant, kLightingSpecConstantCount> constants_{};
  std::array<VkSpecializationMapEntry, kLightingSpecConstantCount> entries_{};
  std::array<std::uint32_t, kLightingSpecConstantCount> values_{};
};

/// A caster of a ShadowView by handle (ShadowView::addCaster, casterHandle): valid until that
/// caster is removed or setCasters() replaces the set; a stale handle is refused by name, never
/// taken for another caster that reuses its slot.
struct CasterHandle {
  std::uint32_t index = 0xffffffffu;
  std::uint32_t generation = 0;
};

class ShadowView {
 public:
  /// Creates the view's renderer (ShadowRenderer::create). Returns nullptr and fills `status`
  /// on error. setSettings() before the first record().
  [[nodiscard]] static std::unique_ptr<ShadowView> create(const DeviceInfo& device,
                                                          const VertexLayout& layout,
                                                          Status* status = nullptr);
  ~ShadowView();
  ShadowView(const ShadowView&) = delete;
  ShadowView& operator=(const ShadowView&) = delete;

  /// Validates and applies settings and renderer options (ShadowRenderer::update: the image is
  /// cleared to lit and sampleable when this returns, or after prepare()). A change of cascade
  /// count restarts the history. On error nothing changes (but see ShadowRenderer::update on a
  /// Vulkan failure while creating objects). After a compute(), a shadow distance
  /// that does not reach past that camera's near plane is refused here (before, by compute()).
  Status setSettings(const ShadowSettings& settings, const RendererOptions& options);
  /// The same with the current options() kept (the defaults before the first call), so that a
  /// settings change does not reset the cache, the depth format or the LOD choices.
  Status setSettings(const ShadowSettings& settings);
  /// Debug output of the lighting shader (checked at the next record).
  void setDebugMode(DebugMode mode) noexcept;
  [[nodiscard]] DebugMode debugMode() const noexcept;

  /// The casters: meshes, instances (each naming a mesh per LOD, see CasterInstance) and each
  /// instance's world bounds for culling (bounds[i] belongs to instances[i]). Copied; the
  /// culling hierarchy is built here. Refuses (naming the index) a mesh index out of range, a
  /// count mismatch or invalid bounds; on error the previous casters stay.
  Status setCasters(std::span<const MeshDraw> meshes, std::span<const CasterInstance> instances,
                    std::span<const AabbWs> boundsWs);
  /// The same with the culling bounds as a CasterSet the host built (spheres or boxes; caster i
  /// of the set is instances[i]; copied, and built here if it was not).
  Status setCasters(std::span<const MeshDraw> meshes, std::span<const CasterInstance> instances,
                    const CasterSet& casterSet);
  /// Casters one by one, at the cost of what changed (no copy of the set, no rebuild of the
  /// culling hierarchy: the nodes above the caster are refitted): add one (its mesh indices into
  /// the meshes of the last setCasters(), which may have given no instances), change its
  /// instance (transform, LOD meshes, flags) and world bounds, or remove it. With the cache, a
  /// static caster that is added, changed or removed invalidates the texels under its old and
  /// new bounds; dynamic ones cost nothing there. Removed slots are reused by later adds. Refused
  /// by name: a stale or unknown handle, an invalid instance (as setCasters) or bounds; nothing
  /// changes then. A frame compute() made stays recordable: recordPass() culls the new casters.
  Status addCaster(const CasterInstance& instance, const AabbWs& boundsWs, CasterHandle* handle);
  Status updateCaster(CasterHandle handle, const CasterInstance& instance, const AabbWs& boundsWs);
  Status removeCaster(CasterHandle handle);
  /// The handle of caster `index` of the last setCasters() (or of a later add); an invalid
  /// handle for a removed or unknown index.
  [[nodiscard]] CasterHandle casterHandle(std::uint32_t index) const noexcept;
  /// Whether `handle` names a caster of this view now.
  [[nodiscard]] bool valid(CasterHandle handle) const noexcept;

  /// Bounds of every receiver and caster (splits end where the scene does, empty cascades are
  /// skipped); nullptr: unbounded. Invalid bounds are refused.
  Status setSceneBounds(const AabbWs* boundsWs);

  /// The frame: computes the cascades for `camera` and `light` (with the view's history), culls
  /// the casters into them and records the shadow pass into `cmd` (a primary command buffer,
  /// outside any render pass). Afterwards the lighting pass binds lightingSet(). Errors name
  /// the invalid input (camera, light) or come from the renderer; nothing is recorded then.
  Status record(VkCommandBuffer cmd, const Camera& camera, const DirectionalLight& light);

  /// record() in two steps, for hosts that prepare frames on the CPU before recording (or on
  /// another thread): compute() computes the cascades (advancing the history) and culls;
  /// recordPass() records that frame. frame() and cull() are valid after compute().
  /// setCasters() between the two is allowed: recordPass() culls the new casters into the frame.
  Status compute(const Camera& camera, const DirectionalLight& light);
  Status recordPass(VkCommandBuffer cmd);

  /// The frame record() would compute now for `camera` and `light`, without recording or
  /// advancing the view's history (for tests, overlays and hosts that place things by the
  /// cascades). With `history`, that history is used and advanced instead: tools that hold
  /// several frames or histories (measurements) compute them so and record them with
  /// record(cmd, frame).
  [[nodiscard]] Result<CascadeFrame> computeFrame(const Camera& camera,
                                                  const DirectionalLight& light,
                                                  CascadeHistory* history = nullptr) const;
  /// Culls and records a frame computed by computeFrame() (with this view's settings: a frame
  /// computed with others is refused, naming the field). record(cmd, camera, light) is this
  /// after computeFrame with the view's own history.
  Status record(VkCommandBuffer cmd, const CascadeFrame& frame);

  /// Records the pending clear of a new image (hosts without DeviceInfo::queue; see
  /// ShadowRenderer::prepare).
  Status prepare(VkCommandBuffer cmd);
  /// The receiver fit (RendererOptions::receiverFit on) and the receiver-marked tiles
  /// (RendererOptions::tiles): records the reduction of this frame's depth buffer, drawn with
  /// the camera of this frame's record() or compute(), after it (in the same or a later command
  /// buffer, before the frame is submitted). The cascades of frame
  /// N + DeviceInfo::framesInFlight + 1 fit the receivers frame N shows, and draw the tiles its
  /// pixels sample (the reduction's result is read by the recordReceiverDepth of frame
  /// N + framesInFlight, whose recording means the host has waited for frame N's fence);
  /// before a first result, after cameraCut() and while only sky is seen they cover the full
  /// range. The tiles are kept until a newer result replaces them (also while only sky is seen);
  /// after cameraCut() and before a first result there are none: the first frame's partial
  /// cascades fall back, the next ones draw what the frustum can sample. Refused, naming the
  /// field, when the fit and the tiles are off, before the frame's compute() (or after a
  /// record(cmd, frame) whose camera the view does not know, with kSplitsAndBoxes or tiles), or
  /// for an unusable layout, extent or projection; nothing is recorded then.
  Status recordReceiverDepth(VkCommandBuffer cmd, const ReceiverDepthInput& depth);
  /// The result of the last recordReceiverDepth() at once, for a host that has waited for that
  /// frame to complete on the GPU (its fence, or the queue idle): its marks, and with the fit its
  /// range, are used from the next compute() on, instead of framesInFlight frames later. Meant
  /// for the frame after a cameraCut(): one wait, and the partial cascades draw the marks of
  /// the cut's frame instead of what the frustum can sample (almost their whole boxes). Refused
  /// when the fit and the tiles are off; a frame without a result (sky only, none recorded
  /// since the cut) changes nothing.
  Status useLatestReceiverDepth();
  /// The view-depth range of the receivers, for a host with its own reduction (as
  /// DepthRangeReducer reports it, a frame or two late); nothing (the default, and what a host
  /// passes after a camera cut or while no result is ready) = the full range. With its
  /// lightBounds (DepthRangeReducer given ReceiverBoundsInputs) the boxes also fit the visible
  /// receivers. Invalid ranges are refused by the next compute, naming the field. With the
  /// receiver fit on, the next recordReceiverDepth() replaces it.
  void setReceiverDepthRange(std::optional<ReceiverDepthRange> range) noexcept;
  /// The receiver range the next compute() fits the cascades to (nothing: the full range).
  [[nodiscard]] const std::optional<ReceiverDepthRange>& receiverDepthRange() const noexcept;
  /// Cached cascades (RendererOptions::cache): marks the static depth under a world box stale
  /// (only the texels under it are re-rendered at the next record). setCasters() already does
  /// this for static instances that changed; call it for anything else the casters do not show
  /// (a mesh's vertices edited in place, terrain streamed into the same buffers).
  Status invalidate(const AabbWs& boxWs);
  /// Re-renders every cascade's static depth at the next record.
  void invalidateAll() noexcept;
  /// RendererOptions::tiles, for a host with its own reduction: the tiles its visible pixels
  /// sampled (ShadowRenderer::setReceiverTiles), used from the next compute() on (with tiles on,
  /// recordReceiverDepth() does this itself). cameraCut() drops them.
  void setReceiverTiles(std::optional<ReceiverTileMarks> marks) noexcept;

  /// Forgets the history (so sizes need not shrink step by step).
  void resetHistory() noexcept;
  /// A camera cut (a teleport, a respawn, a switch of camera): forgets the history and every
  /// receiver range measured before it (the cascades cover the full range until the first depth
  /// buffer after the cut has been reduced), and the receiver-marked tiles.
  void cameraCut() noexcept;
  /// Per-cascade hook of the pass (GPU timestamps, labels): see CascadeHook.
  void setCascadeHook(CascadeHook hook);

  /// The specialization the lighting pipeline is built with (settings().kernel, blend band, PCSS
  /// taps): build it with this and rebuild it when this changes after setSettings(), so that the
  /// pipeline and the view's settings cannot disagree.
  [[nodiscard]] const LightingSpecialization& lightingSpecialization() const noexcept;
  /// The same as Vulkan takes it, for a shader stage's pSpecializationInfo: valid (and
  /// unchanged) until the next setSettings() or the view's destruction.
  [[nodiscard]] const VkSpecializationInfo* lightingSpecializationInfo() const noexcept;
  /// The set layout the lighting pipeline declares at CSM_SET, and the set to bind (it changes
  /// when setSettings() recreates the image: fetch it each frame).
  [[nodiscard]] VkDescriptorSetLayout lightingSetLayout() const noexcept;
  [[nodiscard]] VkDescriptorSet lightingSet() const noexcept;

  /// The last recorded frame and its cull lists (for overlays, statistics, tests).
  [[nodiscard]] const CascadeFrame& frame() const noexcept;
  [[nodiscard]] const CullResult& cull() const noexcept;
  [[nodiscard]] const ShadowSettings& settings() const noexcept;
  [[nodiscard]] const RendererOptions& options() const noexcept;
  /// Caster slots (removed ones included until an add reuses them).
  [[nodiscard]] std::size_t casterCount() const noexcept;
  [[nodiscard]] std::span<const MeshDraw> meshes() const noexcept;
  [[nodiscard]] std::span<const CasterInstance> instances() const noexcept;
  /// The renderer (its image, views, samplers and uniform block).
  [[nodiscard]] ShadowRenderer& renderer() noexcept;
  [[nodiscard]] const ShadowRenderer& renderer() const noexcept;

 private:
  ShadowView();
  void adoptCasters(std::span<const MeshDraw> meshes, std::span<const CasterInstance> instances);
  void applyThinMargins();
  void cullInto(const CascadeFrame& frame);
  void applyReceiverResult(std::optional<ReceiverDepthRange> result);

  void dropReceiverDepth() noexcept;
  Status checkHandle(const char* call, CasterHandle handle) const;
  // Invalidates the cached texels a caster's change touches (its old and new bounds, static ones).
  void invalidateChange(const CasterInstance* before, const AabbWs* beforeBounds,
                        const CasterInstance* after, const AabbWs* afterBounds);

  // The view's state (settings, casters and their handles, history, frame, cull lists, the
  // renderer and the receiver fit's reducer): shadows/src/vulkan/shadow_view_state.hpp.
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace csm::vk
