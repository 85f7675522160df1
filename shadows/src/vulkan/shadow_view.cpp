// ShadowView: one view's settings, casters, history, frame and cull lists around a renderer.
#include "csm/vulkan/shadow_view.hpp"

#include <algorithm>
#include <span>
#include <string>

#include "shadow_renderer_impl.hpp"
#include "shadow_view_state.hpp"

namespace csm::vk {

LightingSpecialization::LightingSpecialization(const ShadowSettings& settings) noexcept
    : constants_(lightingSpecConstants(settings)) {
  for (std::uint32_t i = 0; i < kLightingSpecConstantCount; ++i) {
    values_[i] = constants_[i].value;
    entries_[i] = {constants_[i].id, i * static_cast<std::uint32_t>(sizeof(std::uint32_t)),
                   sizeof(std::uint32_t)};
  }
}

VkSpecializationInfo LightingSpecialization::info() const noexcept {
  return {kLightingSpecConstantCount, entries_.data(), sizeof(values_), values_.data()};
}

std::uint32_t LightingSpecialization::value(std::uint32_t id,
                                            std::uint32_t fallback) const noexcept {
  for (const SpecConstant& c : constants_) {
    if (c.id == id) return c.value;
  }
  return fallback;
}

namespace {

bool sameInstance(const CasterInstance& a, const CasterInstance& b) {
  return a.mesh == b.mesh && a.translationWs == b.translationWs && a.linearWs == b.linearWs &&
         a.lodMeshes == b.lodMeshes && a.lodErrorM == b.lodErrorM && a.dynamic == b.dynamic &&
         a.thin == b.thin && a.thinWidthM == b.thinWidthM && a.closed == b.closed;
}

bool sameBox(const AabbWs& a, const AabbWs& b) {
  return a.minWs == b.minWs && a.maxWs == b.maxWs;
}

std::string handleText(CasterHandle h) {
  return "{index " + std::to_string(h.index) + ", generation " + std::to_string(h.generation) + "}";
}

}  // namespace

ShadowView::ShadowView() : state_(std::make_unique<State>()) {}

ShadowView::~ShadowView() = default;

Status ShadowView::setSettings(const ShadowSettings& settings) {
  return setSettings(settings, state_->options_);
}
void ShadowView::setDebugMode(DebugMode mode) noexcept {
  state_->renderer_->setDebugMode(mode);
}
DebugMode ShadowView::debugMode() const noexcept {
  return state_->renderer_->debugMode();
}
Status ShadowView::prepare(VkCommandBuffer cmd) {
  return state_->renderer_->prepare(cmd);
}
void ShadowView::setReceiverDepthRange(std::optional<ReceiverDepthRange> range) noexcept {
  state_->receiverRange_ = range;
}
const std::optional<ReceiverDepthRange>& ShadowView::receiverDepthRange() const noexcept {
  return state_->receiverRange_;
}
Status ShadowView::invalidate(const AabbWs& boxWs) {
  return state_->renderer_->invalidate(boxWs);
}
void ShadowView::invalidateAll() noexcept {
  state_->renderer_->invalidateAll();
}
void ShadowView::resetHistory() noexcept {
  state_->history_ = {};
}
void ShadowView::setCascadeHook(CascadeHook hook) {
  state_->renderer_->setCascadeHook(std::move(hook));
}
const LightingSpecialization& ShadowView::lightingSpecialization() const noexcept {
  return state_->spec_;
}
const VkSpecializationInfo* ShadowView::lightingSpecializationInfo() const noexcept {
  return &state_->specInfo_;
}
VkDescriptorSetLayout ShadowView::lightingSetLayout() const noexcept {
  return state_->renderer_->lightingSetLayout();
}
VkDescriptorSet ShadowView::lightingSet() const noexcept {
  return state_->renderer_->lightingSet();
}
const CascadeFrame& ShadowView::frame() const noexcept {
  return state_->frame_;
}
const CullResult& ShadowView::cull() const noexcept {
  return state_->cull_;
}
const ShadowSettings& ShadowView::settings() const noexcept {
  return state_->settings_;
}
const RendererOptions& ShadowView::options() const noexcept {
  return state_->options_;
}
std::size_t ShadowView::casterCount() const noexcept {
  return state_->instances_.size();
}
std::span<const MeshDraw> ShadowView::meshes() const noexcept {
  return state_->meshes_;
}
std::span<const CasterInstance> ShadowView::instances() const noexcept {
  return state_->instances_;
}
ShadowRenderer& ShadowView::renderer() noexcept {
  return *state_->renderer_;
}
const ShadowRenderer& ShadowView::renderer() const noexcept {
  return *state_->renderer_;
}

std::unique_ptr<ShadowView> ShadowView::create(const DeviceInfo& device, const VertexLayout& layout,
                                               Status* status) {
  std::unique_ptr<ShadowView> view(new ShadowView());
  view->state_->renderer_ = ShadowRenderer::create(device, layout, status);
  if (!view->state_->renderer_) return nullptr;
  view->state_->device_ = device;
  view->state_->specInfo_ = view->state_->spec_.info();
  return view;
}

Status ShadowView::setSettings(const ShadowSettings& settings, const RendererOptions& options) {
  // Refused here rather than by every later frame: shadows must reach past the near plane of
  // the camera the view last computed for.
  if (state_->lastCamera_) {
    if (auto e = csm::validate(settings, *state_->lastCamera_, DirectionalLight{})) {
      return Status(ErrorCode::kInvalidArgument, e->message());
    }
  }
  if (options.receiverFit != ReceiverFit::kOff && options.receiverFit != ReceiverFit::kSplits &&
      options.receiverFit != ReceiverFit::kSplitsAndBoxes) {
    return Status(ErrorCode::kInvalidArgument,
                  "options.receiverFit = " + std::to_string(int(options.receiverFit)) +
                      " is invalid: allowed kOff, kSplits or kSplitsAndBoxes");
  }
  // The reduction of the receiver fit and of the tile marks, made before anything changes (a
  // failure leaves the view whole).
  std::unique_ptr<DepthRangeReducer> reducer;
  if ((options.receiverFit != ReceiverFit::kOff || options.tiles) && !state_->reducer_) {
    Status made;
    reducer = DepthRangeReducer::create(state_->device_, state_->device_.framesInFlight, &made);
    if (!reducer) return made;
  }
  Status s = state_->renderer_->update(settings, options);
  if (!s.ok()) return s;
  if (reducer) state_->reducer_ = std::move(reducer);
  if (!state_->hasSettings_ || settings.cascadeCount != state_->settings_.cascadeCount) {
    state_->history_ = {};
    dropReceiverDepth();
  }
  if (options.receiverFit != state_->options_.receiverFit ||
      options.tiles != state_->options_.tiles) {
    dropReceiverDepth();
  }
  state_->settings_ = settings;
  state_->options_ = options;
  state_->hasSettings_ = true;
  state_->spec_ = LightingSpecialization(state_->settings_);
  state_->specInfo_ = state_->spec_.info();
  applyThinMargins();
  // A frame compute() made before stays recordable only if it agrees with the new settings in
  // what the pass and the shader read (the renderer checks and names any difference).
  return {};
}

Status ShadowView::setCasters(std::span<const MeshDraw> meshes,
                              std::span<const CasterInstance> instances,
                              std::span<const AabbWs> boundsWs) {
  if (boundsWs.size() != instances.size()) {
    return Status(ErrorCode::kInvalidArgument,
                  "setCasters: " + std::to_string(boundsWs.size()) + " bounds for " +
                      std::to_string(instances.size()) + " instances: give one per instance");
  }
  Status s = validateCasters(meshes, instances);
  if (!s.ok()) return s;
  CasterSet set;
  set.reserve(instances.size());
  for (std::size_t i = 0; i < boundsWs.size(); ++i) {
    auto added = set.addBox(boundsWs[i].minWs, boundsWs[i].maxWs);
    if (!added) {
      return Status(ErrorCode::kInvalidArgument,
                    "setCasters: bounds[" + std::to_string(i) + "]: " + added.error().message());
    }
  }
  set.build();
  state_->casterSet_ = std::move(set);
  adoptCasters(meshes, instances);
  return {};
}

Status ShadowView::setCasters(std::span<const MeshDraw> meshes,
                              std::span<const CasterInstance> instances,
                              const CasterSet& casterSet) {
  if (casterSet.size() != instances.size()) {
    return Status(ErrorCode::kInvalidArgument,
                  "setCasters: a caster set of " + std::to_string(casterSet.size()) + " for " +
                      std::to_string(instances.size()) + " instances: give one per instance");
  }
  Status s = validateCasters(meshes, instances);
  if (!s.ok()) return s;
  state_->casterSet_ = casterSet;
  if (!state_->casterSet_.built() || state_->casterSet_.unindexedCount() > 0)
    state_->casterSet_.build();
  adoptCasters(meshes, instances);
  return {};
}

void ShadowView::adoptCasters(std::span<const MeshDraw> meshes,
                              std::span<const CasterInstance> instances) {
  std::vector<AabbWs> bounds(state_->casterSet_.size());
  for (std::size_t i = 0; i < bounds.size(); ++i) {
    bounds[i] = state_->casterSet_.bounds(static_cast<std::uint32_t>(i));
  }
  // Cached cascades: a static caster whose index, mesh, transform, bounds or thin or closed flag
  // changed (or that was added or removed) invalidates its old and new bounds; dynamic ones are
  // drawn every frame.
  if (state_->options_.cache) {
    const bool meshesSame =
        meshes.size() == state_->meshes_.size() &&
        std::equal(meshes.begin(), meshes.end(), state_->meshes_.begin(),
                   [](const auto& a, const auto& b) {
                     return a.vertexBuffer == b.vertexBuffer && a.indexBuffer == b.indexBuffer &&
                            a.vertexBufferOffset == b.vertexBufferOffset &&
                            a.indexBufferOffset == b.indexBufferOffset &&
                            a.firstIndex == b.firstIndex && a.indexCount == b.indexCount &&
                            a.vertexOffset == b.vertexOffset;
                   });
    if (!meshesSame) {
      state_->renderer_->invalidateAll();
    } else {
      const std::size_t n = std::max(instances.size(), state_->instances_.size());
      for (std::size_t i = 0; i < n; ++i) {
        const bool hasOld = i < state_->instances_.size() && !state_->instances_[i].dynamic;
        const bool hasNew = i < instances.size() && !instances[i].dynamic;
        if (hasOld && hasNew && sameInstance(state_->instances_[i], instances[i]) &&
            sameBox(state_->boundsWs_[i], bounds[i])) {
          continue;
        }
        if (hasOld) (void)state_->renderer_->invalidate(state_->boundsWs_[i]);
        if (hasNew) (void)state_->renderer_->invalidate(bounds[i]);
      }
    }
  }
  state_->meshes_.assign(meshes.begin(), meshes.end());
  state_->instances_.assign(instances.begin(), instances.end());
  state_->boundsWs_ = std::move(bounds);
  // Every handle given before names nothing now.
  state_->generations_.assign(state_->instances_.size(), ++state_->nextGeneration_);
  state_->freeSlots_.clear();
  for (std::uint32_t i = 0; i < state_->casterSet_.size(); ++i) {
    if (state_->casterSet_.removed(i)) state_->freeSlots_.push_back(i);
  }
  applyThinMargins();
  // A frame compute() made stays recordable: recordPass() culls the new casters into it.
  state_->castersChanged_ = true;
}

bool ShadowView::valid(CasterHandle handle) const noexcept {
  return handle.index < state_->generations_.size() &&
         state_->generations_[handle.index] == handle.generation &&
         !state_->casterSet_.removed(handle.index);
}

CasterHandle ShadowView::casterHandle(std::uint32_t index) const noexcept {
  if (index >= state_->generations_.size() || state_->casterSet_.removed(index)) return {};
  return {index, state_->generations_[index]};
}

Status ShadowView::checkHandle(const char* call, CasterHandle handle) const {
  if (valid(handle)) return {};
  return Status(ErrorCode::kInvalidArgument,
                std::string(call) + ": handle " + handleText(handle) +
                    " names no caster of this view (removed, replaced by setCasters, or never "
                    "given)");
}

void ShadowView::invalidateChange(const CasterInstance* before, const AabbWs* beforeBounds,
                                  const CasterInstance* after, const AabbWs* afterBounds) {
  if (!state_->options_.cache) return;
  const bool hasOld = before != nullptr && !before->dynamic;
  const bool hasNew = after != nullptr && !after->dynamic;
  if (hasOld && hasNew && sameInstance(*before, *after) && sameBox(*beforeBounds, *afterBounds)) {
    return;
  }
  if (hasOld) (void)state_->renderer_->invalidate(*beforeBounds);
  if (hasNew) (void)state_->renderer_->invalidate(*afterBounds);
}

Status ShadowView::addCaster(const CasterInstance& instance, const AabbWs& boundsWs,
                             CasterHandle* handle) {
  if (handle == nullptr) {
    return Status(ErrorCode::kInvalidArgument, "addCaster: handle is null: give where to put it");
  }
  if (Status s = validateCasters(state_->meshes_, std::span<const CasterInstance>(&instance, 1));
      !s.ok()) {
    return Status(s.code(), "addCaster: " + s.message());
  }
  std::uint32_t slot;
  if (!state_->freeSlots_.empty()) {
    slot = state_->freeSlots_.back();
    auto set = state_->casterSet_.setBox(slot, boundsWs.minWs, boundsWs.maxWs);
    if (!set) return Status(ErrorCode::kInvalidArgument, "addCaster: " + set.error().message());
    state_->freeSlots_.pop_back();
    state_->instances_[slot] = instance;
    state_->boundsWs_[slot] = state_->casterSet_.bounds(slot);
  } else {
    auto added = state_->casterSet_.addBox(boundsWs.minWs, boundsWs.maxWs);
    if (!added) return Status(ErrorCode::kInvalidArgument, "addCaster: " + added.error().message());
    slot = added.value();
    state_->instances_.push_back(instance);
    state_->boundsWs_.push_back(state_->casterSet_.bounds(slot));
    state_->generations_.push_back(0);
  }
  state_->generations_[slot] = ++state_->nextGeneration_;
  (void)state_->casterSet_.setMarginTexels(
      slot, instance.thin ? state_->renderer_->thinMarginTexels() : 0.0f);
  invalidateChange(nullptr, nullptr, &state_->instances_[slot], &state_->boundsWs_[slot]);
  state_->castersChanged_ = true;
  *handle = {slot, state_->generations_[slot]};
  return {};
}

Status ShadowView::updateCaster(CasterHandle handle, const CasterInstance& instance,
                                const AabbWs& boundsWs) {
  if (Status s = checkHandle("updateCaster", handle); !s.ok()) return s;
  if (Status s = validateCasters(state_->meshes_, std::span<const CasterInstance>(&instance, 1));
      !s.ok()) {
    return Status(s.code(), "updateCaster: " + s.message());
  }
  const std::uint32_t i = handle.index;
  const CasterInstance before = state_->instances_[i];
  const AabbWs beforeBounds = state_->boundsWs_[i];
  auto set = state_->casterSet_.setBox(i, boundsWs.minWs, boundsWs.maxWs);
  if (!set) return Status(ErrorCode::kInvalidArgument, "updateCaster: " + set.error().message());
  state_->instances_[i] = instance;
  state_->boundsWs_[i] = state_->casterSet_.bounds(i);
  if (instance.thin != before.thin) {
    (void)state_->casterSet_.setMarginTexels(
        i, instance.thin ? state_->renderer_->thinMarginTexels() : 0.0f);
  }
  invalidateChange(&before, &beforeBounds, &state_->instances_[i], &state_->boundsWs_[i]);
  state_->castersChanged_ = true;
  return {};
}

Status ShadowView::removeCaster(CasterHandle handle) {
  if (Status s = checkHandle("removeCaster", handle); !s.ok()) return s;
  const std::uint32_t i = handle.index;
  invalidateChange(&state_->instances_[i], &state_->boundsWs_[i], nullptr, nullptr);
  (void)state_->casterSet_.remove(i);
  state_->generations_[i] = ++state_->nextGeneration_;
  state_->freeSlots_.push_back(i);
  state_->castersChanged_ = true;
  return {};
}

// Thin casters reach beyond their bounds by the depth pass's widening: they are culled with it,
// so that no cascade whose box their rim reaches goes without them.
void ShadowView::applyThinMargins() {
  const float margin = state_->renderer_->thinMarginTexels();
  for (std::size_t i = 0; i < state_->instances_.size() && i < state_->casterSet_.size(); ++i) {
    const float m = state_->instances_[i].thin ? margin : 0.0f;
    if (m != state_->casterSet_.marginTexels(static_cast<std::uint32_t>(i))) {
      (void)state_->casterSet_.setMarginTexels(static_cast<std::uint32_t>(i), m);
    }
  }
}

Status ShadowView::setSceneBounds(const AabbWs* boundsWs) {
  if (boundsWs == nullptr) {
    state_->hasSceneBounds_ = false;
    return {};
  }
  if (auto e = csm::validate(*boundsWs, "sceneBounds")) {
    return Status(ErrorCode::kInvalidArgument, e->message());
  }
  state_->sceneBounds_ = *boundsWs;
  state_->hasSceneBounds_ = true;
  return {};
}

Result<CascadeFrame> ShadowView::computeFrame(const Camera& camera, const DirectionalLight& light,
                                              CascadeHistory* history) const {
  CascadeHistory own = state_->history_;
  return computeCascades(state_->settings_, camera, light,
                         state_->hasSceneBounds_ ? &state_->sceneBounds_ : nullptr,
                         history != nullptr ? history : &own,
                         state_->receiverRange_ ? &*state_->receiverRange_ : nullptr);
}

Status ShadowView::record(VkCommandBuffer cmd, const CascadeFrame& frame) {
  if (!state_->hasSettings_) {
    return Status(ErrorCode::kWrongOrder, "ShadowView::record before a successful setSettings()");
  }
  state_->computed_ = false;
  state_->frameCamera_.reset();  // the frame's camera is not known here
  CascadeFrame windowed = frame;
  state_->renderer_->applyCacheWindows(
      windowed);  // cached cascades: the depth windows (else no-op)
  cullInto(windowed);
  Status s = state_->renderer_->impl_->recordValidatedPass(
      cmd, windowed, CasterList{state_->meshes_, state_->instances_, state_->boundsWs_},
      &state_->cull_);
  if (!s.ok()) return s;
  state_->frame_ = windowed;
  return {};
}

Status ShadowView::compute(const Camera& camera, const DirectionalLight& light) {
  if (!state_->hasSettings_) {
    return Status(ErrorCode::kWrongOrder, "ShadowView::compute before a successful setSettings()");
  }
  // Computed into a copy of the history: a refused input leaves the view as it was.
  CascadeHistory history = state_->history_;
  auto frame = computeFrame(camera, light, &history);
  if (!frame.ok()) return Status(ErrorCode::kInvalidArgument, frame.error().message());
  state_->history_ = history;
  state_->lastCamera_ = camera;
  state_->frameCamera_ = camera;
  state_->frame_ = frame.value();
  state_->renderer_->applyCacheWindows(
      state_->frame_);  // cached cascades: the depth windows (else no-op)
  cullInto(state_->frame_);
  state_->computed_ = true;
  return {};
}

// One cull of the frame's casters, each cascade in the light basis the cache's plan draws it in
// (a cascade deferred across a change of light: the basis its layer shows).
void ShadowView::cullInto(const CascadeFrame& frame) {
  const CachePlan& plan = state_->renderer_->impl_->cachePlan();
  std::array<glm::dmat3, kMaxCascades> bases;
  for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
    const bool planned = i < plan.cascadeCount && plan.cascades[i].active;
    bases[i] = planned ? plan.cascades[i].basis : frame.lightBasisWs;
  }
  cullCasters(state_->casterSet_, frame, state_->settings_.minCasterTexels, state_->cull_,
              std::span(bases.data(), frame.cascadeCount));
  state_->castersChanged_ = false;
}

