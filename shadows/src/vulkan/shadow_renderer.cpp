// The cascades' depth image, the depth pass and the lighting descriptors.
#include "csm/vulkan/shadow_renderer.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <string>

#include <csm_shaders/csm_depth.vert.spv.h>
#include <csm_shaders/csm_depth_layered.vert.spv.h>

#include "vk_util.hpp"

namespace csm::vk {

namespace {

glm::mat4 modelCameraRelative(const glm::dvec3& translationWs, const glm::mat3& linearWs,
                              const glm::dvec3& cameraWs) {
  glm::mat4 m(linearWs);
  m[3] = glm::vec4(glm::vec3(translationWs - cameraWs), 1.0f);
  return m;
}

// Model space -> the cascade's shadow clip space, composed in double about the snapped box
// centre: p_clip = S (B^T (R p + T - C)) + o. Nothing here depends on the camera, so a camera
// that moves less than a texel re-renders a bit-identical map, and one that moves further
// shifts it by whole texels (C moves on the world-anchored grid). A camera-relative composition
// would re-round every caster differently each frame and flip coverage of texels that a caster
// edge crosses within float noise of their centre: shimmer.
glm::mat4 modelToShadowClip(const Cascade& c, const glm::dmat3& basisWs,
                            const glm::dvec3& translationWs, const glm::mat3& linearWs) {
  const glm::dvec3 scale(1.0 / c.halfExtentLs.x, 1.0 / c.halfExtentLs.y,
                         1.0 / (c.depthFarLs - c.depthNearLs));
  const glm::dmat3 toLight = glm::transpose(basisWs);
  const glm::dmat3 linear = toLight * glm::dmat3(linearWs);
  const glm::dvec3 t = toLight * (translationWs - c.boxCenterWs) - glm::dvec3(0, 0, c.depthNearLs);
  return scaledAffine(linear, t, scale);
}

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

// Every instance of a caster list valid (validateCasters, unless the caller did) and every
// visible index in range.
Status checkCasterList(const CascadeFrame& frame, const CasterList& casters,
                       const CullResult* visible, bool instancesValidated) {
  const std::size_t instanceCount = casters.instances.size();
  if (!instancesValidated) {
    if (Status s = validateCasters(casters.meshes, casters.instances); !s.ok()) return s;
  }
  if (visible) {
    for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
      if (frame.cascades[c].empty) continue;
      for (std::size_t k = 0; k < visible->visible[c].size(); ++k) {
        if (visible->visible[c][k] >= instanceCount) {
          return Status(ErrorCode::kIndexOutOfRange,
                        fmt("visible[%u][%zu] = %u is out of range: allowed [0, %zu)", c, k,
                            visible->visible[c][k], instanceCount));
        }
      }
    }
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

void CascadeDrawContext::setTransform(const glm::dvec3& translationWs,
                                      const glm::mat3& linearWs) const {
  glm::mat4 m(1.0f);
  if (frame != nullptr && anchored) {
    const glm::dmat3 toLight = glm::transpose(frame->lightBasisWs);
    m = scaledAffine(toLight * glm::dmat3(linearWs), toLight * translationWs - originLs,
                     clipPerMetre);
  } else if (frame != nullptr) {
    m = modelToShadowClip(frame->cascades[cascade], frame->lightBasisWs, translationWs, linearWs);
  }
  const DepthPushPerLayer push{m, cascade};
  vkCmdPushConstants(cmd, pipelineLayout, VK_SHADER_STAGE_VERTEX_BIT, 0, CSM_DEPTH_PUSH_SIZE,
                     &push);
}

// ---------------------------------------------------------------------------------------------
// Creation and destruction

std::unique_ptr<ShadowRenderer> ShadowRenderer::create(const DeviceInfo& device,
                                                       const VertexLayout& layout, Status* status) {
  std::unique_ptr<ShadowRenderer> r(new ShadowRenderer());
  Status s = r->init(device, layout);
  if (status) *status = s;
  if (!s.ok()) return nullptr;
  return r;
}

void ShadowRenderer::setName(std::uint64_t handle, VkObjectType type, const char* name) const {
  setObjectName(setObjectName_, device_.device, handle, type, name);
}

Status ShadowRenderer::init(const DeviceInfo& device, const VertexLayout& layout) {
  Status s = checkCreateArgs(device, layout);
  if (!s.ok()) return s;
  device_ = device;
  layout_ = layout;
  vkGetPhysicalDeviceProperties(device.physicalDevice, &properties_);
  vkGetPhysicalDeviceMemoryProperties(device.physicalDevice, &memory_);
  loadDebugUtils();
  s = createSetLayouts();
  if (s.ok()) s = createPipelineLayout();
  if (s.ok()) s = createDepthSet();
  if (s.ok()) s = createClearResources();
  if (s.ok()) s = createSamplers();
  if (s.ok()) s = createUniformBuffer();
  if (s.ok()) s = createShaderModules();
  return s;
}

// The debug-utils entry points (object names, pass labels) when the host enabled them.
void ShadowRenderer::loadDebugUtils() {
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
Status ShadowRenderer::createSetLayouts() {
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
    VkDescriptorSetLayoutBinding b[3]{};
    b[0] = {CSM_BINDING_UNIFORMS, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, stages, nullptr};
    b[1] = {CSM_BINDING_SHADOW_MAP, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, stages, nullptr};
    b[2] = {CSM_BINDING_SHADOW_DEPTH, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, stages,
            nullptr};
    auto ci = vkInit<VkDescriptorSetLayoutCreateInfo>(
        VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
    ci.bindingCount = 3;
    ci.pBindings = b;
    CSM_VK_TRY(vkCreateDescriptorSetLayout(dev, &ci, nullptr, &lightingLayout_));
    setName(handleBits(lightingLayout_), VK_OBJECT_TYPE_DESCRIPTOR_SET_LAYOUT,
            "csm lighting set layout");
  }
  return {};
}

// The depth pipelines' layout: the depth set and the push constants (DepthPushPerLayer or
// DepthPushLayered, CSM_DEPTH_PUSH_SIZE bytes either way).
Status ShadowRenderer::createPipelineLayout() {
  VkDevice dev = device_.device;
  VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT, 0, CSM_DEPTH_PUSH_SIZE};
  auto ci = vkInit<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  ci.setLayoutCount = 1;
  ci.pSetLayouts = &depthSetLayout_;
  ci.pushConstantRangeCount = 1;
  ci.pPushConstantRanges = &range;
  CSM_VK_TRY(vkCreatePipelineLayout(dev, &ci, nullptr, &pipelineLayout_));
  setName(handleBits(pipelineLayout_), VK_OBJECT_TYPE_PIPELINE_LAYOUT, "csm depth pipeline layout");
  return {};
}

Status ShadowRenderer::createDepthSet() {
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
Status ShadowRenderer::createClearResources() {
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
Status ShadowRenderer::createSamplers() {
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
Status ShadowRenderer::createUniformBuffer() {
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
Status ShadowRenderer::createShaderModules() {
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
  return {};
}

Status ShadowRenderer::allocate(const VkMemoryRequirements& req, VkDeviceMemory* memory,
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

ShadowRenderer::~ShadowRenderer() {
  VkDevice dev = device_.device;
  if (dev == VK_NULL_HANDLE) return;
  // Frames the host still has in flight may use any of what follows.
  if (device_.queue != VK_NULL_HANDLE) (void)vkQueueWaitIdle(device_.queue);
  collectRetired(true);
  destroyPipelines();
  destroyImage();
  retireStaticImage();
  collectRetired(true);
  vkDestroySampler(dev, wrapCompareSampler_, nullptr);
  vkDestroySampler(dev, wrapDepthSampler_, nullptr);
  vkDestroyCommandPool(dev, clearPool_, nullptr);
  vkDestroyFence(dev, clearFence_, nullptr);
  vkDestroyShaderModule(dev, vertexModule_, nullptr);
  vkDestroyShaderModule(dev, layeredModule_, nullptr);
  vkDestroyBuffer(dev, uniformBuffer_, nullptr);
  vkFreeMemory(dev, uniformMemory_, nullptr);
  vkDestroySampler(dev, compareSampler_, nullptr);
  vkDestroySampler(dev, depthSampler_, nullptr);
  vkDestroyDescriptorPool(dev, pool_, nullptr);
  vkDestroyPipelineLayout(dev, pipelineLayout_, nullptr);
  vkDestroyDescriptorSetLayout(dev, depthSetLayout_, nullptr);
  vkDestroyDescriptorSetLayout(dev, lightingLayout_, nullptr);
}

void ShadowRenderer::destroyImage() noexcept {
  VkDevice dev = device_.device;
  for (VkImageView& v : layerViews_) {
    vkDestroyImageView(dev, v, nullptr);
    v = VK_NULL_HANDLE;
  }
  vkDestroyImageView(dev, arrayView_, nullptr);
  vkDestroyImage(dev, image_, nullptr);
  vkFreeMemory(dev, imageMemory_, nullptr);
  vkDestroyDescriptorPool(dev, lightingPool_, nullptr);
  lightingPool_ = VK_NULL_HANDLE;
  lightingSet_ = VK_NULL_HANDLE;
  arrayView_ = VK_NULL_HANDLE;
  image_ = VK_NULL_HANDLE;
  imageMemory_ = VK_NULL_HANDLE;
  layerCount_ = 0;
  resolution_ = 0;
}

void ShadowRenderer::collectRetired(bool all) noexcept {
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

void ShadowRenderer::destroyPipelines() noexcept {
  vkDestroyPipeline(device_.device, pipeline_, nullptr);
  vkDestroyPipeline(device_.device, layeredPipeline_, nullptr);
  pipeline_ = VK_NULL_HANDLE;
  layeredPipeline_ = VK_NULL_HANDLE;
  destroyThinPipeline();
}

// ---------------------------------------------------------------------------------------------
// Settings

Status ShadowRenderer::checkFormat(VkFormat format) const {
  if (format != VK_FORMAT_D32_SFLOAT && format != VK_FORMAT_D16_UNORM) {
    return Status(ErrorCode::kUnsupportedFormat,
                  fmt("options.depthFormat = %d is invalid: allowed VK_FORMAT_D32_SFLOAT (%d) or "
                      "VK_FORMAT_D16_UNORM (%d)",
                      int(format), int(VK_FORMAT_D32_SFLOAT), int(VK_FORMAT_D16_UNORM)));
  }
  auto props3 = vkInit<VkFormatProperties3>(VK_STRUCTURE_TYPE_FORMAT_PROPERTIES_3);
  auto props = vkInit<VkFormatProperties2>(VK_STRUCTURE_TYPE_FORMAT_PROPERTIES_2, &props3);
  vkGetPhysicalDeviceFormatProperties2(device_.physicalDevice, format, &props);
  // Linear filtering of a comparison sampler needs only SAMPLED_IMAGE_DEPTH_COMPARISON
  // (FILTER_LINEAR governs non-comparison sampling; lavapipe does not report it for depth).
  const VkFormatFeatureFlags2 need = VK_FORMAT_FEATURE_2_DEPTH_STENCIL_ATTACHMENT_BIT |
                                     VK_FORMAT_FEATURE_2_SAMPLED_IMAGE_BIT |
                                     VK_FORMAT_FEATURE_2_SAMPLED_IMAGE_DEPTH_COMPARISON_BIT;
  if ((props3.optimalTilingFeatures & need) != need) {
    return Status(ErrorCode::kUnsupportedFormat,
                  fmt("options.depthFormat = %d is not supported by this device for depth "
                      "attachment + linear comparison sampling",
                      int(format)));
  }
  return {};
}

// update()'s checks of settings and options against each other and the device; fills the
// render mode the renderer will use (kAuto resolved).
Status ShadowRenderer::resolveOptions(const ShadowSettings& settings,
                                      const RendererOptions& options, RenderMode* resolved) const {
  if (auto e = csm::validate(settings)) {
    return Status(ErrorCode::kInvalidArgument, e->message());
  }
  Status s = checkFormat(options.depthFormat);
  if (!s.ok()) return s;
  const VkPhysicalDeviceLimits& lim = properties_.limits;
  const std::uint32_t deviceSide =
      std::min({lim.maxImageDimension2D, lim.maxFramebufferWidth, lim.maxFramebufferHeight,
                lim.maxViewportDimensions[0], lim.maxViewportDimensions[1]});
  const std::uint32_t maxSide =
      device_.maxResolution != 0 ? std::min(deviceSide, device_.maxResolution) : deviceSide;
  if (settings.resolution > maxSide) {
    return Status(
        ErrorCode::kDeviceLimit,
        fmt("settings.resolution = %u is invalid: allowed at most %u (%s)", settings.resolution,
            maxSide, maxSide < deviceSide ? "DeviceInfo::maxResolution" : "the device's limit"));
  }
  if (settings.cascadeCount > lim.maxImageArrayLayers) {
    return Status(ErrorCode::kDeviceLimit,
                  fmt("settings.cascadeCount = %u is invalid: this device allows at most %u layers",
                      settings.cascadeCount, lim.maxImageArrayLayers));
  }
  if (options.renderMode != RenderMode::kPerLayer && options.renderMode != RenderMode::kLayered &&
      options.renderMode != RenderMode::kAuto) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("options.renderMode = %d is invalid: allowed kPerLayer (0), kLayered (1), "
                      "kAuto (2)",
                      int(options.renderMode)));
  }
  RenderMode mode = options.renderMode;
  if (mode == RenderMode::kAuto) {
    // Stabilised cascades: per-layer, drawn in world-anchored windows, so the depth is the same
    // with the cache on or off and under sub-texel camera motion (the layered pass composes its
    // transform about the camera: on a GPU it differed from the cached layers in 0.02% of the
    // pixels; shadows/docs/cache.md). On an NVIDIA H200 both modes cost the same (0.91-1.03x,
    // README). Unstabilised: layered on a GPU; CPU rasterisers pay per draw, not per pass, so
    // per-layer there (measured faster on lavapipe).
    const bool gpu = properties_.deviceType != VK_PHYSICAL_DEVICE_TYPE_CPU;
    mode = !settings.stabilize && gpu && device_.shaderOutputLayerEnabled &&
                   settings.cascadeCount <= lim.maxFramebufferLayers
               ? RenderMode::kLayered
               : RenderMode::kPerLayer;
  }
  if (mode == RenderMode::kLayered) {
    if (!device_.shaderOutputLayerEnabled) {
      return Status(ErrorCode::kInvalidArgument,
                    "options.renderMode = kLayered needs shaderOutputLayer "
                    "(DeviceInfo::shaderOutputLayerEnabled)");
    }
    if (settings.cascadeCount > lim.maxFramebufferLayers) {
      return Status(ErrorCode::kDeviceLimit,
                    fmt("settings.cascadeCount = %u is invalid for kLayered: this device allows "
                        "at most %u framebuffer layers",
                        settings.cascadeCount, lim.maxFramebufferLayers));
    }
  }
  for (std::uint32_t c = 0; c < kMaxCascades; ++c) {
    if (options.cascadeLod[c] >= kMaxCasterLods) {
      return Status(ErrorCode::kInvalidArgument,
                    fmt("options.cascadeLod[%u] = %u is invalid: allowed [0, %u)", c,
                        options.cascadeLod[c], kMaxCasterLods));
    }
  }
  if (!(options.lodMaxErrorTexels >= 0.0f && options.lodMaxErrorTexels <= 64.0f)) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("options.lodMaxErrorTexels = %g is invalid: allowed [0, 64] (0 = off)",
                      double(options.lodMaxErrorTexels)));
  }
  if (s = checkThinOptions(options); !s.ok()) return s;
  if ((options.cullMode & ~VkCullModeFlags(VK_CULL_MODE_FRONT_AND_BACK)) != 0) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("options.cullMode = %u is invalid: allowed VK_CULL_MODE_* flags",
                      unsigned(options.cullMode)));
  }

  if (s = checkCacheOptions(settings, options); !s.ok()) return s;
  if (options.cache && !settings.stabilize) {
    return Status(ErrorCode::kInvalidArgument,
                  "options.cache = true needs settings.stabilize = true (cached texels must be "
                  "fixed in the world: boxes snapped to whole texels)");
  }
  if (options.cache && mode != RenderMode::kPerLayer) {
    if (options.renderMode == RenderMode::kAuto) {
      mode = RenderMode::kPerLayer;  // the cache renders scissored regions per layer
    } else {
      return Status(ErrorCode::kInvalidArgument,
                    "options.cache = true needs options.renderMode = kPerLayer or kAuto");
    }
  }
  *resolved = mode;
  return {};
}

// update() builds every object the new settings need before installing any (all-or-nothing):
// the builds may fail (out of memory, a pipeline the driver refuses), the installs cannot.
Status ShadowRenderer::update(const ShadowSettings& settings, const RendererOptions& options) {
  RenderMode mode = RenderMode::kPerLayer;
  Status s = resolveOptions(settings, options, &mode);
  if (!s.ok()) return s;
  // Windowed addressing (stabilised, per-layer) samples through the REPEAT samplers.
  const bool wrap = windowedFor(settings, options, mode);
  const bool newImage = image_ == VK_NULL_HANDLE || settings.resolution != resolution_ ||
                        settings.cascadeCount != layerCount_ ||
                        options.depthFormat != options_.depthFormat ||
                        options.cache != options_.cache || wrap != wrapSampling_;
  const bool newPipelines = !pipelinesBuilt_ || options.depthFormat != options_.depthFormat;
  const ThinPlan thin = planThinPipeline(settings.resolution, options);

  // Build.
  Retired pipelines, image, staticImage, thinPipelines;
  VkDescriptorSet lightingSet = VK_NULL_HANDLE;
  VkDeviceSize staticBytes = 0;
  const UpdateStep failAt = failAt_;
  failAt_ = UpdateStep::kNone;
  auto build = [&](UpdateStep step, auto&& make) -> Status {
    if (failAt == step) {
      return Status(ErrorCode::kVulkan,
                    fmt("update: failure injected at step %d (failNextUpdateAt)", int(step)),
                    VK_ERROR_OUT_OF_DEVICE_MEMORY);
    }
    return make();
  };
  if (newPipelines) {
    s = build(UpdateStep::kPipelines,
              [&] { return buildPipelines(options.depthFormat, pipelines); });
  }
  if (s.ok() && newImage) {
    s = build(UpdateStep::kImage,
              [&] { return buildImage(settings, options.depthFormat, image, lightingSet); });
  }
  if (s.ok() && newImage && options.cache) {
    s = build(UpdateStep::kStaticImage, [&] {
      return buildStaticImage(settings, options.depthFormat, staticImage, staticBytes);
    });
  }
  if (s.ok() && thin.build) {
    s = build(UpdateStep::kThinPipelines, [&] {
      return buildThinPipelines(settings.resolution, options, thin.conservative, thinPipelines);
    });
  }
  if (!s.ok()) {
    // Nothing was installed and nothing built was ever recorded: destroyed now.
    for (Retired* r : {&pipelines, &image, &staticImage, &thinPipelines}) destroyNow(*r);
    return s;
  }

  // Install (nothing below fails). What is replaced is retired: nothing waits for the GPU.
  if (newPipelines) installPipelines(pipelines);
  // Cached cascades: what changes the static depth without a new image re-renders it.
  if (!newImage && options.cache &&
      (settings.depthBiasConstant != settings_.depthBiasConstant ||
       settings.depthBiasSlope != settings_.depthBiasSlope ||
       settings.minCasterTexels != settings_.minCasterTexels ||
       options.cullMode != options_.cullMode || options.frontFace != options_.frontFace ||
       options.cullClosedCasters != options_.cullClosedCasters ||
       options.cascadeLod != options_.cascadeLod ||
       options.lodMaxErrorTexels != options_.lodMaxErrorTexels ||
       options.thinCasterWidenTexels != options_.thinCasterWidenTexels)) {
    invalidateAll();
  }
  if (newImage) {
    wrapSampling_ = wrap;
    installImage(image, lightingSet, settings);
    pendingClear_ = true;
    // A new image (resolution, count, format, cache) invalidates every cached cascade.
    retireStaticImage();
    windows_ = {};
    shown_ = {};
    if (options.cache) installStaticImage(staticImage, staticBytes);
  }
  installThinPipelines(thin, thinPipelines, settings.resolution, options);
  settings_ = settings;
  options_ = options;
  resolvedMode_ = mode;
  // The clear of a new image: on failure it stays pending (prepare() or the next shadow pass
  // records it) and the error is returned with the new settings installed.
  if (pendingClear_ && device_.queue != VK_NULL_HANDLE) return submitClear();
  return {};
}

void ShadowRenderer::destroyNow(Retired& objects) noexcept {
  VkDevice dev = device_.device;
  for (VkImageView& v : objects.views) {
    vkDestroyImageView(dev, v, nullptr);
    v = VK_NULL_HANDLE;
  }
  vkDestroyImage(dev, objects.image, nullptr);
  vkFreeMemory(dev, objects.memory, nullptr);
  vkDestroyDescriptorPool(dev, objects.pool, nullptr);
  for (VkPipeline& p : objects.pipelines) {
    vkDestroyPipeline(dev, p, nullptr);
    p = VK_NULL_HANDLE;
  }
  objects.image = VK_NULL_HANDLE;
  objects.memory = VK_NULL_HANDLE;
  objects.pool = VK_NULL_HANDLE;
}

// The one-time clear of a new image: depth 1 (lit) in every layer, then the sampled layout, so
// a lighting pass can sample it before the first shadow pass. The first time, the uniform block
// is zeroed too (no cascades: csm.glsl reads every receiver as lit).
void ShadowRenderer::recordClear(VkCommandBuffer cmd) {
  VkImageMemoryBarrier2 b[2] = {
      vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2),
      vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2)};
  b[0].srcStageMask = VK_PIPELINE_STAGE_2_NONE;
  b[0].dstStageMask = VK_PIPELINE_STAGE_2_CLEAR_BIT;
  b[0].dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  b[0].oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  b[0].newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  b[0].srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b[0].dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b[0].image = image_;
  b[0].subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, layerCount_};
  b[1] = b[0];
  b[1].srcStageMask = VK_PIPELINE_STAGE_2_CLEAR_BIT;
  b[1].srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  b[1].dstStageMask = options_.consumerStages;
  b[1].dstAccessMask = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  b[1].oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  b[1].newLayout = sampledLayout();
  auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &b[0];
  vkCmdPipelineBarrier2(cmd, &dep);
  const VkClearDepthStencilValue one{1.0f, 0};
  const VkImageSubresourceRange range{VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, layerCount_};
  vkCmdClearDepthStencilImage(cmd, image_, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &one, 1, &range);
  auto buf = vkInit<VkBufferMemoryBarrier2>(VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2);
  if (!uniformsCleared_) {
    vkCmdFillBuffer(cmd, uniformBuffer_, 0, VK_WHOLE_SIZE, 0u);
    buf.srcStageMask = VK_PIPELINE_STAGE_2_CLEAR_BIT;
    buf.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    buf.dstStageMask = options_.consumerStages | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT;
    buf.dstAccessMask = VK_ACCESS_2_UNIFORM_READ_BIT;
    buf.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    buf.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    buf.buffer = uniformBuffer_;
    buf.size = VK_WHOLE_SIZE;
    dep.bufferMemoryBarrierCount = 1;
    dep.pBufferMemoryBarriers = &buf;
    uniformsCleared_ = true;
  }
  dep.pImageMemoryBarriers = &b[1];
  vkCmdPipelineBarrier2(cmd, &dep);
  pendingClear_ = false;
}

