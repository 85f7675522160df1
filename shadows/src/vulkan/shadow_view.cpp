// ShadowView: one view's settings, casters, history, frame and cull lists around a renderer.
#include "csm/vulkan/shadow_view.hpp"

#include <algorithm>
#include <span>
#include <string>

#include "shadow_renderer_impl.hpp"

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
         a.thin == b.thin && a.closed == b.closed;
}

bool sameBox(const AabbWs& a, const AabbWs& b) {
  return a.minWs == b.minWs && a.maxWs == b.maxWs;
}

std::string handleText(CasterHandle h) {
  return "{index " + std::to_string(h.index) + ", generation " + std::to_string(h.generation) + "}";
}

}  // namespace

std::unique_ptr<ShadowView> ShadowView::create(const DeviceInfo& device, const VertexLayout& layout,
                                               Status* status) {
  std::unique_ptr<ShadowView> view(new ShadowView());
  view->renderer_ = ShadowRenderer::create(device, layout, status);
  if (!view->renderer_) return nullptr;
  view->device_ = device;
  view->specInfo_ = view->spec_.info();
  return view;
}

Status ShadowView::setSettings(const ShadowSettings& settings, const RendererOptions& options) {
  // Refused here rather than by every later frame: shadows must reach past the near plane of
  // the camera the view last computed for.
  if (lastCamera_) {
    if (auto e = csm::validate(settings, *lastCamera_, DirectionalLight{})) {
      return Status(ErrorCode::kInvalidArgument, e->message());
    }
  }
  if (options.receiverFit != ReceiverFit::kOff && options.receiverFit != ReceiverFit::kSplits &&
      options.receiverFit != ReceiverFit::kSplitsAndBoxes) {
    return Status(ErrorCode::kInvalidArgument,
                  "options.receiverFit = " + std::to_string(int(options.receiverFit)) +
                      " is invalid: allowed kOff, kSplits or kSplitsAndBoxes");
  }
  // The receiver fit's reduction, made before anything changes (a failure leaves the view whole).
  std::unique_ptr<DepthRangeReducer> reducer;
  if (options.receiverFit != ReceiverFit::kOff && !reducer_) {
    Status made;
    reducer = DepthRangeReducer::create(device_, device_.framesInFlight, &made);
    if (!reducer) return made;
  }
  Status s = renderer_->update(settings, options);
  if (!s.ok()) return s;
  if (reducer) reducer_ = std::move(reducer);
  if (!hasSettings_ || settings.cascadeCount != settings_.cascadeCount) {
    history_ = {};
    dropReceiverDepth();
  }
  if (options.receiverFit != options_.receiverFit) dropReceiverDepth();
  settings_ = settings;
  options_ = options;
  hasSettings_ = true;
  spec_ = LightingSpecialization(settings_);
  specInfo_ = spec_.info();
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
  casterSet_ = std::move(set);
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
  casterSet_ = casterSet;
  if (!casterSet_.built() || casterSet_.unindexedCount() > 0) casterSet_.build();
  adoptCasters(meshes, instances);
  return {};
}