Status ShadowView::recordPass(VkCommandBuffer cmd) {
  if (!state_->computed_) {
    return Status(ErrorCode::kWrongOrder, "ShadowView::recordPass without a compute() before it");
  }
  if (state_->castersChanged_) cullInto(state_->frame_);  // setCasters() since compute()
  return state_->renderer_->impl_->recordValidatedPass(
      cmd, state_->frame_, CasterList{state_->meshes_, state_->instances_, state_->boundsWs_},
      &state_->cull_);
}

Status ShadowView::record(VkCommandBuffer cmd, const Camera& camera,
                          const DirectionalLight& light) {
  const CascadeHistory before = state_->history_;
  Status s = compute(camera, light);
  if (s.ok()) s = recordPass(cmd);
  if (!s.ok()) state_->history_ = before;  // nothing recorded: the view stays as it was
  return s;
}

void ShadowView::dropReceiverDepth() noexcept {
  if (state_->reducer_) state_->reducer_->invalidate();
  state_->receiverRange_.reset();
  state_->olderReads_ = 0;
}

void ShadowView::cameraCut() noexcept {
  state_->history_ = {};
  dropReceiverDepth();
  setReceiverTiles(std::nullopt);
}

void ShadowView::setReceiverTiles(std::optional<ReceiverTileMarks> marks) noexcept {
  if (state_->renderer_) state_->renderer_->setReceiverTiles(std::move(marks));
}

