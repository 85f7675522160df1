// The receiver depth range on the GPU: a compute reduction over the host's depth buffer that
// finds the nearest and farthest view depth of the visible receivers, for receiver-driven splits
// (csm::computeCascades' ReceiverDepthRange, as in sample-distribution shadow maps).
//
// Per frame, with N slots (one per frame in flight, or more for a longer delay):
//   range = reducer.read(slot)                  // the slot's last result, once its fence passed
//   frame = csm::computeCascades(..., range ? &*range : nullptr)
//   ... host renders its depth buffer, makes it readable by compute ...
//   reducer.record(cmd, depthView, layout, extent, projection, slot)
//   slot = (slot + 1) % N
// So the splits use the range of a frame one to N frames old. With a histogram range in the
// projection (DepthProjection::histogramNearM), the result also carries the receivers'
// view-depth histogram (ReceiverDepthRange::histogram) for histogram-driven splits. After a camera
// cut call invalidate(): every result recorded before it is dropped (read returns nothing) and the
// splits fall back to the full range until a new one arrives. Given the frame the depth buffer
// was drawn with (ReceiverBoundsInputs), the result also carries the receivers' light-space
// bounds per cascade (ReceiverDepthRange::lightBounds) for receiver-driven boxes. Not
// thread-safe.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <memory>
#include <optional>

#include "csm/types.hpp"
#include "csm/vulkan/shadow_renderer.hpp"
#include "csm/vulkan/status.hpp"

namespace csm::vk {

/// How to turn the host's depth-buffer values into view depth: d = p32 / (z + p22), with
/// p22 = P[2][2] and p32 = P[3][2] of its projection matrix P (column-major, GLM/GLSL
/// indexing). Holds for any perspective projection, standard or reversed depth, finite or
/// infinite far. Pixels whose value equals clearDepth (nothing drawn) are skipped.
struct DepthProjection {
  float p22 = -1.0f;
  float p32 = -0.1f;
  float clearDepth = 1.0f;
  /// The receivers' view-depth histogram (csm::ReceiverDepthHistogram, for
  /// ReceiverSplitScheme::kHistogram): kDepthHistogramBins log-spaced bins over
  /// [histogramNearM, histogramFarM), e.g. the camera's near plane and the shadow distance; depths
  /// outside count in the end bins. histogramNearM = 0 (the default): no histogram.
  /// 0 < histogramNearM < histogramFarM, finite, when set.
  float histogramNearM = 0.0f;
  float histogramFarM = 0.0f;
  /// For the receivers' light-space bounds (ReceiverBoundsInputs): P[0][0], P[1][1], P[2][0] and
  /// P[2][1] of the projection, with Vulkan's image convention (pixel row 0 at ndc y = -1, so a
  /// projection that shows +y up has P[1][1] < 0): a pixel at ndc (x, y) and view depth d is at
  /// view-space ((x + P[2][0]) d / P[0][0], (y + P[2][1]) d / P[1][1], -d).
  float p00 = 1.0f;
  float p11 = -1.0f;
  float p20 = 0.0f;
  float p21 = 0.0f;
};

/// What the reduction needs to bound the receivers in light space per cascade: the cascades the
/// depth buffer's frame was drawn with (cascadeCount, splitsM, lightBasisWs, cameraPositionWs)
/// and its camera (orientation, field of view and aspect).
/// With `tiles` (the settings the frame is lit with: its filter, bias and blend band) the
/// reduction also marks the tiles the receivers sample per cascade (ReceiverDepthRange::tiles,
/// csm/receiver_tiles.hpp).
struct ReceiverBoundsInputs {
  const CascadeFrame* frame = nullptr;
  const Camera* camera = nullptr;
  const ShadowSettings* tiles = nullptr;
};

class DepthRangeReducer {
 public:
  /// As many as DeviceInfo::framesInFlight allows (a ShadowView makes one slot per frame).
  static constexpr std::uint32_t kMaxSlots = 16;

  /// Creates the compute pipeline, the sampler, `slots` descriptor sets and the host-visible
  /// result buffer. slots in [1, kMaxSlots]. Returns nullptr and fills `status` on error.
  [[nodiscard]] static std::unique_ptr<DepthRangeReducer> create(const DeviceInfo& device,
                                                                 std::uint32_t slots,
                                                                 Status* status = nullptr);
  ~DepthRangeReducer();
  DepthRangeReducer(const DepthRangeReducer&) = delete;
  DepthRangeReducer& operator=(const DepthRangeReducer&) = delete;

  /// Records the reduction of `depthView` (a depth view of `extent`, with SAMPLED usage, in
  /// `layout`: DEPTH_READ_ONLY_OPTIMAL, DEPTH_STENCIL_READ_ONLY_OPTIMAL, READ_ONLY_OPTIMAL or
  /// SHADER_READ_ONLY_OPTIMAL, its writes made visible to the compute stage by the host) into
  /// `slot`. The slot's previous submission must have completed (its result read or dropped).
  /// With `bounds` (its frame non-null) the slot also collects the receivers' light-space bounds
  /// per cascade of that frame.
  Status record(VkCommandBuffer cmd, VkImageView depthView, VkImageLayout layout, VkExtent2D extent,
                const DepthProjection& projection, std::uint32_t slot,
                const ReceiverBoundsInputs& bounds = {});

  /// The range last recorded into `slot`, valid once that submission has completed; nothing if
  /// the slot was never recorded, was recorded before the last invalidate(), or saw no
  /// receiver pixel. Its histogram is present when the slot was recorded with a histogram range,
  /// its lightBounds when it was recorded with ReceiverBoundsInputs (float light-space positions
  /// relative to the camera, plus the camera's in double).
  [[nodiscard]] std::optional<ReceiverDepthRange> read(std::uint32_t slot) const;

  /// A camera cut: drops every result recorded so far.
  void invalidate() noexcept { ++generation_; }

  [[nodiscard]] std::uint32_t slotCount() const noexcept { return slots_; }

 private:
  DepthRangeReducer() = default;
  Status init(const DeviceInfo& device, std::uint32_t slots);
  // init()'s steps, in order.
  Status createSetLayout();
  Status createPipelineLayout();
  Status createPipeline(VkPipelineCache cache);
  Status createSampler();
  Status createResultBuffer(VkPhysicalDevice physicalDevice);
  Status createSets();
  void setName(std::uint64_t handle, VkObjectType type, const char* name) const;

  VkDevice device_ = VK_NULL_HANDLE;
  std::uint32_t slots_ = 0;
  std::uint64_t generation_ = 1;
  std::uint64_t slotGeneration_[kMaxSlots]{};
  float slotHistogramNearM_[kMaxSlots]{};  // the histogram range each slot was recorded with
  float slotHistogramFarM_[kMaxSlots]{};
  ReceiverLightBounds slotBounds_[kMaxSlots]{};  // the frame each slot's bounds were taken with
  ReceiverTileMarks slotTiles_[kMaxSlots]{};     // the grids each slot's tiles were marked on
  VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout pipelineLayout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
  VkShaderModule module_ = VK_NULL_HANDLE;
  VkSampler sampler_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSet sets_[kMaxSlots]{};
  VkBuffer buffer_ = VK_NULL_HANDLE;
  VkDeviceMemory memory_ = VK_NULL_HANDLE;
  void* mapped_ = nullptr;
  PFN_vkSetDebugUtilsObjectNameEXT setObjectName_ = nullptr;
};

}  // namespace csm::vk
