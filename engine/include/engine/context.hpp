// The Vulkan 1.3 instance, physical device, logical device and its one graphics+compute queue,
// plus the memory allocator every buffer and image of the engine comes from.
#pragma once

#include <vulkan/vulkan.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace engine {

class Allocator;

/// What a Context should be created with.
struct ContextDesc {
  std::string appName = "csm";  ///< reported to the driver
  /// Enables VK_LAYER_KHRONOS_validation with synchronization validation and a messenger that
  /// prints and counts messages. The environment variable CSM_VALIDATION=0/1 overrides this.
  bool validation = false;
  /// Extra instance extensions (a window system's surface extensions, from GLFW).
  std::vector<std::string> instanceExtensions;
  /// Requires VK_KHR_swapchain and a queue that can present (set by WindowTarget users).
  bool presentation = false;
  /// Optional test for presentation support of (physical device, queue family) on a surface-less
  /// basis (glfwGetPhysicalDevicePresentationSupport); null accepts every family.
  std::function<bool(VkInstance, VkPhysicalDevice, uint32_t)> presentSupport;
};

/// Optional features, each true when the device supports it and the engine enabled it.
struct DeviceFeatures {
  bool depthClamp = false;
  bool depthBiasClamp = false;
  bool fillModeNonSolid = false;
  bool samplerAnisotropy = false;
  bool multiview = false;                  ///< VkPhysicalDeviceVulkan11Features::multiview
  bool shaderOutputLayer = false;          ///< VkPhysicalDeviceVulkan12Features::shaderOutputLayer
  bool timestamps = false;                 ///< the queue has timestampValidBits > 0
  bool geometryShader = false;             ///< VkPhysicalDeviceFeatures::geometryShader
  bool conservativeRasterization = false;  ///< VK_EXT_conservative_rasterization enabled
  /// VkPhysicalDeviceFeatures::shaderStorageImageExtendedFormats (storage images such as RG32F)
  bool shaderStorageImageExtendedFormats = false;
};

/// Owns the Vulkan instance and device. Throws NoDeviceError when there is no loader, no driver
/// or no device with Vulkan 1.3, dynamic rendering and synchronization2. Not copyable or movable:
/// everything else holds a reference to it.
class Context {
 public:
  /// Creates instance, (optional) messenger, device, queue and allocator.
  explicit Context(const ContextDesc& desc = {});
  /// Calls shutdown().
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  /// Waits for the device, then destroys allocator, device, messenger and instance, in that
  /// order. Validation messages raised during destruction (leak reports) are counted in
  /// engine::validationCounts(), so read the counter after this call. Idempotent. Every object
  /// created from this context must be destroyed before.
  void shutdown() noexcept;

  VkInstance instance() const { return instance_; }
  VkPhysicalDevice physicalDevice() const { return physicalDevice_; }
  VkDevice device() const { return device_; }
  /// The graphics+compute queue (also the present queue when presentation was requested).
  VkQueue queue() const { return queue_; }
  uint32_t queueFamily() const { return queueFamily_; }
  /// Properties of the chosen physical device (limits, timestampPeriod, name).
  const VkPhysicalDeviceProperties& properties() const { return properties_; }
  /// timestampValidBits of the queue family (0: no timestamps).
  uint32_t timestampValidBits() const { return timestampValidBits_; }
  /// Which optional features are enabled.
  const DeviceFeatures& features() const { return features_; }
  /// Whether validation layers and the counting messenger are on.
  bool validationEnabled() const { return validation_; }
  /// Whether VK_EXT_debug_utils names and labels are active.
  bool debugUtilsEnabled() const { return debugUtils_; }
  /// The sub-allocator for device memory.
  Allocator& allocator() { return *allocator_; }

  /// Records commands with `record` into a one-time command buffer, submits them and waits for
  /// completion (uploads, readbacks, initial layout transitions). Blocking and not thread-safe;
  /// not meant for per-frame work.
  void submitAndWait(const std::function<void(VkCommandBuffer)>& record);
  /// vkDeviceWaitIdle, checked.
  void waitIdle();

 private:
  void createInstance(const ContextDesc& desc);
  void pickPhysicalDevice(const ContextDesc& desc);
  void createDevice(const ContextDesc& desc);

  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  VkPhysicalDevice physicalDevice_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  uint32_t queueFamily_ = 0;
  uint32_t timestampValidBits_ = 0;
  VkPhysicalDeviceProperties properties_{};
  DeviceFeatures features_{};
  bool validation_ = false;
  bool debugUtils_ = false;
  VkCommandPool immediatePool_ = VK_NULL_HANDLE;
  VkFence immediateFence_ = VK_NULL_HANDLE;
  std::unique_ptr<Allocator> allocator_;
};

/// Whether validation should be on: CSM_VALIDATION=0/1 when set, else `requested`.
bool resolveValidationSetting(bool requested) noexcept;

}  // namespace engine