Status ShadowView::recordReceiverDepth(VkCommandBuffer cmd, const ReceiverDepthInput& depth) {
  const bool fit = state_->options_.receiverFit != ReceiverFit::kOff;
  const bool tiles = state_->options_.tiles;
  if ((!fit && !tiles) || !state_->reducer_) {
    return Status(ErrorCode::kWrongOrder,
                  "ShadowView::recordReceiverDepth with options.receiverFit = kOff and "
                  "options.tiles = false: turn the receiver fit or the tiles on (setSettings) "
                  "first");
  }
  const bool boxes = state_->options_.receiverFit == ReceiverFit::kSplitsAndBoxes;
  const bool rays = boxes || tiles;  // per-pixel positions: the boxes' bounds, the tile marks
  if (!state_->lastCamera_ || (rays && !state_->frameCamera_)) {
    return Status(ErrorCode::kWrongOrder,
                  rays ? "ShadowView::recordReceiverDepth with options.receiverFit = "
                         "kSplitsAndBoxes or options.tiles needs the frame's camera: "
                         "record(cmd, camera, light) or compute() before it"
                       : "ShadowView::recordReceiverDepth before any record(cmd, camera, light) "
                         "or compute()");
  }
  const glm::mat4& p = depth.projection;
  // The view depth of a depth value (DepthProjection), the histogram over the shadows' depth
  // range (for ReceiverSplitScheme::kHistogram) and, for the boxes, the pixel rays.
  DepthProjection dp{
      p[2][2], p[3][2], depth.clearDepth, float(state_->lastCamera_->nearM),
      float(std::max(state_->settings_.shadowDistanceM, 2.0 * state_->lastCamera_->nearM))};
  ReceiverBoundsInputs bounds;
  if (rays) {
    dp.p00 = p[0][0];
    dp.p11 = p[1][1];
    dp.p20 = p[2][0];
    dp.p21 = p[2][1];
    bounds = {&state_->frame_, &*state_->frameCamera_, tiles ? &state_->settings_ : nullptr};
  }
  // The slot this frame fills was last filled framesInFlight frames ago; the host has waited for
  // that frame before recording this one, so its result is complete: the next compute() uses it.
  const std::uint32_t slot = state_->reducerSlot_;
  std::optional<ReceiverDepthRange> previous = state_->reducer_->read(slot);
  Status s =
      state_->reducer_->record(cmd, depth.depthView, depth.layout, depth.extent, dp, slot, bounds);
  if (!s.ok()) return s;
  if (state_->olderReads_ > 0) {
    --state_->olderReads_;  // older than what useLatestReceiverDepth() took
  } else {
    applyReceiverResult(std::move(previous));
  }
  state_->reducerSlot_ = (slot + 1) % state_->reducer_->slotCount();
  return {};
}