void ShadowView::adoptCasters(std::span<const MeshDraw> meshes,
                              std::span<const CasterInstance> instances) {
  std::vector<AabbWs> bounds(casterSet_.size());
  for (std::size_t i = 0; i < bounds.size(); ++i) {
    bounds[i] = casterSet_.bounds(static_cast<std::uint32_t>(i));
  }
  // Cached cascades: a static caster whose index, mesh, transform, bounds or thin or closed flag
  // changed (or that was added or removed) invalidates its old and new bounds; dynamic ones are
  // drawn every frame.
  if (options_.cache) {
    const bool meshesSame =
        meshes.size() == meshes_.size() &&
        std::equal(meshes.begin(), meshes.end(), meshes_.begin(), [](const auto& a, const auto& b) {
          return a.vertexBuffer == b.vertexBuffer && a.indexBuffer == b.indexBuffer &&
                 a.vertexBufferOffset == b.vertexBufferOffset &&
                 a.indexBufferOffset == b.indexBufferOffset && a.firstIndex == b.firstIndex &&
                 a.indexCount == b.indexCount && a.vertexOffset == b.vertexOffset;
        });
    if (!meshesSame) {
      renderer_->invalidateAll();
    } else {
      const std::size_t n = std::max(instances.size(), instances_.size());
      for (std::size_t i = 0; i < n; ++i) {
        const bool hasOld = i < instances_.size() && !instances_[i].dynamic;
        const bool hasNew = i < instances.size() && !instances[i].dynamic;
        if (hasOld && hasNew && sameInstance(instances_[i], instances[i]) &&
            sameBox(boundsWs_[i], bounds[i])) {
          continue;
        }
        if (hasOld) (void)renderer_->invalidate(boundsWs_[i]);
        if (hasNew) (void)renderer_->invalidate(bounds[i]);
      }
    }
  }
  meshes_.assign(meshes.begin(), meshes.end());
  instances_.assign(instances.begin(), instances.end());
  boundsWs_ = std::move(bounds);
  // Every handle given before names nothing now.
  generations_.assign(instances_.size(), ++nextGeneration_);
  freeSlots_.clear();
  for (std::uint32_t i = 0; i < casterSet_.size(); ++i) {
    if (casterSet_.removed(i)) freeSlots_.push_back(i);
  }
  applyThinMargins();
  // A frame compute() made stays recordable: recordPass() culls the new casters into it.
  castersChanged_ = true;
}

bool ShadowView::valid(CasterHandle handle) const noexcept {
  return handle.index < generations_.size() && generations_[handle.index] == handle.generation &&
         !casterSet_.removed(handle.index);
}

CasterHandle ShadowView::casterHandle(std::uint32_t index) const noexcept {
  if (index >= generations_.size() || casterSet_.removed(index)) return {};
  return {index, generations_[index]};
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
  if (!options_.cache) return;
  const bool hasOld = before != nullptr && !before->dynamic;
  const bool hasNew = after != nullptr && !after->dynamic;
  if (hasOld && hasNew && sameInstance(*before, *after) && sameBox(*beforeBounds, *afterBounds)) {
    return;
  }
  if (hasOld) (void)renderer_->invalidate(*beforeBounds);
  if (hasNew) (void)renderer_->invalidate(*afterBounds);
}

Status ShadowView::addCaster(const CasterInstance& instance, const AabbWs& boundsWs,
                             CasterHandle* handle) {
  if (handle == nullptr) {
    return Status(ErrorCode::kInvalidArgument, "addCaster: handle is null: give where to put it");
  }
  if (Status s = validateCasters(meshes_, std::span<const CasterInstance>(&instance, 1)); !s.ok()) {
    return Status(s.code(), "addCaster: " + s.message());
  }
  std::uint32_t slot;
  if (!freeSlots_.empty()) {
    slot = freeSlots_.back();
    auto set = casterSet_.setBox(slot, boundsWs.minWs, boundsWs.maxWs);
    if (!set) return Status(ErrorCode::kInvalidArgument, "addCaster: " + set.error().message());
    freeSlots_.pop_back();
    instances_[slot] = instance;
    boundsWs_[slot] = casterSet_.bounds(slot);
  } else {
    auto added = casterSet_.addBox(boundsWs.minWs, boundsWs.maxWs);
    if (!added) return Status(ErrorCode::kInvalidArgument, "addCaster: " + added.error().message());
    slot = added.value();
    instances_.push_back(instance);
    boundsWs_.push_back(casterSet_.bounds(slot));
    generations_.push_back(0);
  }
  generations_[slot] = ++nextGeneration_;
  (void)casterSet_.setMarginTexels(slot, instance.thin ? renderer_->thinMarginTexels() : 0.0f);
  invalidateChange(nullptr, nullptr, &instances_[slot], &boundsWs_[slot]);
  castersChanged_ = true;
  *handle = {slot, generations_[slot]};
  return {};
}

