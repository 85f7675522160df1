#include "csm/vulkan/depth_range.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>

#include <glm/gtc/quaternion.hpp>

#include <csm_shaders/csm_depth_range.comp.spv.h>

#include "csm/receiver_bounds.hpp"
#include "csm/receiver_tiles.hpp"
#include "vk_util.hpp"

namespace csm::vk {
namespace {

// Pixels a side per workgroup of csm_depth_range.comp (8x8 invocations of 2x2 pixels).
constexpr std::uint32_t kGroup = 16;
constexpr std::uint32_t kFltMaxBits = 0x7f7fffffu;
// One result slot: uvec4 (min bits, max bits, count, unused), the histogram's bins, then per
// cascade (min x, min y, ~max x, ~max y) as order-preserving uints, then per cascade the tile
// marks (kTileWords words), the tile grids and the blend bands (a vec4 each, written by record).
constexpr VkDeviceSize kBinsBytes = 4 * VkDeviceSize(kDepthHistogramBins);
constexpr VkDeviceSize kBoundsBytes = 16 * VkDeviceSize(kMaxCascades);
constexpr VkDeviceSize kTilesOffset = 16 + kBinsBytes + kBoundsBytes;
constexpr VkDeviceSize kTilesBytes = 4 * VkDeviceSize(kTileWords) * kMaxCascades;
constexpr VkDeviceSize kGridOffset = kTilesOffset + kTilesBytes;
constexpr VkDeviceSize kGridBytes = 2 * 16 * VkDeviceSize(kMaxCascades);  // grid, then band
constexpr VkDeviceSize kSlotBytes = kGridOffset + kGridBytes;
static_assert(kTilesOffset % 16 == 0 && kGridOffset % 16 == 0 && kSlotBytes % 16 == 0);

struct PushConstants {
  std::uint32_t extent[2];
  float p22;
  float p32;
  float clearDepth;
  std::uint32_t slot;
  float histNear;  // 0: no histogram
  float binsPerLog;
  float lsX[4];  // light x row of (basis^T R_camera), 1 / P[0][0]
  float lsY[4];  // light y row, 1 / P[1][1]
  float pOff[2];
  std::uint32_t boundsCount;  // 0: no bounds
  std::uint32_t tileMarks;    // 1: mark tiles
  float splits[kMaxCascades + 1];
};
static_assert(sizeof(PushConstants) == 80 + 4 * (kMaxCascades + 1));
static_assert(sizeof(PushConstants) <= 128);

// The inverse of the shader's orderedBits().
float fromOrderedBits(std::uint32_t u) {
  u = (u & 0x80000000u) != 0u ? (u & 0x7fffffffu) : ~u;
  float f = 0.0f;
  std::memcpy(&f, &u, 4);
  return f;
}

bool readableLayout(VkImageLayout l) {
  return l == VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL ||
         l == VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL ||
         l == VK_IMAGE_LAYOUT_READ_ONLY_OPTIMAL || l == VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
}

}  // namespace

std::unique_ptr<DepthRangeReducer> DepthRangeReducer::create(const DeviceInfo& device,
                                                             std::uint32_t slots, Status* status) {
  std::unique_ptr<DepthRangeReducer> r(new DepthRangeReducer());
  const Status s = r->init(device, slots);
  if (status) *status = s;
  if (!s.ok()) return nullptr;
  return r;
}

void DepthRangeReducer::setName(std::uint64_t handle, VkObjectType type, const char* name) const {
  setObjectName(setObjectName_, device_, handle, type, name);
}

Status DepthRangeReducer::init(const DeviceInfo& device, std::uint32_t slots) {
  if (device.physicalDevice == VK_NULL_HANDLE || device.device == VK_NULL_HANDLE) {
    return Status(ErrorCode::kInvalidArgument,
                  "DeviceInfo: physicalDevice and device are required");
  }
  if (!(slots >= 1 && slots <= kMaxSlots)) {
    return Status(ErrorCode::kInvalidArgument,
                  "DepthRangeReducer: slots = " + std::to_string(slots) +
                      " is invalid: allowed an integer in [1, " + std::to_string(kMaxSlots) + "]");
  }
  device_ = device.device;
  slots_ = slots;
  if (device.debugUtilsEnabled) {
    setObjectName_ = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
        vkGetDeviceProcAddr(device_, "vkSetDebugUtilsObjectNameEXT"));
  }

