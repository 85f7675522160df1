// ShadowRenderer: creation and destruction of the settings-independent objects, the status
// helpers, and the public interface forwarding to the Impl. The settings (update) are in
// shadow_renderer_update.cpp, the pass in shadow_renderer_pass.cpp, the cache's steps in
// shadow_cache.cpp, the thin casters' in thin_casters.cpp.
#include "csm/vulkan/shadow_renderer.hpp"
#include "csm/moments.hpp"
#include "csm/thin_casters.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <string>

#include <csm_shaders/csm_cache_restore.frag.spv.h>
#include <csm_shaders/csm_cache_restore.vert.spv.h>
#include <csm_shaders/csm_depth.vert.spv.h>
#include <csm_shaders/csm_depth_layered.vert.spv.h>

#include "shadow_renderer_impl.hpp"
#include "vk_util.hpp"

namespace csm::vk {

namespace {

// What create() needs of the host: a device, a readable vertex layout, a frame count.
Status checkCreateArgs(const DeviceInfo& device, const VertexLayout& layout) {
  if (device.physicalDevice == VK_NULL_HANDLE || device.device == VK_NULL_HANDLE) {
    return Status(ErrorCode::kInvalidArgument,
                  "DeviceInfo: physicalDevice and device are required");
  }
  if (layout.stride == 0 || layout.positionOffset + 12 > layout.stride ||
      (layout.positionFormat != VK_FORMAT_R32G32B32_SFLOAT &&
       layout.positionFormat != VK_FORMAT_R32G32B32A32_SFLOAT) ||
      (layout.indexType != VK_INDEX_TYPE_UINT32 && layout.indexType != VK_INDEX_TYPE_UINT16)) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("VertexLayout: stride %u, positionOffset %u, format %d, index type %d is "
                      "invalid: allowed a float3/float4 position inside the stride and a "
                      "16/32-bit index type",
                      layout.stride, layout.positionOffset, int(layout.positionFormat),
                      int(layout.indexType)));
  }
  if (device.framesInFlight < 1 || device.framesInFlight > 16) {
    return Status(
        ErrorCode::kInvalidArgument,
        fmt("DeviceInfo::framesInFlight = %u is invalid: allowed [1, 16]", device.framesInFlight));
  }
  return {};
}

}  // namespace

Status validateCasters(std::span<const MeshDraw> meshes,
                       std::span<const CasterInstance> instances) {
  for (std::size_t i = 0; i < instances.size(); ++i) {
    const CasterInstance& inst = instances[i];
    if (inst.mesh >= meshes.size()) {
      return Status(ErrorCode::kIndexOutOfRange,
                    fmt("casters.instances[%zu].mesh = %u is out of range: allowed [0, %zu)", i,
                        inst.mesh, meshes.size()));
    }
    for (std::uint32_t k = 0; k + 1 < kMaxCasterLods; ++k) {
      const std::uint32_t m = inst.lodMeshes[k];
      if (m != kNoMesh && m >= meshes.size()) {
        return Status(ErrorCode::kIndexOutOfRange,
                      fmt("casters.instances[%zu].lodMeshes[%u] = %u is out of range: allowed "
                          "[0, %zu) or kNoMesh",
                          i, k, m, meshes.size()));
      }
      const float e = inst.lodErrorM[k];
      if (!(e >= 0.0f)) {
        return Status(ErrorCode::kInvalidArgument,
                      fmt("casters.instances[%zu].lodErrorM[%u] = %g is invalid: allowed "
                          "[0, +inf] metres (kUnknownLodError = not known)",
                          i, k, double(e)));
      }
    }
    if (!(inst.thinWidthM >= 0.0f && inst.thinWidthM <= kMaxThinWidthM)) {
      return Status(ErrorCode::kInvalidArgument,
                    fmt("casters.instances[%zu].thinWidthM = %g is invalid: allowed [0, 1000] "
                        "metres (0 = not known)",
                        i, double(inst.thinWidthM)));
    }
    static constexpr const char* kAxes = "xyz";
    for (int a = 0; a < 3; ++a) {
      if (!(std::abs(inst.translationWs[a]) <= kMaxWorldCoordinateM)) {
        return Status(ErrorCode::kInvalidArgument,
                      fmt("casters.instances[%zu].translationWs.%c = %g is invalid: allowed a "
                          "coordinate in metres in [-1e9, 1e9] (kMaxWorldCoordinateM)",
                          i, kAxes[a], inst.translationWs[a]));
      }
    }
    for (int col = 0; col < 3; ++col) {
      for (int row = 0; row < 3; ++row) {
        if (!std::isfinite(inst.linearWs[col][row])) {
          return Status(ErrorCode::kInvalidArgument,
                        fmt("casters.instances[%zu].linearWs[%d][%d] = %g is invalid: allowed a "
                            "finite number",
                            i, col, row, double(inst.linearWs[col][row])));
        }
      }
    }
  }
  return {};
}