// A reduction's result: the tiles its pixels sampled go to the renderer (kept when there are
// none: sky only, or a slot emptied by a cut, whose drop cameraCut() made); the range (none: the
// full range) to the fit, without the bounds where only the tiles asked for them.
void ShadowView::applyReceiverResult(std::optional<ReceiverDepthRange> result) {
  const bool fit = state_->options_.receiverFit != ReceiverFit::kOff;
  const bool boxes = state_->options_.receiverFit == ReceiverFit::kSplitsAndBoxes;
  if (state_->options_.tiles && result && result->tiles.present()) {
    state_->renderer_->setReceiverTiles(result->tiles);
  }
  if (result) {
    result->tiles = {};
    if (!boxes) result->lightBounds = {};
  }
  if (fit) state_->receiverRange_ = std::move(result);  // else a range the host set stays
}

Status ShadowView::useLatestReceiverDepth() {
  const bool fit = state_->options_.receiverFit != ReceiverFit::kOff;
  if ((!fit && !state_->options_.tiles) || !state_->reducer_) {
    return Status(ErrorCode::kWrongOrder,
                  "ShadowView::useLatestReceiverDepth with options.receiverFit = kOff and "
                  "options.tiles = false: turn the receiver fit or the tiles on (setSettings) "
                  "first");
  }
  const std::uint32_t n = state_->reducer_->slotCount();
  std::optional<ReceiverDepthRange> latest =
      state_->reducer_->read((state_->reducerSlot_ + n - 1) % n);
  if (!latest) return {};
  applyReceiverResult(std::move(latest));
  // The next n - 1 recordReceiverDepth() read the slots filled before it.
  state_->olderReads_ = n - 1;
  return {};
}

}  // namespace csm::vk