  Status s = createSetLayout();
  if (s.ok()) s = createPipelineLayout();
  if (s.ok()) s = createPipeline(device.pipelineCache);
  if (s.ok()) s = createSampler();
  if (s.ok()) s = createResultBuffer(device.physicalDevice);
  if (s.ok()) s = createSets();
  return s;
}

// Set layout: the depth buffer (combined image sampler) and the result slots.
Status DepthRangeReducer::createSetLayout() {
  const VkDevice dev = device_;
  VkDescriptorSetLayoutBinding b[2]{};
  b[0].binding = 0;
  b[0].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  b[0].descriptorCount = 1;
  b[0].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  b[1].binding = 1;
  b[1].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  b[1].descriptorCount = 1;
  b[1].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  auto ci =
      vkInit<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
  ci.bindingCount = 2;
  ci.pBindings = b;
  CSM_VK_TRY(vkCreateDescriptorSetLayout(dev, &ci, nullptr, &setLayout_));
  setName(handleBits(setLayout_), VK_OBJECT_TYPE_DESCRIPTOR_SET_LAYOUT,
          "csm depth range set layout");
  return {};
}

// The pipeline layout: the set and the push constants.
Status DepthRangeReducer::createPipelineLayout() {
  const VkDevice dev = device_;
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(PushConstants)};
  auto ci = vkInit<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  ci.setLayoutCount = 1;
  ci.pSetLayouts = &setLayout_;
  ci.pushConstantRangeCount = 1;
  ci.pPushConstantRanges = &range;
  CSM_VK_TRY(vkCreatePipelineLayout(dev, &ci, nullptr, &pipelineLayout_));
  setName(handleBits(pipelineLayout_), VK_OBJECT_TYPE_PIPELINE_LAYOUT,
          "csm depth range pipeline layout");
  return {};
}

// The compute pipeline of csm_depth_range.comp.
Status DepthRangeReducer::createPipeline(VkPipelineCache cache) {
  const VkDevice dev = device_;
  auto ci = vkInit<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
  ci.codeSize = sizeof(csm_depth_range_comp_spv);
  ci.pCode = csm_depth_range_comp_spv;
  CSM_VK_TRY(vkCreateShaderModule(dev, &ci, nullptr, &module_));
  setName(handleBits(module_), VK_OBJECT_TYPE_SHADER_MODULE, "csm_depth_range.comp");
  auto pci = vkInit<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
  pci.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  pci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  pci.stage.module = module_;
  pci.stage.pName = "main";
  pci.layout = pipelineLayout_;
  CSM_VK_TRY(vkCreateComputePipelines(dev, cache, 1, &pci, nullptr, &pipeline_));
  setName(handleBits(pipeline_), VK_OBJECT_TYPE_PIPELINE, "csm depth range pipeline");
  return {};
}

// The nearest, clamped sampler the shader reads depth through.
Status DepthRangeReducer::createSampler() {
  const VkDevice dev = device_;
  auto ci = vkInit<VkSamplerCreateInfo>(VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO);
  ci.magFilter = VK_FILTER_NEAREST;
  ci.minFilter = VK_FILTER_NEAREST;
  ci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  ci.addressModeU = ci.addressModeV = ci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  ci.maxLod = 0.0f;
  CSM_VK_TRY(vkCreateSampler(dev, &ci, nullptr, &sampler_));
  setName(handleBits(sampler_), VK_OBJECT_TYPE_SAMPLER, "csm depth range sampler");
  return {};
}