std::string vkResultName(VkResult result) {
  switch (result) {
#define CSM_VK_RESULT_CASE(x) \
  case x:                     \
    return #x;
    CSM_VK_RESULT_CASE(VK_SUCCESS)
    CSM_VK_RESULT_CASE(VK_NOT_READY)
    CSM_VK_RESULT_CASE(VK_TIMEOUT)
    CSM_VK_RESULT_CASE(VK_EVENT_SET)
    CSM_VK_RESULT_CASE(VK_EVENT_RESET)
    CSM_VK_RESULT_CASE(VK_INCOMPLETE)
    CSM_VK_RESULT_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
    CSM_VK_RESULT_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    CSM_VK_RESULT_CASE(VK_ERROR_INITIALIZATION_FAILED)
    CSM_VK_RESULT_CASE(VK_ERROR_DEVICE_LOST)
    CSM_VK_RESULT_CASE(VK_ERROR_MEMORY_MAP_FAILED)
    CSM_VK_RESULT_CASE(VK_ERROR_LAYER_NOT_PRESENT)
    CSM_VK_RESULT_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
    CSM_VK_RESULT_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
    CSM_VK_RESULT_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
    CSM_VK_RESULT_CASE(VK_ERROR_TOO_MANY_OBJECTS)
    CSM_VK_RESULT_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
    CSM_VK_RESULT_CASE(VK_ERROR_FRAGMENTED_POOL)
    CSM_VK_RESULT_CASE(VK_ERROR_UNKNOWN)
    CSM_VK_RESULT_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
    CSM_VK_RESULT_CASE(VK_ERROR_INVALID_EXTERNAL_HANDLE)
    CSM_VK_RESULT_CASE(VK_ERROR_FRAGMENTATION)
    CSM_VK_RESULT_CASE(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
    CSM_VK_RESULT_CASE(VK_PIPELINE_COMPILE_REQUIRED)
    CSM_VK_RESULT_CASE(VK_ERROR_SURFACE_LOST_KHR)
    CSM_VK_RESULT_CASE(VK_ERROR_NATIVE_WINDOW_IN_USE_KHR)
    CSM_VK_RESULT_CASE(VK_SUBOPTIMAL_KHR)
    CSM_VK_RESULT_CASE(VK_ERROR_OUT_OF_DATE_KHR)
    CSM_VK_RESULT_CASE(VK_ERROR_INCOMPATIBLE_DISPLAY_KHR)
    CSM_VK_RESULT_CASE(VK_ERROR_VALIDATION_FAILED_EXT)
#undef CSM_VK_RESULT_CASE
    default:
      return "VkResult(" + std::to_string(static_cast<int>(result)) + ")";
  }
}

const char* errorCodeName(ErrorCode code) noexcept {
  switch (code) {
    case ErrorCode::kOk:
      return "ok";
    case ErrorCode::kWrongOrder:
      return "wrong order";
    case ErrorCode::kInvalidArgument:
      return "invalid argument";
    case ErrorCode::kIndexOutOfRange:
      return "index out of range";
    case ErrorCode::kDeviceLimit:
      return "device limit";
    case ErrorCode::kUnsupportedFormat:
      return "unsupported format";
    case ErrorCode::kVulkan:
      return "Vulkan error";
  }
  return "unknown";
}

// ---------------------------------------------------------------------------------------------
// Creation and destruction

std::unique_ptr<ShadowRenderer> ShadowRenderer::create(const DeviceInfo& device,
                                                       const VertexLayout& layout, Status* status) {
  std::unique_ptr<ShadowRenderer> r(new ShadowRenderer());
  Status s = r->impl_->init(device, layout);
  if (status) *status = s;
  if (!s.ok()) return nullptr;
  return r;
}

void ShadowRenderer::Impl::setName(std::uint64_t handle, VkObjectType type,
                                   const char* name) const {
  setObjectName(setObjectName_, device_.device, handle, type, name);
}

Status ShadowRenderer::Impl::init(const DeviceInfo& device, const VertexLayout& layout) {
  Status s = checkCreateArgs(device, layout);
  if (!s.ok()) return s;
  device_ = device;
  layout_ = layout;
  vkGetPhysicalDeviceProperties(device.physicalDevice, &properties_);
  vkGetPhysicalDeviceMemoryProperties(device.physicalDevice, &memory_);
  // Against the device's limit: refused by name, never clamped.
  const float maxAnisotropy = properties_.limits.maxSamplerAnisotropy;
  if (!(device.maxSamplerAnisotropy >= 1.0f &&
        device.maxSamplerAnisotropy <= std::max(1.0f, maxAnisotropy))) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("DeviceInfo::maxSamplerAnisotropy = %g is invalid: allowed [1, %g] (the "
                      "device's maxSamplerAnisotropy; above 1 with samplerAnisotropy enabled)",
                      double(device.maxSamplerAnisotropy), double(std::max(1.0f, maxAnisotropy))));
  }
  if (device.storageImageExtendedFormatsEnabled) {
    VkPhysicalDeviceFeatures features{};
    vkGetPhysicalDeviceFeatures(device.physicalDevice, &features);
    if (features.shaderStorageImageExtendedFormats != VK_TRUE) {
      return Status(ErrorCode::kInvalidArgument,
                    "DeviceInfo::storageImageExtendedFormatsEnabled = true is invalid: the device "
                    "does not support shaderStorageImageExtendedFormats (allowed: false)");
    }
  }
  loadDebugUtils();
  s = createSetLayouts();
  if (s.ok()) s = createPipelineLayout();
  if (s.ok()) s = createDepthSet();
  if (s.ok()) s = createClearResources();
  if (s.ok()) s = createSamplers();
  if (s.ok()) s = createUniformBuffer();
  if (s.ok()) s = createShaderModules();
  if (s.ok()) s = createMomentResources();
  return s;
}

