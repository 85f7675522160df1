// Debug utilities: object names and command-buffer labels (VK_EXT_debug_utils, no-ops when the
// extension is absent) and the process-wide counters of validation messages.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <string_view>

namespace engine {

/// Counts of validation-layer messages seen by every engine messenger in this process.
struct ValidationCounts {
  uint64_t warnings = 0;  ///< messages of severity WARNING
  uint64_t errors = 0;    ///< messages of severity ERROR
};

/// The current counts. Messages raised inside vkDestroyDevice / vkDestroyInstance (leak reports)
/// are counted too, so read this after Context::shutdown() to include them.
ValidationCounts validationCounts() noexcept;

/// Warnings plus errors since the process started (or the last resetValidationCounts()).
uint64_t validationMessageCount() noexcept;

/// Sets both counters back to zero (tests call it at their start).
void resetValidationCounts() noexcept;

/// The VkObjectType of a Vulkan handle type, for naming objects.
template <class T>
struct ObjectTypeOf;

#define ENGINE_OBJECT_TYPE(Handle, Enum)        \
  template <>                                   \
  struct ObjectTypeOf<Handle> {                 \
    static constexpr VkObjectType value = Enum; \
  };
ENGINE_OBJECT_TYPE(VkInstance, VK_OBJECT_TYPE_INSTANCE)
ENGINE_OBJECT_TYPE(VkPhysicalDevice, VK_OBJECT_TYPE_PHYSICAL_DEVICE)
ENGINE_OBJECT_TYPE(VkDevice, VK_OBJECT_TYPE_DEVICE)
ENGINE_OBJECT_TYPE(VkQueue, VK_OBJECT_TYPE_QUEUE)
ENGINE_OBJECT_TYPE(VkSemaphore, VK_OBJECT_TYPE_SEMAPHORE)
ENGINE_OBJECT_TYPE(VkCommandBuffer, VK_OBJECT_TYPE_COMMAND_BUFFER)
ENGINE_OBJECT_TYPE(VkFence, VK_OBJECT_TYPE_FENCE)
ENGINE_OBJECT_TYPE(VkDeviceMemory, VK_OBJECT_TYPE_DEVICE_MEMORY)
ENGINE_OBJECT_TYPE(VkBuffer, VK_OBJECT_TYPE_BUFFER)
ENGINE_OBJECT_TYPE(VkImage, VK_OBJECT_TYPE_IMAGE)
ENGINE_OBJECT_TYPE(VkEvent, VK_OBJECT_TYPE_EVENT)
ENGINE_OBJECT_TYPE(VkQueryPool, VK_OBJECT_TYPE_QUERY_POOL)
ENGINE_OBJECT_TYPE(VkBufferView, VK_OBJECT_TYPE_BUFFER_VIEW)
ENGINE_OBJECT_TYPE(VkImageView, VK_OBJECT_TYPE_IMAGE_VIEW)
ENGINE_OBJECT_TYPE(VkShaderModule, VK_OBJECT_TYPE_SHADER_MODULE)
ENGINE_OBJECT_TYPE(VkPipelineCache, VK_OBJECT_TYPE_PIPELINE_CACHE)
ENGINE_OBJECT_TYPE(VkPipelineLayout, VK_OBJECT_TYPE_PIPELINE_LAYOUT)
ENGINE_OBJECT_TYPE(VkPipeline, VK_OBJECT_TYPE_PIPELINE)
ENGINE_OBJECT_TYPE(VkDescriptorSetLayout, VK_OBJECT_TYPE_DESCRIPTOR_SET_LAYOUT)
ENGINE_OBJECT_TYPE(VkSampler, VK_OBJECT_TYPE_SAMPLER)
ENGINE_OBJECT_TYPE(VkDescriptorPool, VK_OBJECT_TYPE_DESCRIPTOR_POOL)
ENGINE_OBJECT_TYPE(VkDescriptorSet, VK_OBJECT_TYPE_DESCRIPTOR_SET)
ENGINE_OBJECT_TYPE(VkCommandPool, VK_OBJECT_TYPE_COMMAND_POOL)
ENGINE_OBJECT_TYPE(VkSurfaceKHR, VK_OBJECT_TYPE_SURFACE_KHR)
ENGINE_OBJECT_TYPE(VkSwapchainKHR, VK_OBJECT_TYPE_SWAPCHAIN_KHR)
ENGINE_OBJECT_TYPE(VkDebugUtilsMessengerEXT, VK_OBJECT_TYPE_DEBUG_UTILS_MESSENGER_EXT)
#undef ENGINE_OBJECT_TYPE

/// Names an object by type and 64-bit handle value (no-op without VK_EXT_debug_utils).
void setDebugNameRaw(VkDevice device, VkObjectType type, uint64_t handle, std::string_view name);

/// Gives `handle` a debug name shown by validation messages and capture tools such as RenderDoc.
/// A no-op when VK_EXT_debug_utils is not enabled or the handle is null.
template <class T>
void setDebugName(VkDevice device, T handle, std::string_view name) {
  setDebugNameRaw(device, ObjectTypeOf<T>::value, reinterpret_cast<uint64_t>(handle), name);
}

/// A debug label around a range of commands (a pass), opened on construction and closed on
/// destruction: `ScopedLabel label(cmd, "shadow pass");`. A no-op without VK_EXT_debug_utils.
class ScopedLabel {
 public:
  /// Opens the label `name` in `cmd`, shown in `color` (RGBA) by tools that draw labels.
  ScopedLabel(VkCommandBuffer cmd, std::string_view name,
              const float (&color)[4] = {0.5f, 0.5f, 0.5f, 1.0f});
  /// Closes the label.
  ~ScopedLabel();
  ScopedLabel(const ScopedLabel&) = delete;
  ScopedLabel& operator=(const ScopedLabel&) = delete;

 private:
  VkCommandBuffer cmd_;
};

namespace detail {
/// Loads (instance != null) or clears (null) the debug-utils entry points used by setDebugName
/// and ScopedLabel. Called by Context; one Context at a time owns them.
void loadDebugUtils(VkInstance instance) noexcept;
/// The messenger callback that prints and counts validation messages.
VKAPI_ATTR VkBool32 VKAPI_CALL debugMessengerCallback(
    VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT types,
    const VkDebugUtilsMessengerCallbackDataEXT* data, void* user);
}  // namespace detail

}  // namespace engine