// The result buffer: one Slot (uvec4 + bins) per slot, host-visible and coherent (read back by
// the CPU).
Status DepthRangeReducer::createResultBuffer(VkPhysicalDevice physicalDevice) {
  const VkDevice dev = device_;
  const std::uint32_t slots = slots_;
  auto ci = vkInit<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
  ci.size = kSlotBytes * slots;
  ci.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  ci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  CSM_VK_TRY(vkCreateBuffer(dev, &ci, nullptr, &buffer_));
  setName(handleBits(buffer_), VK_OBJECT_TYPE_BUFFER, "csm depth range results");
  VkMemoryRequirements req{};
  vkGetBufferMemoryRequirements(dev, buffer_, &req);
  VkPhysicalDeviceMemoryProperties mem{};
  vkGetPhysicalDeviceMemoryProperties(physicalDevice, &mem);
  const VkMemoryPropertyFlags want =
      VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  std::uint32_t type = UINT32_MAX;
  for (std::uint32_t i = 0; i < mem.memoryTypeCount; ++i) {
    if ((req.memoryTypeBits & (1u << i)) && (mem.memoryTypes[i].propertyFlags & want) == want) {
      type = i;
      break;
    }
  }
  if (type == UINT32_MAX) {
    return Status(ErrorCode::kDeviceLimit,
                  "DepthRangeReducer: no host-visible coherent memory for the results");
  }
  auto ai = vkInit<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
  ai.allocationSize = req.size;
  ai.memoryTypeIndex = type;
  CSM_VK_TRY(vkAllocateMemory(dev, &ai, nullptr, &memory_));
  setName(handleBits(memory_), VK_OBJECT_TYPE_DEVICE_MEMORY, "csm depth range results memory");
  CSM_VK_TRY(vkBindBufferMemory(dev, buffer_, memory_, 0));
  CSM_VK_TRY(vkMapMemory(dev, memory_, 0, VK_WHOLE_SIZE, 0, &mapped_));
  std::memset(mapped_, 0, std::size_t(kSlotBytes) * slots);
  return {};
}

// The descriptor pool and one set per slot.
Status DepthRangeReducer::createSets() {
  const VkDevice dev = device_;
  const std::uint32_t slots = slots_;
  VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, slots},
                                   {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, slots}};
  auto ci = vkInit<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  ci.maxSets = slots;
  ci.poolSizeCount = 2;
  ci.pPoolSizes = sizes;
  CSM_VK_TRY(vkCreateDescriptorPool(dev, &ci, nullptr, &pool_));
  setName(handleBits(pool_), VK_OBJECT_TYPE_DESCRIPTOR_POOL, "csm depth range pool");
  VkDescriptorSetLayout layouts[kMaxSlots];
  for (std::uint32_t i = 0; i < slots; ++i) layouts[i] = setLayout_;
  auto ai = vkInit<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  ai.descriptorPool = pool_;
  ai.descriptorSetCount = slots;
  ai.pSetLayouts = layouts;
  CSM_VK_TRY(vkAllocateDescriptorSets(dev, &ai, sets_));
  for (std::uint32_t i = 0; i < slots; ++i) {
    const std::string name = "csm depth range set " + std::to_string(i);
    setName(handleBits(sets_[i]), VK_OBJECT_TYPE_DESCRIPTOR_SET, name.c_str());
  }
  return {};
}

DepthRangeReducer::~DepthRangeReducer() {
  if (device_ == VK_NULL_HANDLE) return;
  if (pool_) vkDestroyDescriptorPool(device_, pool_, nullptr);
  if (memory_) {
    if (mapped_) vkUnmapMemory(device_, memory_);
    vkFreeMemory(device_, memory_, nullptr);
  }
  if (buffer_) vkDestroyBuffer(device_, buffer_, nullptr);
  if (sampler_) vkDestroySampler(device_, sampler_, nullptr);
  if (pipeline_) vkDestroyPipeline(device_, pipeline_, nullptr);
  if (module_) vkDestroyShaderModule(device_, module_, nullptr);
  if (pipelineLayout_) vkDestroyPipelineLayout(device_, pipelineLayout_, nullptr);
  if (setLayout_) vkDestroyDescriptorSetLayout(device_, setLayout_, nullptr);
}