Status ShadowRenderer::submitClear() {
  VkDevice dev = device_.device;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  auto ai = vkInit<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
  ai.commandPool = clearPool_;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  CSM_VK_TRY(vkAllocateCommandBuffers(dev, &ai, &cmd));
  auto bi = vkInit<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  VkResult r = vkBeginCommandBuffer(cmd, &bi);
  if (r == VK_SUCCESS) {
    recordClear(cmd);
    r = vkEndCommandBuffer(cmd);
  }
  if (r == VK_SUCCESS) {
    auto si = vkInit<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
    r = vkQueueSubmit(device_.queue, 1, &si, clearFence_);
    if (r == VK_SUCCESS) r = vkWaitForFences(dev, 1, &clearFence_, VK_TRUE, UINT64_MAX);
    if (r == VK_SUCCESS) r = vkResetFences(dev, 1, &clearFence_);
  }
  vkFreeCommandBuffers(dev, clearPool_, 1, &cmd);
  if (r != VK_SUCCESS) {
    pendingClear_ = true;  // prepare() can still record it
    return vkError(r, "the one-time clear of the shadow map (DeviceInfo::queue)");
  }
  return {};
}

Status ShadowRenderer::prepare(VkCommandBuffer cmd) {
  if (image_ == VK_NULL_HANDLE) {
    return Status(ErrorCode::kWrongOrder, "prepare before a successful update()");
  }
  if (cmd == VK_NULL_HANDLE) return Status(ErrorCode::kInvalidArgument, "cmd is VK_NULL_HANDLE");
  if (pendingClear_) recordClear(cmd);
  return {};
}