Status ShadowView::updateCaster(CasterHandle handle, const CasterInstance& instance,
                                const AabbWs& boundsWs) {
  if (Status s = checkHandle("updateCaster", handle); !s.ok()) return s;
  if (Status s = validateCasters(meshes_, std::span<const CasterInstance>(&instance, 1)); !s.ok()) {
    return Status(s.code(), "updateCaster: " + s.message());
  }
  const std::uint32_t i = handle.index;
  const CasterInstance before = instances_[i];
  const AabbWs beforeBounds = boundsWs_[i];
  auto set = casterSet_.setBox(i, boundsWs.minWs, boundsWs.maxWs);
  if (!set) return Status(ErrorCode::kInvalidArgument, "updateCaster: " + set.error().message());
  instances_[i] = instance;
  boundsWs_[i] = casterSet_.bounds(i);
  if (instance.thin != before.thin) {
    (void)casterSet_.setMarginTexels(i, instance.thin ? renderer_->thinMarginTexels() : 0.0f);
  }
  invalidateChange(&before, &beforeBounds, &instances_[i], &boundsWs_[i]);
  castersChanged_ = true;
  return {};
}

Status ShadowView::removeCaster(CasterHandle handle) {
  if (Status s = checkHandle("removeCaster", handle); !s.ok()) return s;
  const std::uint32_t i = handle.index;
  invalidateChange(&instances_[i], &boundsWs_[i], nullptr, nullptr);
  (void)casterSet_.remove(i);
  generations_[i] = ++nextGeneration_;
  freeSlots_.push_back(i);
  castersChanged_ = true;
  return {};
}

// Thin casters reach beyond their bounds by the depth pass's widening: they are culled with it,
// so that no cascade whose box their rim reaches goes without them.
void ShadowView::applyThinMargins() {
  const float margin = renderer_->thinMarginTexels();
  for (std::size_t i = 0; i < instances_.size() && i < casterSet_.size(); ++i) {
    const float m = instances_[i].thin ? margin : 0.0f;
    if (m != casterSet_.marginTexels(static_cast<std::uint32_t>(i))) {
      (void)casterSet_.setMarginTexels(static_cast<std::uint32_t>(i), m);
    }
  }
}

// A cascade the cache budget deferred across a change of light still shows the light basis it
// was rendered with: its (dynamic) casters are culled in that basis.
void ShadowView::cullDeferred(const CascadeFrame& frame) {
  for (std::uint32_t i = 0; i < frame.cascadeCount; ++i) {
    if (frame.cascades[i].empty || !renderer_->impl_->cacheDeferred(i) ||
        renderer_->impl_->cacheLightBasis(i) == frame.lightBasisWs) {
      continue;
    }
    CascadeFrame old = frame;
    old.lightBasisWs = renderer_->impl_->cacheLightBasis(i);
    old.lightDirectionWs = old.lightBasisWs[2];
    for (std::uint32_t j = 0; j < old.cascadeCount; ++j) old.cascades[j].empty = j != i;
    CullResult one;
    cullCasters(casterSet_, old, settings_.minCasterTexels, one);
    cull_.visible[i] = std::move(one.visible[i]);
  }
}

Status ShadowView::setSceneBounds(const AabbWs* boundsWs) {
  if (boundsWs == nullptr) {
    hasSceneBounds_ = false;
    return {};
  }
  if (auto e = csm::validate(*boundsWs, "sceneBounds")) {
    return Status(ErrorCode::kInvalidArgument, e->message());
  }
  sceneBounds_ = *boundsWs;
  hasSceneBounds_ = true;
  return {};
}

Result<CascadeFrame> ShadowView::computeFrame(const Camera& camera, const DirectionalLight& light,
                                              CascadeHistory* history) const {
  CascadeHistory own = history_;
  return computeCascades(settings_, camera, light, hasSceneBounds_ ? &sceneBounds_ : nullptr,
                         history != nullptr ? history : &own,
                         receiverRange_ ? &*receiverRange_ : nullptr);
}

Status ShadowView::record(VkCommandBuffer cmd, const CascadeFrame& frame) {
  if (!hasSettings_) {
    return Status(ErrorCode::kWrongOrder, "ShadowView::record before a successful setSettings()");
  }
  computed_ = false;
  frameCamera_.reset();  // the frame's camera is not known here
  CascadeFrame windowed = frame;
  renderer_->applyCacheWindows(windowed);  // cached cascades: the depth windows (else no-op)
  cullInto(windowed);
  Status s = renderer_->impl_->recordValidatedPass(
      cmd, windowed, CasterList{meshes_, instances_, boundsWs_}, &cull_);
  if (!s.ok()) return s;
  frame_ = windowed;
  return {};
}