namespace {

// record()'s arguments: the slot in range, a readable depth view, bounds inputs that go together
// with a usable projection, and a valid histogram range; each refusal names what is wrong.
Status checkRecordArguments(VkImageView depthView, VkImageLayout layout, VkExtent2D extent,
                            const DepthProjection& projection, std::uint32_t slot,
                            std::uint32_t slots, const ReceiverBoundsInputs& bounds) {
  if (!(slot < slots)) {
    return Status(ErrorCode::kIndexOutOfRange,
                  "DepthRangeReducer::record: slot = " + std::to_string(slot) +
                      " is invalid: allowed [0, " + std::to_string(slots - 1) + "]");
  }
  if (depthView == VK_NULL_HANDLE || extent.width == 0 || extent.height == 0 ||
      !readableLayout(layout)) {
    return Status(ErrorCode::kInvalidArgument,
                  "DepthRangeReducer::record: a depth view, a non-zero extent and a read-only "
                  "layout (DEPTH_READ_ONLY, DEPTH_STENCIL_READ_ONLY, READ_ONLY or "
                  "SHADER_READ_ONLY) are required");
  }
  if ((bounds.frame != nullptr) != (bounds.camera != nullptr)) {
    return Status(ErrorCode::kInvalidArgument,
                  "DepthRangeReducer::record: bounds.frame and bounds.camera go together");
  }
  if (bounds.tiles != nullptr) {
    if (bounds.frame == nullptr) {
      return Status(ErrorCode::kInvalidArgument,
                    "DepthRangeReducer::record: bounds.tiles needs bounds.frame and bounds.camera");
    }
    if (auto e = csm::validate(*bounds.tiles)) {
      return Status(ErrorCode::kInvalidArgument,
                    "DepthRangeReducer::record: bounds.tiles: " + e->message());
    }
  }
  if (bounds.frame != nullptr &&
      (!std::isfinite(projection.p00) || !std::isfinite(projection.p11) ||
       !std::isfinite(projection.p20) || !std::isfinite(projection.p21) || projection.p00 == 0.0f ||
       projection.p11 == 0.0f || bounds.frame->cascadeCount == 0 ||
       bounds.frame->cascadeCount > kMaxCascades)) {
    return Status(ErrorCode::kInvalidArgument,
                  "DepthRangeReducer::record: with bounds, projection.p00, p11, p20 and p21 must "
                  "be finite, p00 and p11 != 0, and bounds.frame a computed frame (cascadeCount "
                  "in [1, CSM_MAX_CASCADES])");
  }
  if (!std::isfinite(projection.p22) || !std::isfinite(projection.p32) || projection.p32 == 0.0f) {
    return Status(ErrorCode::kInvalidArgument,
                  "DepthRangeReducer::record: projection.p22 and p32 must be finite, p32 != 0");
  }
  const float hNear = projection.histogramNearM, hFar = projection.histogramFarM;
  if (hNear != 0.0f &&
      !(hNear > 0.0f && std::isfinite(hFar) && double(hFar) > double(hNear) * (1.0 + 1e-6))) {
    char buf[224];
    std::snprintf(buf, sizeof buf,
                  "DepthRangeReducer::record: projection.histogramNearM = %g, histogramFarM = %g "
                  "is invalid: allowed 0 < histogramNearM < histogramFarM (finite), or "
                  "histogramNearM = 0 for no histogram",
                  double(hNear), double(hFar));
    return Status(ErrorCode::kInvalidArgument, buf);
  }
  return {};
}

}  // namespace