// The debug-utils entry points (object names, pass labels) when the host enabled them.
void ShadowRenderer::Impl::loadDebugUtils() {
  VkDevice dev = device_.device;
  if (device_.debugUtilsEnabled) {
    setObjectName_ = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
        vkGetDeviceProcAddr(dev, "vkSetDebugUtilsObjectNameEXT"));
    beginLabel_ = reinterpret_cast<PFN_vkCmdBeginDebugUtilsLabelEXT>(
        vkGetDeviceProcAddr(dev, "vkCmdBeginDebugUtilsLabelEXT"));
    endLabel_ = reinterpret_cast<PFN_vkCmdEndDebugUtilsLabelEXT>(
        vkGetDeviceProcAddr(dev, "vkCmdEndDebugUtilsLabelEXT"));
  }
}

// Descriptor set layouts: the depth pass reads the uniform block; the lighting pass reads the
// block and the map through both samplers.
Status ShadowRenderer::Impl::createSetLayouts() {
  VkDevice dev = device_.device;
  {
    VkDescriptorSetLayoutBinding b{};
    b.binding = CSM_BINDING_UNIFORMS;
    b.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    b.descriptorCount = 1;
    b.stageFlags = VK_SHADER_STAGE_VERTEX_BIT;
    auto ci = vkInit<VkDescriptorSetLayoutCreateInfo>(
        VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
    ci.bindingCount = 1;
    ci.pBindings = &b;
    CSM_VK_TRY(vkCreateDescriptorSetLayout(dev, &ci, nullptr, &depthSetLayout_));
    setName(handleBits(depthSetLayout_), VK_OBJECT_TYPE_DESCRIPTOR_SET_LAYOUT,
            "csm depth set layout");
  }
  {
    const VkShaderStageFlags stages = VK_SHADER_STAGE_FRAGMENT_BIT | VK_SHADER_STAGE_COMPUTE_BIT;
    VkDescriptorSetLayoutBinding b[4]{};
    b[0] = {CSM_BINDING_UNIFORMS, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, stages, nullptr};
    b[1] = {CSM_BINDING_SHADOW_MAP, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, stages, nullptr};
    b[2] = {CSM_BINDING_SHADOW_DEPTH, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, stages,
            nullptr};
    b[3] = {CSM_BINDING_MOMENTS, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, stages, nullptr};
    auto ci = vkInit<VkDescriptorSetLayoutCreateInfo>(
        VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
    ci.bindingCount = 4;
    ci.pBindings = b;
    CSM_VK_TRY(vkCreateDescriptorSetLayout(dev, &ci, nullptr, &lightingLayout_));
    setName(handleBits(lightingLayout_), VK_OBJECT_TYPE_DESCRIPTOR_SET_LAYOUT,
            "csm lighting set layout");
  }
  return {};
}

// The depth pipelines' layout: the depth set and the push constants (DepthPushPerLayer or
// DepthPushLayered, CSM_DEPTH_PUSH_SIZE bytes either way), then, where the device has a
// geometry stage, the thin casters' widening (ThinPush).
Status ShadowRenderer::Impl::createPipelineLayout() {
  VkDevice dev = device_.device;
  const VkPushConstantRange ranges[2] = {
      {VK_SHADER_STAGE_VERTEX_BIT, 0, CSM_DEPTH_PUSH_SIZE},
      {VK_SHADER_STAGE_GEOMETRY_BIT, CSM_THIN_PUSH_OFFSET, CSM_THIN_PUSH_SIZE}};
  auto ci = vkInit<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  ci.setLayoutCount = 1;
  ci.pSetLayouts = &depthSetLayout_;
  ci.pushConstantRangeCount = device_.geometryShaderEnabled ? 2 : 1;
  ci.pPushConstantRanges = ranges;
  CSM_VK_TRY(vkCreatePipelineLayout(dev, &ci, nullptr, &pipelineLayout_));
  setName(handleBits(pipelineLayout_), VK_OBJECT_TYPE_PIPELINE_LAYOUT, "csm depth pipeline layout");
  // CacheRestore::kShaderCopy: one static layer, sampled by the fragment stage.
  VkDescriptorSetLayoutBinding b{};
  b.binding = 0;
  b.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  b.descriptorCount = 1;
  b.stageFlags = VK_SHADER_STAGE_FRAGMENT_BIT;
  auto li =
      vkInit<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
  li.bindingCount = 1;
  li.pBindings = &b;
  CSM_VK_TRY(vkCreateDescriptorSetLayout(dev, &li, nullptr, &restoreSetLayout_));
  setName(handleBits(restoreSetLayout_), VK_OBJECT_TYPE_DESCRIPTOR_SET_LAYOUT,
          "csm cache restore set layout");
  ci.pSetLayouts = &restoreSetLayout_;
  ci.pushConstantRangeCount = 0;
  ci.pPushConstantRanges = nullptr;
  CSM_VK_TRY(vkCreatePipelineLayout(dev, &ci, nullptr, &restoreLayout_));
  setName(handleBits(restoreLayout_), VK_OBJECT_TYPE_PIPELINE_LAYOUT,
          "csm cache restore pipeline layout");
  return {};
}

Status ShadowRenderer::Impl::createDepthSet() {
  VkDevice dev = device_.device;
  // The depth pass's set never changes; the lighting set lives with each image (buildImage).
  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1};
  auto ci = vkInit<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  ci.maxSets = 1;
  ci.poolSizeCount = 1;
  ci.pPoolSizes = &size;
  CSM_VK_TRY(vkCreateDescriptorPool(dev, &ci, nullptr, &pool_));
  setName(handleBits(pool_), VK_OBJECT_TYPE_DESCRIPTOR_POOL, "csm descriptor pool");
  auto ai = vkInit<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  ai.descriptorPool = pool_;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &depthSetLayout_;
  CSM_VK_TRY(vkAllocateDescriptorSets(dev, &ai, &depthSet_));
  setName(handleBits(depthSet_), VK_OBJECT_TYPE_DESCRIPTOR_SET, "csm depth set");
  return {};
}

// The command pool and fence of the one-time clear update() submits (DeviceInfo::queue).
Status ShadowRenderer::Impl::createClearResources() {
  VkDevice dev = device_.device;
  if (device_.queue == VK_NULL_HANDLE) return {};
  auto ci = vkInit<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
  ci.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  ci.queueFamilyIndex = device_.queueFamily;
  CSM_VK_TRY(vkCreateCommandPool(dev, &ci, nullptr, &clearPool_));
  setName(handleBits(clearPool_), VK_OBJECT_TYPE_COMMAND_POOL, "csm clear command pool");
  auto fi = vkInit<VkFenceCreateInfo>(VK_STRUCTURE_TYPE_FENCE_CREATE_INFO);
  CSM_VK_TRY(vkCreateFence(dev, &fi, nullptr, &clearFence_));
  setName(handleBits(clearFence_), VK_OBJECT_TYPE_FENCE, "csm clear fence");
  return {};
}

// The comparison and raw-depth samplers, clamped (outside = lit) and wrapped (cached cascades).
Status ShadowRenderer::Impl::createSamplers() {
  VkDevice dev = device_.device;
  auto ci = vkInit<VkSamplerCreateInfo>(VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO);
  ci.magFilter = VK_FILTER_LINEAR;
  ci.minFilter = VK_FILTER_LINEAR;
  ci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  ci.addressModeU = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_BORDER;
  ci.addressModeV = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_BORDER;
  ci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  ci.compareEnable = VK_TRUE;
  ci.compareOp = VK_COMPARE_OP_LESS_OR_EQUAL;
  ci.minLod = 0.0f;
  ci.maxLod = 0.0f;
  // Outside the map reads as the far plane: every receiver compares lit.
  ci.borderColor = VK_BORDER_COLOR_FLOAT_OPAQUE_WHITE;
  CSM_VK_TRY(vkCreateSampler(dev, &ci, nullptr, &compareSampler_));
  setName(handleBits(compareSampler_), VK_OBJECT_TYPE_SAMPLER, "csm comparison sampler");
  ci.magFilter = VK_FILTER_NEAREST;
  ci.minFilter = VK_FILTER_NEAREST;
  ci.compareEnable = VK_FALSE;
  ci.compareOp = VK_COMPARE_OP_ALWAYS;
  CSM_VK_TRY(vkCreateSampler(dev, &ci, nullptr, &depthSampler_));
  setName(handleBits(depthSampler_), VK_OBJECT_TYPE_SAMPLER, "csm depth sampler");
  // Cached cascades: layers addressed toroidally; csm.glsl keeps outside-the-box = lit itself.
  ci.addressModeU = VK_SAMPLER_ADDRESS_MODE_REPEAT;
  ci.addressModeV = VK_SAMPLER_ADDRESS_MODE_REPEAT;
  CSM_VK_TRY(vkCreateSampler(dev, &ci, nullptr, &wrapDepthSampler_));
  setName(handleBits(wrapDepthSampler_), VK_OBJECT_TYPE_SAMPLER, "csm depth sampler (wrap)");
  ci.magFilter = VK_FILTER_LINEAR;
  ci.minFilter = VK_FILTER_LINEAR;
  ci.compareEnable = VK_TRUE;
  ci.compareOp = VK_COMPARE_OP_LESS_OR_EQUAL;
  CSM_VK_TRY(vkCreateSampler(dev, &ci, nullptr, &wrapCompareSampler_));
  setName(handleBits(wrapCompareSampler_), VK_OBJECT_TYPE_SAMPLER, "csm comparison sampler (wrap)");
  return {};
}

// The uniform block's buffer, written into the depth set (the lighting set gets it in buildImage).
Status ShadowRenderer::Impl::createUniformBuffer() {
  VkDevice dev = device_.device;
  auto ci = vkInit<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
  ci.size = sizeof(CsmUniforms);
  ci.usage = VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  ci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  CSM_VK_TRY(vkCreateBuffer(dev, &ci, nullptr, &uniformBuffer_));
  setName(handleBits(uniformBuffer_), VK_OBJECT_TYPE_BUFFER, "csm uniforms");
  VkMemoryRequirements req{};
  vkGetBufferMemoryRequirements(dev, uniformBuffer_, &req);
  Status s = allocate(req, &uniformMemory_, "csm uniforms memory");
  if (!s.ok()) return s;
  CSM_VK_TRY(vkBindBufferMemory(dev, uniformBuffer_, uniformMemory_, 0));
  VkDescriptorBufferInfo bi{uniformBuffer_, 0, sizeof(CsmUniforms)};
  auto w = vkInit<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
  w.dstSet = depthSet_;
  w.dstBinding = CSM_BINDING_UNIFORMS;
  w.descriptorCount = 1;
  w.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  w.pBufferInfo = &bi;
  vkUpdateDescriptorSets(dev, 1, &w, 0, nullptr);
  return {};
}

// The depth pass's vertex shaders (the layered one only with shaderOutputLayer).
Status ShadowRenderer::Impl::createShaderModules() {
  VkDevice dev = device_.device;
  auto ci = vkInit<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
  ci.codeSize = sizeof(csm_depth_vert_spv);
  ci.pCode = csm_depth_vert_spv;
  CSM_VK_TRY(vkCreateShaderModule(dev, &ci, nullptr, &vertexModule_));
  setName(handleBits(vertexModule_), VK_OBJECT_TYPE_SHADER_MODULE, "csm_depth.vert");
  if (device_.shaderOutputLayerEnabled) {
    ci.codeSize = sizeof(csm_depth_layered_vert_spv);
    ci.pCode = csm_depth_layered_vert_spv;
    CSM_VK_TRY(vkCreateShaderModule(dev, &ci, nullptr, &layeredModule_));
    setName(handleBits(layeredModule_), VK_OBJECT_TYPE_SHADER_MODULE, "csm_depth_layered.vert");
  }
  ci.codeSize = sizeof(csm_cache_restore_vert_spv);
  ci.pCode = csm_cache_restore_vert_spv;
  CSM_VK_TRY(vkCreateShaderModule(dev, &ci, nullptr, &restoreVertexModule_));
  setName(handleBits(restoreVertexModule_), VK_OBJECT_TYPE_SHADER_MODULE, "csm_cache_restore.vert");
  ci.codeSize = sizeof(csm_cache_restore_frag_spv);
  ci.pCode = csm_cache_restore_frag_spv;
  CSM_VK_TRY(vkCreateShaderModule(dev, &ci, nullptr, &restoreFragmentModule_));
  setName(handleBits(restoreFragmentModule_), VK_OBJECT_TYPE_SHADER_MODULE,
          "csm_cache_restore.frag");
  return {};
}

Status ShadowRenderer::Impl::allocate(const VkMemoryRequirements& req, VkDeviceMemory* memory,
                                      const char* name) const {
  // Device-local when there is such a type that fits, else any type that fits.
  std::uint32_t type = UINT32_MAX;
  for (int pass = 0; pass < 2 && type == UINT32_MAX; ++pass) {
    for (std::uint32_t i = 0; i < memory_.memoryTypeCount; ++i) {
      const bool fits = (req.memoryTypeBits & (1u << i)) != 0;
      const bool local =
          (memory_.memoryTypes[i].propertyFlags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) != 0;
      if (fits && (local || pass == 1)) {
        type = i;
        break;
      }
    }
  }
  if (type == UINT32_MAX) {
    return Status(ErrorCode::kVulkan, std::string(name) + ": no memory type fits",
                  VK_ERROR_OUT_OF_DEVICE_MEMORY);
  }
  auto ai = vkInit<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
  ai.allocationSize = req.size;
  ai.memoryTypeIndex = type;
  CSM_VK_TRY(vkAllocateMemory(device_.device, &ai, nullptr, memory));
  setName(handleBits(*memory), VK_OBJECT_TYPE_DEVICE_MEMORY, name);
  return {};
}

ShadowRenderer::Impl::~Impl() {
  VkDevice dev = device_.device;
  if (dev == VK_NULL_HANDLE) return;
  // Frames the host still has in flight may use any of what follows.
  if (device_.queue != VK_NULL_HANDLE) (void)vkQueueWaitIdle(device_.queue);
  collectRetired(true);
  destroyPipelines();
  destroyImage();
  retireStaticImage();
  collectRetired(true);
  destroyMomentResources();
  vkDestroySampler(dev, wrapCompareSampler_, nullptr);
  vkDestroySampler(dev, wrapDepthSampler_, nullptr);
  vkDestroyCommandPool(dev, clearPool_, nullptr);
  vkDestroyFence(dev, clearFence_, nullptr);
  vkDestroyShaderModule(dev, vertexModule_, nullptr);
  vkDestroyShaderModule(dev, layeredModule_, nullptr);
  vkDestroyShaderModule(dev, restoreVertexModule_, nullptr);
  vkDestroyShaderModule(dev, restoreFragmentModule_, nullptr);
  vkDestroyBuffer(dev, uniformBuffer_, nullptr);
  vkFreeMemory(dev, uniformMemory_, nullptr);
  vkDestroySampler(dev, compareSampler_, nullptr);
  vkDestroySampler(dev, depthSampler_, nullptr);
  vkDestroyDescriptorPool(dev, pool_, nullptr);
  vkDestroyPipelineLayout(dev, pipelineLayout_, nullptr);
  vkDestroyPipelineLayout(dev, restoreLayout_, nullptr);
  vkDestroyDescriptorSetLayout(dev, restoreSetLayout_, nullptr);
  vkDestroyDescriptorSetLayout(dev, depthSetLayout_, nullptr);
  vkDestroyDescriptorSetLayout(dev, lightingLayout_, nullptr);
}

void ShadowRenderer::Impl::destroyImage() noexcept {
  VkDevice dev = device_.device;
  for (VkImageView& v : layerViews_) {
    vkDestroyImageView(dev, v, nullptr);
    v = VK_NULL_HANDLE;
  }
  vkDestroyImageView(dev, arrayView_, nullptr);
  vkDestroyImage(dev, image_, nullptr);
  vkFreeMemory(dev, imageMemory_, nullptr);
  destroyMomentImages(moments_);
  vkDestroyDescriptorPool(dev, lightingPool_, nullptr);
  lightingPool_ = VK_NULL_HANDLE;
  lightingSet_ = VK_NULL_HANDLE;
  arrayView_ = VK_NULL_HANDLE;
  image_ = VK_NULL_HANDLE;
  imageMemory_ = VK_NULL_HANDLE;
  layerCount_ = 0;
  resolution_ = 0;
}

void ShadowRenderer::Impl::collectRetired(bool all) noexcept {
  std::size_t kept = 0;
  for (Retired& r : retired_) {
    if (!all && records_ < r.afterRecord + device_.framesInFlight) {
      retired_[kept++] = r;
      continue;
    }
    destroyNow(r);
  }
  retired_.resize(kept);
}

void ShadowRenderer::Impl::destroyPipelines() noexcept {
  vkDestroyPipeline(device_.device, pipeline_, nullptr);
  vkDestroyPipeline(device_.device, layeredPipeline_, nullptr);
  vkDestroyPipeline(device_.device, restorePipeline_, nullptr);
  pipeline_ = VK_NULL_HANDLE;
  layeredPipeline_ = VK_NULL_HANDLE;
  restorePipeline_ = VK_NULL_HANDLE;
  destroyThinPipeline();
}

// ---------------------------------------------------------------------------------------------
// The public interface: each call forwards to the Impl (shadow_renderer_impl.hpp).

ShadowRenderer::ShadowRenderer() : impl_(std::make_unique<Impl>()) {}
ShadowRenderer::~ShadowRenderer() = default;

Status ShadowRenderer::update(const ShadowSettings& settings, const RendererOptions& options) {
  return impl_->update(settings, options);
}
Status ShadowRenderer::update(const ShadowSettings& settings) {
  return impl_->update(settings);
}
void ShadowRenderer::failNextUpdateAt(UpdateStep step) noexcept {
  impl_->failNextUpdateAt(step);
}
Status ShadowRenderer::prepare(VkCommandBuffer cmd) {
  return impl_->prepare(cmd);
}
bool ShadowRenderer::needsPrepare() const noexcept {
  return impl_->needsPrepare();
}
void ShadowRenderer::setDebugMode(DebugMode mode) noexcept {
  impl_->setDebugMode(mode);
}

float ShadowRenderer::momentAnisotropy() const noexcept {
  return impl_->device_.maxSamplerAnisotropy;
}

DebugMode ShadowRenderer::debugMode() const noexcept {
  return impl_->debugMode();
}
void ShadowRenderer::setCascadeHook(CascadeHook hook) {
  impl_->setCascadeHook(std::move(hook));
}
Status ShadowRenderer::recordShadowPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                                        const CasterList& casters, const CullResult* visible) {
  return impl_->recordShadowPass(cmd, frame, casters, visible);
}
Status ShadowRenderer::recordShadowPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                                        const CascadeDrawCallback& draw,
                                        const CullResult* visible) {
  return impl_->recordShadowPass(cmd, frame, draw, visible);
}
bool ShadowRenderer::ready() const noexcept {
  return impl_->ready();
}
VkImageView ShadowRenderer::arrayView() const noexcept {
  return impl_->arrayView();
}
VkSampler ShadowRenderer::comparisonSampler() const noexcept {
  return impl_->comparisonSampler();
}
VkSampler ShadowRenderer::depthSampler() const noexcept {
  return impl_->depthSampler();
}
float ShadowRenderer::thinMarginTexels() const noexcept {
  return impl_->thinMarginTexels();
}
VkImage ShadowRenderer::image() const noexcept {
  return impl_->image();
}
VkFormat ShadowRenderer::depthFormat() const noexcept {
  return impl_->depthFormat();
}
RenderMode ShadowRenderer::renderMode() const noexcept {
  return impl_->renderMode();
}
const CsmUniforms& ShadowRenderer::uniforms() const noexcept {
  return impl_->uniforms();
}
VkBuffer ShadowRenderer::uniformBuffer() const noexcept {
  return impl_->uniformBuffer();
}
void ShadowRenderer::applyCacheWindows(CascadeFrame& frame) {
  impl_->applyCacheWindows(frame);
}
const CachePlan& ShadowRenderer::cachePlan() const noexcept {
  return impl_->cachePlan();
}
Status ShadowRenderer::invalidate(const AabbWs& boxWs) {
  return impl_->invalidate(boxWs);
}
void ShadowRenderer::invalidateAll() noexcept {
  impl_->invalidateAll();
}
void ShadowRenderer::setReceiverTiles(std::optional<ReceiverTileMarks> marks) noexcept {
  impl_->setReceiverTiles(std::move(marks));
}
const std::array<CascadeCacheStats, kMaxCascades>& ShadowRenderer::cacheStats() const noexcept {
  return impl_->cacheStats();
}
VkDeviceSize ShadowRenderer::cacheBytes() const noexcept {
  return impl_->cacheBytes();
}
VkImage ShadowRenderer::staticImage() const noexcept {
  return impl_->staticImage();
}
VkImage ShadowRenderer::momentImage() const noexcept {
  return impl_->moments_.image;
}
std::uint32_t ShadowRenderer::momentLevels() const noexcept {
  return impl_->moments_.levels;
}
VkFormat ShadowRenderer::momentFormat() const noexcept {
  return impl_->moments_.format;
}
VkDeviceSize ShadowRenderer::momentBytes() const noexcept {
  if (impl_->moments_.image == VK_NULL_HANDLE) return 0;
  const VkFormat format = impl_->moments_.format;
  return momentImageBytes(impl_->settings_,
                          format != VK_FORMAT_UNDEFINED && format != VK_FORMAT_R32G32B32A32_SFLOAT);
}
VkDescriptorSetLayout ShadowRenderer::lightingSetLayout() const noexcept {
  return impl_->lightingSetLayout();
}
VkDescriptorSet ShadowRenderer::lightingSet() const noexcept {
  return impl_->lightingSet();
}
Status ShadowRenderer::writeLightingSet(VkDescriptorSet set) const {
  return impl_->writeLightingSet(set);
}

}  // namespace csm::vk
