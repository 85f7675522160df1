// ShadowView's state (not installed): what the public header used to declare privately.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "csm/culling.hpp"
#include "csm/vulkan/depth_range.hpp"
#include "csm/vulkan/shadow_view.hpp"

namespace csm::vk {

struct ShadowView::State {
  DeviceInfo device_{};
  std::unique_ptr<ShadowRenderer> renderer_;
  std::unique_ptr<DepthRangeReducer> reducer_;  // the receiver fit's, made when it is turned on
  std::uint32_t reducerSlot_ = 0;               // the slot the next recordReceiverDepth fills
  // Reads older than the result useLatestReceiverDepth() took, still to come (not applied).
  std::uint32_t olderReads_ = 0;
  ShadowSettings settings_{};
  RendererOptions options_{};
  LightingSpecialization spec_{ShadowSettings{}};  // of settings_, for the lighting pipeline
  VkSpecializationInfo specInfo_{};                // spec_.info(): points into spec_
  bool hasSettings_ = false;
  CasterSet casterSet_;
  std::vector<MeshDraw> meshes_;
  std::vector<CasterInstance> instances_;
  std::vector<AabbWs> boundsWs_;            // casterSet_.bounds(i), for the cached pass's regions
  std::vector<std::uint32_t> generations_;  // per slot: a handle's generation must match
  std::vector<std::uint32_t> freeSlots_;    // removed slots, reused by addCaster
  std::uint32_t nextGeneration_ = 0;
  AabbWs sceneBounds_{};
  bool hasSceneBounds_ = false;
  std::optional<ReceiverDepthRange> receiverRange_;
  CascadeHistory history_{};
  CascadeFrame frame_{};
  bool computed_ = false;              // frame_ and cull_ hold compute()'s result for recordPass()
  bool castersChanged_ = false;        // setCasters() since cull_ was made
  std::optional<Camera> lastCamera_;   // of the last compute(), for setSettings()' cross-checks
  std::optional<Camera> frameCamera_;  // the camera frame_ was computed for (not record(frame))
  CullResult cull_;
};

}  // namespace csm::vk