Status ShadowRenderer::buildImage(const ShadowSettings& settings, VkFormat format, Retired& out,
                                  VkDescriptorSet& lightingSet) {
  VkDevice dev = device_.device;
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView arrayView = VK_NULL_HANDLE;
  VkImageView layerViews[kMaxCascades] = {};
  auto cleanup = [&] {
    for (VkImageView v : layerViews) vkDestroyImageView(dev, v, nullptr);
    vkDestroyImageView(dev, arrayView, nullptr);
    vkDestroyImage(dev, image, nullptr);
    vkFreeMemory(dev, memory, nullptr);
  };
  auto fail = [&](Status st) {
    cleanup();
    return st;
  };

  auto ci = vkInit<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
  ci.imageType = VK_IMAGE_TYPE_2D;
  ci.format = format;
  ci.extent = {settings.resolution, settings.resolution, 1};
  ci.mipLevels = 1;
  ci.arrayLayers = settings.cascadeCount;
  ci.samples = VK_SAMPLE_COUNT_1_BIT;
  ci.tiling = VK_IMAGE_TILING_OPTIMAL;
  ci.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
             VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  ci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  ci.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkResult r = vkCreateImage(dev, &ci, nullptr, &image);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImage(shadow map)"));
  setName(handleBits(image), VK_OBJECT_TYPE_IMAGE, "csm shadow map");
  VkMemoryRequirements req{};
  vkGetImageMemoryRequirements(dev, image, &req);
  Status s = allocate(req, &memory, "csm shadow map memory");
  if (!s.ok()) return fail(s);
  r = vkBindImageMemory(dev, image, memory, 0);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkBindImageMemory(shadow map)"));

  auto vi = vkInit<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
  vi.image = image;
  vi.viewType = VK_IMAGE_VIEW_TYPE_2D_ARRAY;
  vi.format = format;
  vi.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, settings.cascadeCount};
  r = vkCreateImageView(dev, &vi, nullptr, &arrayView);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImageView(shadow map array)"));
  setName(handleBits(arrayView), VK_OBJECT_TYPE_IMAGE_VIEW, "csm shadow map array view");
  for (std::uint32_t i = 0; i < settings.cascadeCount; ++i) {
    vi.viewType = VK_IMAGE_VIEW_TYPE_2D;
    vi.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, i, 1};
    r = vkCreateImageView(dev, &vi, nullptr, &layerViews[i]);
    if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImageView(shadow map layer)"));
    const std::string name = "csm shadow map layer " + std::to_string(i);
    setName(handleBits(layerViews[i]), VK_OBJECT_TYPE_IMAGE_VIEW, name.c_str());
  }
  // The lighting set lives with the image: command buffers recorded with the old set stay valid.
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
  {
    VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
                                     {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 2}};
    auto pci = vkInit<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
    pci.maxSets = 1;
    pci.poolSizeCount = 2;
    pci.pPoolSizes = sizes;
    r = vkCreateDescriptorPool(dev, &pci, nullptr, &pool);
    if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateDescriptorPool(csm lighting)"));
    setName(handleBits(pool), VK_OBJECT_TYPE_DESCRIPTOR_POOL, "csm lighting pool");
    auto ai = vkInit<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
    ai.descriptorPool = pool;
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &lightingLayout_;
    r = vkAllocateDescriptorSets(dev, &ai, &set);
    if (r != VK_SUCCESS) {
      vkDestroyDescriptorPool(dev, pool, nullptr);
      return fail(vkError(r, "vkAllocateDescriptorSets(csm lighting)"));
    }
    setName(handleBits(set), VK_OBJECT_TYPE_DESCRIPTOR_SET, "csm lighting set");
  }

  out.image = image;
  out.memory = memory;
  out.views[0] = arrayView;
  std::copy(std::begin(layerViews), std::end(layerViews), out.views + 1);
  out.pool = pool;
  lightingSet = set;
  return {};
}

