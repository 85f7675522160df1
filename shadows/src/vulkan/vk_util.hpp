// Small Vulkan helpers the module's Vulkan sources share (private to shadows/src/vulkan: not
// installed, not part of the API).
#pragma once

#include <vulkan/vulkan.h>

#include <glm/glm.hpp>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include "csm/vulkan/shadow_renderer.hpp"
#include "csm/vulkan/status.hpp"

namespace csm::vk {

/// A zeroed Vulkan struct with its sType (and pNext) set.
template <class T>
T vkInit(VkStructureType type, void* next = nullptr) {
  T value{};
  value.sType = type;
  value.pNext = next;
  return value;
}

/// A handle as the 64-bit integer VkDebugUtilsObjectNameInfoEXT wants.
template <class T>
std::uint64_t handleBits(T handle) {
  return (std::uint64_t)(handle);  // NOLINT: handles are pointers or 64-bit integers
}

/// kVulkan naming the call that failed and its VkResult.
inline Status vkError(VkResult r, const char* what) {
  return Status(ErrorCode::kVulkan, std::string(what) + " failed with " + vkResultName(r), r);
}

/// printf into a std::string (messages of at most 511 characters).
template <class... Args>
std::string fmt(const char* format, Args... args) {
  char buf[512];
  std::snprintf(buf, sizeof(buf), format, args...);
  return buf;
}

/// Names a Vulkan object through VK_EXT_debug_utils when `setObjectName` was loaded; naming is
/// best effort and never fails a call.
inline void setObjectName(PFN_vkSetDebugUtilsObjectNameEXT setObjectName, VkDevice device,
                          std::uint64_t handle, VkObjectType type, const char* name) {
  if (!setObjectName || handle == 0) return;
  auto info =
      vkInit<VkDebugUtilsObjectNameInfoEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT);
  info.objectType = type;
  info.objectHandle = handle;
  info.pObjectName = name;
  (void)setObjectName(device, &info);
}

/// Binds `mesh`'s vertex and index buffers unless `bound` (the mesh drawn last in this render
/// pass, or nullptr) already bound the same ones; then `bound` is `mesh`.
inline void bindMeshBuffers(VkCommandBuffer cmd, const MeshDraw& mesh, const MeshDraw*& bound,
                            VkIndexType indexType) {
  if (bound == nullptr || bound->vertexBuffer != mesh.vertexBuffer ||
      bound->vertexBufferOffset != mesh.vertexBufferOffset) {
    vkCmdBindVertexBuffers(cmd, 0, 1, &mesh.vertexBuffer, &mesh.vertexBufferOffset);
  }
  if (bound == nullptr || bound->indexBuffer != mesh.indexBuffer ||
      bound->indexBufferOffset != mesh.indexBufferOffset) {
    vkCmdBindIndexBuffer(cmd, mesh.indexBuffer, mesh.indexBufferOffset, indexType);
  }
  bound = &mesh;
}

/// The depth pass's float matrix p -> scale * (linear p + t), composed in double (each row of
/// `linear` and `t` scaled before the one rounding to float).
inline glm::mat4 scaledAffine(const glm::dmat3& linear, const glm::dvec3& t,
                              const glm::dvec3& scale) {
  glm::mat4 m(0.0f);
  for (int col = 0; col < 3; ++col) {
    for (int row = 0; row < 3; ++row) {
      m[col][row] = static_cast<float>(linear[col][row] * scale[row]);
    }
  }
  for (int row = 0; row < 3; ++row) m[3][row] = static_cast<float>(t[row] * scale[row]);
  m[3][3] = 1.0f;
  return m;
}

/// What differs between the module's depth pipelines (the renderer's per-layer and layered
/// ones, the thin casters' ones); the rest is the depth pass's fixed state: triangle lists of
/// one float position, fill, dynamic viewport/scissor/depth bias/cull mode/front face, depth
/// test and write with LESS_OR_EQUAL, no colour attachment, one sample.
struct DepthPipelineDesc {
  /// The shader stages (vertex, and geometry for the thin casters).
  const VkPipelineShaderStageCreateInfo* stages = nullptr;
  std::uint32_t stageCount = 0;
  /// Chained to the rasterisation state (conservative rasterisation), or nullptr.
  const void* rasterizationNext = nullptr;
  /// The casters' vertex buffers.
  VertexLayout vertexLayout{};
  /// Depth clamp (DeviceInfo::depthClampEnabled).
  bool depthClamp = false;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  /// The depth attachment's format (dynamic rendering).
  VkFormat depthFormat = VK_FORMAT_UNDEFINED;
  /// The cache's shader copy (CacheRestore::kShaderCopy): no vertex input, no depth bias, the
  /// depth test always passes and the fragment's depth is written. The dynamic states are the
  /// depth pipelines' (their values set for the depth pass stay valid across the switch).
  bool restore = false;
};

/// Creates one depth pipeline (vkCreateGraphicsPipelines through `cache`); `*out` is
/// VK_NULL_HANDLE when it fails.
VkResult createDepthPipeline(VkDevice device, VkPipelineCache cache, const DepthPipelineDesc& desc,
                             VkPipeline* out);

static_assert(CSM_DEPTH_PUSH_SIZE == sizeof(glm::mat4) + sizeof(std::uint32_t));

/// Push constants of the per-layer depth pass (csm_depth.vert): one cascade per render pass.
struct DepthPushPerLayer {
  /// Model -> the cascade's shadow clip space, composed in double (modelToShadowClip).
  glm::mat4 modelToShadowClip;
  /// The cascade drawn (not read by the shader; kept for the shared layout and for debuggers).
  std::uint32_t cascade;
};
/// Push constants of the layered depth pass (csm_depth_layered.vert): every cascade in one pass.
struct DepthPushLayered {
  /// Model -> camera-relative world; the shader applies each cascade's viewProjCr.
  glm::mat4 modelToCameraRelative;
  /// The cascades this caster is instanced into: instance n draws into the n-th set bit.
  std::uint32_t cascadeMask;
};
static_assert(sizeof(DepthPushPerLayer) == CSM_DEPTH_PUSH_SIZE);
static_assert(sizeof(DepthPushLayered) == CSM_DEPTH_PUSH_SIZE);
static_assert(offsetof(DepthPushPerLayer, cascade) == 64);
static_assert(offsetof(DepthPushLayered, cascadeMask) == 64);
/// Push constants of the thin casters' geometry stage (csm_depth_thin.geom), at
/// CSM_THIN_PUSH_OFFSET: the widening in texels each side per layer the draw writes.
struct ThinPush {
  float widenTexels[CSM_MAX_CASCADES];
};
static_assert(sizeof(ThinPush) == CSM_THIN_PUSH_SIZE);
static_assert(CSM_THIN_PUSH_OFFSET == CSM_DEPTH_PUSH_SIZE);

}  // namespace csm::vk

/// Returns vkError(result, "call") from the enclosing function when `call` does not succeed.
#define CSM_VK_TRY(call)                                             \
  do {                                                               \
    const VkResult csmResult_ = (call);                              \
    if (csmResult_ != VK_SUCCESS) return vkError(csmResult_, #call); \
  } while (false)