Status DepthRangeReducer::record(VkCommandBuffer cmd, VkImageView depthView, VkImageLayout layout,
                                 VkExtent2D extent, const DepthProjection& projection,
                                 std::uint32_t slot, const ReceiverBoundsInputs& bounds) {
  if (Status s = checkRecordArguments(depthView, layout, extent, projection, slot, slots_, bounds);
      !s.ok()) {
    return s;
  }
  const float hNear = projection.histogramNearM, hFar = projection.histogramFarM;
  // The slot's previous submission has completed (the caller's contract): rewrite its set.
  VkDescriptorImageInfo image{sampler_, depthView, layout};
  VkDescriptorBufferInfo buffer{buffer_, 0, VK_WHOLE_SIZE};
  VkWriteDescriptorSet w[2]{};
  for (int i = 0; i < 2; ++i) {
    w[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    w[i].dstSet = sets_[slot];
    w[i].dstBinding = std::uint32_t(i);
    w[i].descriptorCount = 1;
  }
  w[0].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  w[0].pImageInfo = &image;
  w[1].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  w[1].pBufferInfo = &buffer;
  vkUpdateDescriptorSets(device_, 2, w, 0, nullptr);

  // Reset the slot (min = FLT_MAX, max = count = 0, every bin 0, every bound 0xffffffff), then
  // reduce.
  const VkDeviceSize offset = kSlotBytes * slot;
  vkCmdFillBuffer(cmd, buffer_, offset, 4, kFltMaxBits);
  vkCmdFillBuffer(cmd, buffer_, offset + 4, 12 + kBinsBytes, 0u);
  vkCmdFillBuffer(cmd, buffer_, offset + 16 + kBinsBytes, kBoundsBytes, 0xffffffffu);
  vkCmdFillBuffer(cmd, buffer_, offset + kTilesOffset, kTilesBytes, 0u);
  slotTiles_[slot] = ReceiverTileMarks{};
  if (bounds.frame != nullptr && bounds.tiles != nullptr) {
    // Each cascade's grid about the camera (the shader's positions are camera-relative floats).
    const ReceiverTileMarks t = emptyReceiverTileMarks(*bounds.tiles, *bounds.frame);
    const glm::dmat3 basisT = glm::transpose(t.lightBasisWs);
    const glm::dvec3 cam = basisT * bounds.frame->cameraPositionWs;
    float grid[2][kMaxCascades][4]{};
    for (std::uint32_t i = 0; i < t.cascadeCount; ++i) {
      grid[1][i][0] = float(t.blendStartM[i]);
      if (!(t.nonEmptyMask >> i & 1u)) continue;
      const double tileM = t.texelM[i] * t.tileTexels;
      grid[0][i][0] = float(double(t.gridOrigin[i].x) * tileM - cam.x);
      grid[0][i][1] = float(double(t.gridOrigin[i].y) * tileM - cam.y);
      grid[0][i][2] = float(1.0 / tileM);
      grid[0][i][3] = float(t.reachM[i]);
      grid[1][i][1] = 1.0f;
    }
    static_assert(sizeof grid == kGridBytes);
    vkCmdUpdateBuffer(cmd, buffer_, offset + kGridOffset, kGridBytes, grid);
    slotTiles_[slot] = t;
  }
  auto toCompute = vkInit<VkMemoryBarrier2>(VK_STRUCTURE_TYPE_MEMORY_BARRIER_2);
  toCompute.srcStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  toCompute.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  toCompute.dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  toCompute.dstAccessMask =
      VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
  auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.memoryBarrierCount = 1;
  dep.pMemoryBarriers = &toCompute;
  vkCmdPipelineBarrier2(cmd, &dep);

  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelineLayout_, 0, 1, &sets_[slot],
                          0, nullptr);
  const float binsPerLog =
      hNear > 0.0f ? float(double(kDepthHistogramBins) / std::log(double(hFar) / double(hNear)))
                   : 0.0f;
  PushConstants push{{extent.width, extent.height},
                     projection.p22,
                     projection.p32,
                     projection.clearDepth,
                     slot,
                     hNear,
                     binsPerLog,
                     {},
                     {},
                     {},
                     0u,
                     0u,
                     {}};
  slotBounds_[slot] = ReceiverLightBounds{};
  if (bounds.frame != nullptr) {
    const CascadeFrame& f = *bounds.frame;
    const glm::dmat3 r = glm::mat3_cast(glm::normalize(bounds.camera->orientationWs));
    for (int j = 0; j < 3; ++j) {
      push.lsX[j] = float(glm::dot(f.lightBasisWs[0], r[j]));
      push.lsY[j] = float(glm::dot(f.lightBasisWs[1], r[j]));
    }
    push.lsX[3] = 1.0f / projection.p00;
    push.lsY[3] = 1.0f / projection.p11;
    push.pOff[0] = projection.p20;
    push.pOff[1] = projection.p21;
    push.boundsCount = f.cascadeCount;
    push.tileMarks = slotTiles_[slot].present() ? 1u : 0u;
    for (std::uint32_t i = 0; i <= f.cascadeCount; ++i) push.splits[i] = float(f.splitsM[i]);
    slotBounds_[slot] = emptyReceiverLightBounds(f, *bounds.camera);
  }
  vkCmdPushConstants(cmd, pipelineLayout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  vkCmdDispatch(cmd, (extent.width + kGroup - 1) / kGroup, (extent.height + kGroup - 1) / kGroup,
                1);

  auto toHost = vkInit<VkMemoryBarrier2>(VK_STRUCTURE_TYPE_MEMORY_BARRIER_2);
  toHost.srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  toHost.srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
  toHost.dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT;
  toHost.dstAccessMask = VK_ACCESS_2_HOST_READ_BIT;
  dep.pMemoryBarriers = &toHost;
  vkCmdPipelineBarrier2(cmd, &dep);
  slotGeneration_[slot] = generation_;
  slotHistogramNearM_[slot] = hNear;
  slotHistogramFarM_[slot] = hFar;
  return {};
}

std::optional<ReceiverDepthRange> DepthRangeReducer::read(std::uint32_t slot) const {
  if (!(slot < slots_) || slotGeneration_[slot] != generation_) return std::nullopt;
  std::uint32_t v[4];
  const char* base = static_cast<const char*>(mapped_) + std::size_t(kSlotBytes) * slot;
  std::memcpy(v, base, sizeof v);
  if (v[2] == 0) return std::nullopt;  // no receiver pixel
  float lo = 0.0f, hi = 0.0f;
  std::memcpy(&lo, &v[0], 4);
  std::memcpy(&hi, &v[1], 4);
  if (!(lo > 0.0f) || !(hi >= lo) || !std::isfinite(hi)) return std::nullopt;
  ReceiverDepthRange range{double(lo), double(hi)};
  if (slotHistogramNearM_[slot] > 0.0f) {
    range.histogram.nearM = double(slotHistogramNearM_[slot]);
    range.histogram.farM = double(slotHistogramFarM_[slot]);
    std::memcpy(range.histogram.counts.data(), base + 16, 4 * std::size_t(kDepthHistogramBins));
  }
  const ReceiverLightBounds& b = slotBounds_[slot];
  if (b.present()) {
    std::uint32_t u[kMaxCascades * 4];
    std::memcpy(u, base + 16 + kBinsBytes, sizeof u);
    range.lightBounds = b;
    const glm::dvec2 cameraLs(glm::dot(b.lightBasisWs[0], b.cameraPositionWs),
                              glm::dot(b.lightBasisWs[1], b.cameraPositionWs));
    constexpr double kInf = std::numeric_limits<double>::infinity();
    for (std::uint32_t i = 0; i < b.cascadeCount; ++i) {
      const std::uint32_t* q = u + 4 * i;
      if (q[0] == 0xffffffffu) {  // no receiver in this cascade
        range.lightBounds.minLs[i] = glm::dvec2(kInf);
        range.lightBounds.maxLs[i] = glm::dvec2(-kInf);
        continue;
      }
      range.lightBounds.minLs[i] =
          cameraLs + glm::dvec2(fromOrderedBits(q[0]), fromOrderedBits(q[1]));
      range.lightBounds.maxLs[i] =
          cameraLs + glm::dvec2(fromOrderedBits(~q[2]), fromOrderedBits(~q[3]));
    }
  }
  if (slotTiles_[slot].present()) {
    range.tiles = slotTiles_[slot];
    for (std::uint32_t i = 0; i < range.tiles.cascadeCount; ++i) {
      std::memcpy(range.tiles.bits[i].data(), base + kTilesOffset + 4 * kTileWords * i,
                  4 * kTileWords);
    }
  }
  return range;
}

}  // namespace csm::vk