void ShadowRenderer::installImage(Retired& built, VkDescriptorSet lightingSet,
                                  const ShadowSettings& settings) noexcept {
  if (image_ != VK_NULL_HANDLE) {
    Retired old;
    old.afterRecord = records_;
    old.image = image_;
    old.memory = imageMemory_;
    old.views[0] = arrayView_;
    std::copy(std::begin(layerViews_), std::end(layerViews_), old.views + 1);
    old.pool = lightingPool_;
    retired_.push_back(old);
  }
  lightingPool_ = built.pool;
  lightingSet_ = lightingSet;
  image_ = built.image;
  imageMemory_ = built.memory;
  arrayView_ = built.views[0];
  std::copy(built.views + 1, built.views + 1 + kMaxCascades, std::begin(layerViews_));
  layerCount_ = settings.cascadeCount;
  resolution_ = settings.resolution;
  built = Retired{};
  (void)writeLightingSet(lightingSet_);  // fails only without an image or set: both are here
}

Status ShadowRenderer::buildPipelines(VkFormat format, Retired& out) {
  VkPipeline pipes[2] = {VK_NULL_HANDLE, VK_NULL_HANDLE};
  for (int layered = 0; layered < 2; ++layered) {
    if (layered == 1 && layeredModule_ == VK_NULL_HANDLE) break;
    auto stage = vkInit<VkPipelineShaderStageCreateInfo>(
        VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
    stage.stage = VK_SHADER_STAGE_VERTEX_BIT;
    stage.module = layered ? layeredModule_ : vertexModule_;
    stage.pName = "main";
    DepthPipelineDesc desc;
    desc.stages = &stage;
    desc.stageCount = 1;
    desc.vertexLayout = layout_;
    desc.depthClamp = device_.depthClampEnabled;
    desc.layout = pipelineLayout_;
    desc.depthFormat = format;
    const VkResult r =
        createDepthPipeline(device_.device, device_.pipelineCache, desc, &pipes[layered]);
    if (r != VK_SUCCESS) {
      vkDestroyPipeline(device_.device, pipes[0], nullptr);
      return vkError(r, "vkCreateGraphicsPipelines(csm depth)");
    }
    setName(handleBits(pipes[layered]), VK_OBJECT_TYPE_PIPELINE,
            layered ? "csm depth pipeline (layered)" : "csm depth pipeline");
  }
  out.pipelines[0] = pipes[0];
  out.pipelines[1] = pipes[1];
  return {};
}

void ShadowRenderer::installPipelines(Retired& built) noexcept {
  if (pipelinesBuilt_) {
    Retired old;
    old.afterRecord = records_;
    old.pipelines[0] = pipeline_;
    old.pipelines[1] = layeredPipeline_;
    retired_.push_back(old);
  }
  pipeline_ = built.pipelines[0];
  layeredPipeline_ = built.pipelines[1];
  pipelinesBuilt_ = true;
  built = Retired{};
}

Status ShadowRenderer::writeLightingSet(VkDescriptorSet set) const {
  if (image_ == VK_NULL_HANDLE) {
    return Status(ErrorCode::kWrongOrder, "writeLightingSet before a successful update()");
  }
  if (set == VK_NULL_HANDLE) return Status(ErrorCode::kInvalidArgument, "set is VK_NULL_HANDLE");
  VkDescriptorBufferInfo bi{uniformBuffer_, 0, sizeof(CsmUniforms)};
  VkDescriptorImageInfo compare{wrapSampling_ ? wrapCompareSampler_ : compareSampler_, arrayView_,
                                sampledLayout()};
  VkDescriptorImageInfo depth{wrapSampling_ ? wrapDepthSampler_ : depthSampler_, arrayView_,
                              sampledLayout()};
  VkWriteDescriptorSet w[3]{};
  for (auto& x : w) {
    x.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    x.dstSet = set;
    x.descriptorCount = 1;
  }
  w[0].dstBinding = CSM_BINDING_UNIFORMS;
  w[0].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  w[0].pBufferInfo = &bi;
  w[1].dstBinding = CSM_BINDING_SHADOW_MAP;
  w[1].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  w[1].pImageInfo = &compare;
  w[2].dstBinding = CSM_BINDING_SHADOW_DEPTH;
  w[2].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  w[2].pImageInfo = &depth;
  vkUpdateDescriptorSets(device_.device, 3, w, 0, nullptr);
  return {};
}

// ---------------------------------------------------------------------------------------------
// The pass. Its resources: the depth image (all layers) written as a depth attachment through
// the per-layer views (or the array view when layered), the uniform buffer written by
// vkCmdUpdateBuffer; its barriers: consumers' reads -> transfer/attachment writes at the start,
// attachment/transfer writes -> consumers' reads (SHADER_READ_ONLY_OPTIMAL) at the end.

Status ShadowRenderer::checkFrame(const CascadeFrame& frame) const {
  if (image_ == VK_NULL_HANDLE) {
    return Status(ErrorCode::kWrongOrder, "recordShadowPass before a successful update()");
  }
  if (static_cast<std::uint32_t>(uniformOptions_.debugMode) >= CSM_DEBUG_COUNT) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("UniformOptions::debugMode = %u is invalid: allowed [0, %d) (csm::DebugMode)",
                      static_cast<std::uint32_t>(uniformOptions_.debugMode), CSM_DEBUG_COUNT));
  }
  if (frame.blendBand != settings_.blendBand) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("frame.blendBand = %g but update() was given settings.blendBand = %g: "
                      "compute the frame with the settings given to update()",
                      frame.blendBand, settings_.blendBand));
  }
  if (frame.normalOffsetTexels != settings_.normalOffsetTexels) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("frame.normalOffsetTexels = %g but update() was given "
                      "settings.normalOffsetTexels = %g: compute the frame with the settings "
                      "given to update()",
                      double(frame.normalOffsetTexels), double(settings_.normalOffsetTexels)));
  }
  if (frame.cascadeCount != settings_.cascadeCount || frame.resolution != settings_.resolution) {
    return Status(
        ErrorCode::kInvalidArgument,
        fmt("frame has %u cascades of %u texels but the renderer was updated with %u of "
            "%u: compute the frame with the settings given to update()",
            frame.cascadeCount, frame.resolution, settings_.cascadeCount, settings_.resolution));
  }
  return {};
}