Status ShadowView::compute(const Camera& camera, const DirectionalLight& light) {
  if (!hasSettings_) {
    return Status(ErrorCode::kWrongOrder, "ShadowView::compute before a successful setSettings()");
  }
  // Computed into a copy of the history: a refused input leaves the view as it was.
  CascadeHistory history = history_;
  auto frame = computeFrame(camera, light, &history);
  if (!frame.ok()) return Status(ErrorCode::kInvalidArgument, frame.error().message());
  history_ = history;
  lastCamera_ = camera;
  frameCamera_ = camera;
  frame_ = frame.value();
  renderer_->applyCacheWindows(frame_);  // cached cascades: the depth windows (else no-op)
  cullInto(frame_);
  computed_ = true;
  return {};
}

void ShadowView::cullInto(const CascadeFrame& frame) {
  cullCasters(casterSet_, frame, settings_.minCasterTexels, cull_);
  cullDeferred(frame);
  castersChanged_ = false;
}

Status ShadowView::recordPass(VkCommandBuffer cmd) {
  if (!computed_) {
    return Status(ErrorCode::kWrongOrder, "ShadowView::recordPass without a compute() before it");
  }
  if (castersChanged_) cullInto(frame_);  // setCasters() since compute()
  return renderer_->impl_->recordValidatedPass(cmd, frame_,
                                               CasterList{meshes_, instances_, boundsWs_}, &cull_);
}

Status ShadowView::record(VkCommandBuffer cmd, const Camera& camera,
                          const DirectionalLight& light) {
  const CascadeHistory before = history_;
  Status s = compute(camera, light);
  if (s.ok()) s = recordPass(cmd);
  if (!s.ok()) history_ = before;  // nothing recorded: the view stays as it was
  return s;
}

void ShadowView::dropReceiverDepth() noexcept {
  if (reducer_) reducer_->invalidate();
  receiverRange_.reset();
}

void ShadowView::cameraCut() noexcept {
  history_ = {};
  dropReceiverDepth();
}

Status ShadowView::recordReceiverDepth(VkCommandBuffer cmd, const ReceiverDepthInput& depth) {
  if (options_.receiverFit == ReceiverFit::kOff || !reducer_) {
    return Status(ErrorCode::kWrongOrder,
                  "ShadowView::recordReceiverDepth with options.receiverFit = kOff: turn the "
                  "receiver fit on (setSettings) first");
  }
  const bool boxes = options_.receiverFit == ReceiverFit::kSplitsAndBoxes;
  if (!lastCamera_ || (boxes && !frameCamera_)) {
    return Status(ErrorCode::kWrongOrder,
                  boxes ? "ShadowView::recordReceiverDepth with options.receiverFit = "
                          "kSplitsAndBoxes needs the frame's camera: record(cmd, camera, light) "
                          "or compute() before it"
                        : "ShadowView::recordReceiverDepth before any record(cmd, camera, light) "
                          "or compute()");
  }
  const glm::mat4& p = depth.projection;
  // The view depth of a depth value (DepthProjection), the histogram over the shadows' depth
  // range (for ReceiverSplitScheme::kHistogram) and, for the boxes, the pixel rays.
  DepthProjection dp{p[2][2], p[3][2], depth.clearDepth, float(lastCamera_->nearM),
                     float(std::max(settings_.shadowDistanceM, 2.0 * lastCamera_->nearM))};
  ReceiverBoundsInputs bounds;
  if (boxes) {
    dp.p00 = p[0][0];
    dp.p11 = p[1][1];
    dp.p20 = p[2][0];
    dp.p21 = p[2][1];
    bounds = {&frame_, &*frameCamera_};
  }
  // The slot this frame fills was last filled framesInFlight frames ago; the host has waited for
  // that frame before recording this one, so its result is complete: the next compute() uses it.
  const std::uint32_t slot = reducerSlot_;
  std::optional<ReceiverDepthRange> previous = reducer_->read(slot);
  Status s = reducer_->record(cmd, depth.depthView, depth.layout, depth.extent, dp, slot, bounds);
  if (!s.ok()) return s;
  receiverRange_ = previous;
  reducerSlot_ = (slot + 1) % reducer_->slotCount();
  return {};
}

}  // namespace csm::vk