// The start every recorded pass shares (cached or not): one more host frame, so what was
// retired framesInFlight records ago is no longer in use; the pass leaves every layer written
// and sampleable. Returns whether the image was still waiting for its one-time clear.
bool ShadowRenderer::countRecord() {
  ++records_;
  collectRetired(false);
  const bool wasPending = pendingClear_;
  pendingClear_ = false;
  uniformsCleared_ = true;
  return wasPending;
}

// Opens the pass's debug label and uploads uniforms_ between two barriers: earlier readers of
// the block finish before it is overwritten (write after read), then the pass's and the host's
// readers see the new block. `images` (the pass's first image transitions) join the first one.
void ShadowRenderer::recordPassStart(VkCommandBuffer cmd, const char* label,
                                     std::span<const VkImageMemoryBarrier2> images) {
  if (beginLabel_) {
    auto info = vkInit<VkDebugUtilsLabelEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT);
    info.pLabelName = label;
    info.color[0] = 0.3f;
    info.color[1] = 0.3f;
    info.color[2] = 0.8f;
    info.color[3] = 1.0f;
    beginLabel_(cmd, &info);
  }
  const VkPipelineStageFlags2 readers =
      options_.consumerStages | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT;
  auto toWrite = vkInit<VkBufferMemoryBarrier2>(VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2);
  toWrite.srcStageMask = readers;
  toWrite.srcAccessMask = VK_ACCESS_2_NONE;
  toWrite.dstStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  toWrite.dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  toWrite.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toWrite.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toWrite.buffer = uniformBuffer_;
  toWrite.size = VK_WHOLE_SIZE;
  auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.bufferMemoryBarrierCount = 1;
  dep.pBufferMemoryBarriers = &toWrite;
  dep.imageMemoryBarrierCount = static_cast<std::uint32_t>(images.size());
  dep.pImageMemoryBarriers = images.data();
  vkCmdPipelineBarrier2(cmd, &dep);

  vkCmdUpdateBuffer(cmd, uniformBuffer_, 0, sizeof(CsmUniforms), &uniforms_);

  VkBufferMemoryBarrier2 toRead = toWrite;
  toRead.srcStageMask = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  toRead.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  toRead.dstStageMask = readers;
  toRead.dstAccessMask = VK_ACCESS_2_UNIFORM_READ_BIT;
  auto dep2 = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep2.bufferMemoryBarrierCount = 1;
  dep2.pBufferMemoryBarriers = &toRead;
  vkCmdPipelineBarrier2(cmd, &dep2);
}

// The uniform block of `frame` as every pass packs it: the host's options with the depth
// format's bits (the depth floor's quantum).
CsmUniforms ShadowRenderer::packFrameUniforms(const CascadeFrame& frame) const {
  UniformOptions uniformOptions = uniformOptions_;
  uniformOptions.depthBits = options_.depthFormat == VK_FORMAT_D16_UNORM ? 16u : 32u;
  return packUniforms(frame, settings_, uniformOptions);
}

void ShadowRenderer::recordBegin(VkCommandBuffer cmd, const CascadeFrame& frame) {
  countRecord();
  uniforms_ = packFrameUniforms(frame);
  recordDiscardingStart(cmd, "csm shadow pass");
}

// The start of a pass that renders every layer whole: earlier samplers of the map finish before
// it is discarded and rendered again; then the uniform block (uniforms_).
void ShadowRenderer::recordDiscardingStart(VkCommandBuffer cmd, const char* label) {
  auto toAttachment = vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2);
  toAttachment.srcStageMask = options_.consumerStages;
  toAttachment.srcAccessMask = VK_ACCESS_2_NONE;
  toAttachment.dstStageMask =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  toAttachment.dstAccessMask = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
                               VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  toAttachment.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;  // the previous frame's depth is not kept
  toAttachment.newLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  toAttachment.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toAttachment.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toAttachment.image = image_;
  toAttachment.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, layerCount_};
  recordPassStart(cmd, label, {&toAttachment, 1});
}

void ShadowRenderer::recordEnd(VkCommandBuffer cmd) {
  auto toSampled = vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2);
  toSampled.srcStageMask =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  toSampled.srcAccessMask = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  toSampled.dstStageMask = options_.consumerStages;
  toSampled.dstAccessMask = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  toSampled.oldLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  toSampled.newLayout = sampledLayout();
  toSampled.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toSampled.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toSampled.image = image_;
  toSampled.subresourceRange = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, layerCount_};
  auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &toSampled;
  vkCmdPipelineBarrier2(cmd, &dep);
  if (endLabel_) endLabel_(cmd);
}

// Begins dynamic rendering of the depth pass into `view` (`layers` layers, cleared to depth 1
// or loaded; DEPTH_ATTACHMENT_OPTIMAL) under a debug label, with the pass's dynamic state,
// `pipeline` and the depth set bound. Viewport and scissor are the caller's.
void ShadowRenderer::beginDepthRendering(VkCommandBuffer cmd, VkImageView view,
                                         std::uint32_t layers, bool clear, const std::string& label,
                                         VkPipeline pipeline) {
  if (beginLabel_) {
    auto info = vkInit<VkDebugUtilsLabelEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT);
    info.pLabelName = label.c_str();
    beginLabel_(cmd, &info);
  }
  auto depth = vkInit<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
  depth.imageView = view;
  depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depth.loadOp = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
  depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  depth.clearValue.depthStencil = {1.0f, 0};
  auto ri = vkInit<VkRenderingInfo>(VK_STRUCTURE_TYPE_RENDERING_INFO);
  ri.renderArea = {{0, 0}, {resolution_, resolution_}};
  ri.layerCount = layers;
  ri.pDepthAttachment = &depth;
  vkCmdBeginRendering(cmd, &ri);
  vkCmdSetDepthBias(cmd, settings_.depthBiasConstant, 0.0f, settings_.depthBiasSlope);
  vkCmdSetCullMode(cmd, options_.cullMode);
  vkCmdSetFrontFace(cmd, options_.frontFace);
  drawCull_ = options_.cullMode;
  drawFront_ = options_.frontFace;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelineLayout_, 0, 1, &depthSet_,
                          0, nullptr);
}

// Closed casters: cull the faces turned away from the light (RendererOptions::
// cullClosedCasters). Light space is right-handed with +z along the light's travel, and its x, y
// go to the framebuffer's x, y unflipped, so a face whose outward normal points at the light
// (-z) has a positive area in Vulkan's sense: counter-clockwise is front. A mirroring transform
// turns the winding. Sets the state only where it changes within the rendering.
void ShadowRenderer::setCasterCull(VkCommandBuffer cmd, const CasterInstance& instance) {
  VkCullModeFlags cull = options_.cullMode;
  VkFrontFace front = options_.frontFace;
  if (cull == VK_CULL_MODE_NONE && options_.cullClosedCasters && instance.closed &&
      !instance.thin) {
    const float det = glm::determinant(instance.linearWs);
    if (det != 0.0f) {
      cull = VK_CULL_MODE_BACK_BIT;
      front = det > 0.0f ? VK_FRONT_FACE_COUNTER_CLOCKWISE : VK_FRONT_FACE_CLOCKWISE;
    }
  }
  if (cull != drawCull_) {
    vkCmdSetCullMode(cmd, cull);
    drawCull_ = cull;
  }
  if (front != drawFront_) {
    vkCmdSetFrontFace(cmd, front);
    drawFront_ = front;
  }
}

void ShadowRenderer::beginLayer(VkCommandBuffer cmd, std::uint32_t cascade, bool layered) {
  beginDepthRendering(
      cmd, layered ? arrayView_ : layerViews_[cascade], layered ? layerCount_ : 1, true,
      layered ? std::string("csm cascades (layered)") : "csm cascade " + std::to_string(cascade),
      layered ? layeredPipeline_ : pipeline_);
  const VkViewport viewport{0.0f, 0.0f, float(resolution_), float(resolution_), 0.0f, 1.0f};
  const VkRect2D scissor{{0, 0}, {resolution_, resolution_}};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

void ShadowRenderer::endLayer(VkCommandBuffer cmd) {
  vkCmdEndRendering(cmd);
  if (endLabel_) endLabel_(cmd);
}

Status ShadowRenderer::recordShadowPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                                        const CasterList& casters, const CullResult* visible) {
  return recordCasterListPass(cmd, frame, casters, visible, false);
}

Status ShadowRenderer::recordValidatedPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                                           const CasterList& casters, const CullResult* visible) {
  return recordCasterListPass(cmd, frame, casters, visible, true);
}

Status ShadowRenderer::recordCasterListPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                                            const CasterList& casters, const CullResult* visible,
                                            bool instancesValidated) {
  Status s = checkFrame(frame);
  if (!s.ok()) return s;
  if (cmd == VK_NULL_HANDLE) return Status(ErrorCode::kInvalidArgument, "cmd is VK_NULL_HANDLE");
  s = checkCasterList(frame, casters, visible, instancesValidated);
  if (!s.ok()) return s;
  const std::size_t instanceCount = casters.instances.size();
  if (options_.cache) {
    if (visible == nullptr) {
      return Status(ErrorCode::kInvalidArgument,
                    "options.cache = true needs the cull lists (visible) of the frame");
    }
    if (casters.boundsWs.size() != instanceCount) {
      return Status(ErrorCode::kInvalidArgument,
                    fmt("options.cache = true needs casters.boundsWs for every instance: %zu "
                        "bounds for %zu instances",
                        casters.boundsWs.size(), instanceCount));
    }
  } else if (!casters.boundsWs.empty() && casters.boundsWs.size() != instanceCount) {
    return Status(ErrorCode::kInvalidArgument,
                  fmt("casters.boundsWs has %zu bounds for %zu instances: give one per instance "
                      "or none",
                      casters.boundsWs.size(), instanceCount));
  }
  if (windowed()) return recordCachedPass(cmd, frame, casters, visible);
  recordBegin(cmd, frame);
  // The mesh cascade c draws instance i with: its LOD by the schedule and the texel error budget.
  auto lodMesh = [&](std::size_t i, std::uint32_t c) {
    const CasterInstance& inst = casters.instances[i];
    const Cascade& cascade = frame.cascades[c];
    return inst.meshForLod(casterLod(inst, options_.cascadeLod[c],
                                     glm::min(cascade.texelSizeLs.x, cascade.texelSizeLs.y),
                                     options_.lodMaxErrorTexels));
  };
  const glm::dvec3 cam = frame.cameraPositionWs;
  const MeshDraw* bound = nullptr;
  // Draws instance `index` with mesh `meshIndex`: per-layer into cascade `cascades` (an index),
  // layered instanced into the cascades of the mask `cascades`, `copies` of them.
  auto drawCaster = [&](std::uint32_t index, std::uint32_t meshIndex, std::uint32_t cascades,
                        std::uint32_t copies) {
    const CasterInstance& inst = casters.instances[index];
    const MeshDraw& mesh = casters.meshes[meshIndex];
    if (mesh.indexCount == 0) return;
    bindMeshBuffers(cmd, mesh, bound, layout_.indexType);
    // Per-layer: the exact, camera-independent transform. Layered: one draw serves several
    // cascades, so the shader applies each cascade's camera-relative matrix.
    if (resolvedMode_ == RenderMode::kLayered) {
      const DepthPushLayered push{modelCameraRelative(inst.translationWs, inst.linearWs, cam),
                                  cascades};
      vkCmdPushConstants(cmd, pipelineLayout_, VK_SHADER_STAGE_VERTEX_BIT, 0, CSM_DEPTH_PUSH_SIZE,
                         &push);
    } else {
      const DepthPushPerLayer push{modelToShadowClip(frame.cascades[cascades], frame.lightBasisWs,
                                                     inst.translationWs, inst.linearWs),
                                   cascades};
      vkCmdPushConstants(cmd, pipelineLayout_, VK_SHADER_STAGE_VERTEX_BIT, 0, CSM_DEPTH_PUSH_SIZE,
                         &push);
    }
    drawIndexedCaster(cmd, inst, mesh, copies);
  };

  std::uint32_t nonEmpty = 0;
  for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
    if (!frame.cascades[c].empty) nonEmpty |= 1u << c;
  }
  if (resolvedMode_ == RenderMode::kLayered && nonEmpty != 0) {
    // One pass; each caster once, instanced into the cascades it was culled into.
    casterMasks_.assign(instanceCount, 0u);
    for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
      if ((nonEmpty & (1u << c)) == 0) continue;
      if (visible) {
        for (std::uint32_t i : visible->visible[c]) casterMasks_[i] |= 1u << c;
      } else {
        for (std::size_t i = 0; i < instanceCount; ++i) casterMasks_[i] |= 1u << c;
      }
    }
    if (cascadeHook_) cascadeHook_(cmd, static_cast<std::uint32_t>(std::countr_zero(nonEmpty)));
    beginLayer(cmd, 0, true);
    for (std::size_t i = 0; i < instanceCount; ++i) {
      std::uint32_t mask = casterMasks_[i];
      // One instanced draw per distinct LOD mesh among the cascades the caster is culled into.
      while (mask != 0) {
        const std::uint32_t first = static_cast<std::uint32_t>(std::countr_zero(mask));
        const std::uint32_t m = lodMesh(i, first);
        std::uint32_t same = 0;
        for (std::uint32_t c = first; c < frame.cascadeCount; ++c) {
          if ((mask & (1u << c)) != 0 && lodMesh(i, c) == m) {
            same |= 1u << c;
          }
        }
        drawCaster(static_cast<std::uint32_t>(i), m, same,
                   static_cast<std::uint32_t>(std::popcount(same)));
        mask &= ~same;
      }
    }
    endLayer(cmd);
  } else {
    for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
      if ((nonEmpty & (1u << c)) == 0) continue;
      if (cascadeHook_) cascadeHook_(cmd, c);
      beginLayer(cmd, c, false);
      bound = nullptr;
      if (visible) {
        for (std::uint32_t i : visible->visible[c]) drawCaster(i, lodMesh(i, c), c, 1);
      } else {
        for (std::size_t i = 0; i < instanceCount; ++i) {
          drawCaster(static_cast<std::uint32_t>(i), lodMesh(i, c), c, 1);
        }
      }
      endLayer(cmd);
    }
  }
  if (cascadeHook_ && nonEmpty != 0) cascadeHook_(cmd, kCascadeHookEnd);
  recordEnd(cmd);
  return {};
}

CascadeDrawContext ShadowRenderer::drawContext(VkCommandBuffer cmd, const CascadeFrame& frame,
                                               std::uint32_t cascade,
                                               const CullResult* visible) const {
  CascadeDrawContext ctx;
  ctx.cmd = cmd;
  ctx.cascade = cascade;
  ctx.visible = visible ? &visible->visible[cascade] : nullptr;
  ctx.pipelineLayout = pipelineLayout_;
  ctx.cameraPositionWs = frame.cameraPositionWs;
  ctx.frame = &frame;
  return ctx;
}

Status ShadowRenderer::recordShadowPass(VkCommandBuffer cmd, const CascadeFrame& frame,
                                        const CascadeDrawCallback& draw,
                                        const CullResult* visible) {
  Status s = checkFrame(frame);
  if (!s.ok()) return s;
  if (cmd == VK_NULL_HANDLE) return Status(ErrorCode::kInvalidArgument, "cmd is VK_NULL_HANDLE");
  if (!draw) return Status(ErrorCode::kInvalidArgument, "draw callback is empty");
  if (options_.cache) {
    return Status(ErrorCode::kInvalidArgument,
                  "options.cache = true: use the caster-list form of recordShadowPass (the "
                  "cache draws scissored regions with the casters' bounds)");
  }
  if (windowed()) return recordWindowedCallbackPass(cmd, frame, draw, visible);
  recordBegin(cmd, frame);
  bool any = false;
  for (std::uint32_t c = 0; c < frame.cascadeCount; ++c) {
    if (frame.cascades[c].empty) continue;
    if (cascadeHook_) cascadeHook_(cmd, c);
    any = true;
    beginLayer(cmd, c, false);
    draw(drawContext(cmd, frame, c, visible));
    endLayer(cmd);
  }
  if (cascadeHook_ && any) cascadeHook_(cmd, kCascadeHookEnd);
  recordEnd(cmd);
  return {};
}

}  // namespace csm::vk
