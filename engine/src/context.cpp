#include "engine/context.hpp"

#if defined(__SANITIZE_ADDRESS__)
#include <dlfcn.h>
#include <link.h>
#endif

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>

#include "engine/debug.hpp"
#include "engine/errors.hpp"
#include "engine/memory.hpp"
#include "vk_struct.hpp"

namespace engine {
namespace {

#if defined(__SANITIZE_ADDRESS__)
// Sanitizer builds only: the Vulkan loader dlcloses the driver and the layers when the instance
// is destroyed, so LeakSanitizer, which reports at exit, sees their never-freed caches as
// allocations from "<unknown module>" and tools/lsan.supp cannot name them. Every Vulkan
// driver or layer library loaded now is pinned (RTLD_NOLOAD | RTLD_NODELETE: nothing new is
// loaded, what is loaded stays mapped), so the leak reports name their library.
int pinOne(dl_phdr_info* info, std::size_t, void*) {
  const std::string_view name = info->dlpi_name ? info->dlpi_name : "";
  if (name.find("libvulkan_") != std::string_view::npos ||
      name.find("libVkLayer_") != std::string_view::npos) {
    (void)dlopen(info->dlpi_name, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
  }
  return 0;
}
void pinVulkanLibraries() {
  dl_iterate_phdr(pinOne, nullptr);
}
#else
void pinVulkanLibraries() {}
#endif

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

bool hasExtension(const std::vector<VkExtensionProperties>& list, const char* name) {
  return std::any_of(list.begin(), list.end(), [&](const VkExtensionProperties& e) {
    return std::strcmp(e.extensionName, name) == 0;
  });
}

std::vector<VkExtensionProperties> instanceExtensions(const char* layer) {
  uint32_t count = 0;
  if (vkEnumerateInstanceExtensionProperties(layer, &count, nullptr) != VK_SUCCESS) return {};
  std::vector<VkExtensionProperties> list(count);
  if (vkEnumerateInstanceExtensionProperties(layer, &count, list.data()) != VK_SUCCESS) return {};
  list.resize(count);
  return list;
}

bool hasValidationLayer() {
  uint32_t count = 0;
  if (vkEnumerateInstanceLayerProperties(&count, nullptr) != VK_SUCCESS) return false;
  std::vector<VkLayerProperties> layers(count);
  if (vkEnumerateInstanceLayerProperties(&count, layers.data()) != VK_SUCCESS) return false;
  return std::any_of(layers.begin(), layers.begin() + count, [](const VkLayerProperties& l) {
    return std::strcmp(l.layerName, kValidationLayer) == 0;
  });
}

// Results of instance/device enumeration that mean "there is no usable driver".
bool meansNoDriver(VkResult r) {
  return r == VK_ERROR_INCOMPATIBLE_DRIVER || r == VK_ERROR_INITIALIZATION_FAILED ||
         r == VK_ERROR_EXTENSION_NOT_PRESENT || r == VK_ERROR_LAYER_NOT_PRESENT;
}

int deviceTypeRank(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return 1;
    default:
      return 0;
  }
}

}  // namespace

bool resolveValidationSetting(bool requested) noexcept {
  const char* env = std::getenv("CSM_VALIDATION");
  if (!env || !*env) return requested;
  if (std::strcmp(env, "0") == 0) return false;
  if (std::strcmp(env, "1") == 0) return true;
  std::fprintf(stderr, "CSM_VALIDATION=%s ignored: expected 0 or 1\n", env);
  return requested;
}

Context::Context(const ContextDesc& desc) {
  try {
    createInstance(desc);
    pickPhysicalDevice(desc);
    createDevice(desc);
  } catch (...) {
    shutdown();
    throw;
  }
}

Context::~Context() {
  shutdown();
}

void Context::createInstance(const ContextDesc& desc) {
  uint32_t loaderVersion = 0;
  const VkResult versionResult = vkEnumerateInstanceVersion(&loaderVersion);
  if (versionResult != VK_SUCCESS || loaderVersion < VK_API_VERSION_1_3)
    throw NoDeviceError("the Vulkan loader does not support Vulkan 1.3 (instance version " +
                        std::to_string(VK_API_VERSION_MAJOR(loaderVersion)) + "." +
                        std::to_string(VK_API_VERSION_MINOR(loaderVersion)) + ")");

  validation_ = resolveValidationSetting(desc.validation);
  if (validation_ && !hasValidationLayer()) {
    std::fprintf(stderr,
                 "warning: validation requested but %s is not installed; running without it\n",
                 kValidationLayer);
    validation_ = false;
  }

  const auto available = instanceExtensions(nullptr);
  std::vector<std::string> names = desc.instanceExtensions;
  for (const std::string& name : names)
    if (!hasExtension(available, name.c_str()))
      throw NoDeviceError("required instance extension " + name + " is not available");
  debugUtils_ = hasExtension(available, VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  if (debugUtils_) names.emplace_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  const bool portability = hasExtension(available, VK_KHR_PORTABILITY_ENUMERATION_EXTENSION_NAME);
  if (portability) names.emplace_back(VK_KHR_PORTABILITY_ENUMERATION_EXTENSION_NAME);
  bool validationFeatures = false;
  if (validation_) {
    validationFeatures = hasExtension(instanceExtensions(kValidationLayer),
                                      VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME);
    if (validationFeatures) names.emplace_back(VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME);
    if (!debugUtils_) {
      std::fprintf(stderr, "warning: %s missing, validation messages will not be counted\n",
                   VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    }
  }
  std::vector<const char*> extensionPtrs;
  for (const std::string& n : names) extensionPtrs.push_back(n.c_str());

  auto app = detail::vkStruct<VkApplicationInfo>(VK_STRUCTURE_TYPE_APPLICATION_INFO);
  app.pApplicationName = desc.appName.c_str();
  app.pEngineName = "csm engine";
  app.apiVersion = VK_API_VERSION_1_3;

  // The messenger in the pNext chain also reports on vkCreateInstance and vkDestroyInstance.
  auto messengerInfo = detail::vkStruct<VkDebugUtilsMessengerCreateInfoEXT>(
      VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT);
  messengerInfo.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                                  VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  messengerInfo.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                              VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                              VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  messengerInfo.pfnUserCallback = detail::debugMessengerCallback;

  const VkValidationFeatureEnableEXT enables[] = {
      VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
  auto features =
      detail::vkStruct<VkValidationFeaturesEXT>(VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT);
  features.enabledValidationFeatureCount = 1;
  features.pEnabledValidationFeatures = enables;

  auto info = detail::vkStruct<VkInstanceCreateInfo>(VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO);
  info.pApplicationInfo = &app;
  info.enabledExtensionCount = static_cast<uint32_t>(extensionPtrs.size());
  info.ppEnabledExtensionNames = extensionPtrs.data();
  if (portability) info.flags |= VK_INSTANCE_CREATE_ENUMERATE_PORTABILITY_BIT_KHR;
  if (validation_) {
    info.enabledLayerCount = 1;
    info.ppEnabledLayerNames = &kValidationLayer;
    if (debugUtils_) {
      info.pNext = &messengerInfo;
      if (validationFeatures) messengerInfo.pNext = &features;
    } else if (validationFeatures) {
      info.pNext = &features;
    }
  }
  const VkResult r = vkCreateInstance(&info, nullptr, &instance_);
  if (meansNoDriver(r))
    throw NoDeviceError("vkCreateInstance failed with " + vkResultName(r) +
                        " (no Vulkan driver installed or none loadable)");
  ENGINE_VK_CHECK(r);

  if (debugUtils_) detail::loadDebugUtils(instance_);
  if (validation_ && debugUtils_) {
    auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance_, "vkCreateDebugUtilsMessengerEXT"));
    if (create) {
      messengerInfo.pNext = nullptr;
      ENGINE_VK_CHECK(create(instance_, &messengerInfo, nullptr, &messenger_));
    }
  }
}

void Context::pickPhysicalDevice(const ContextDesc& desc) {
  uint32_t count = 0;
  VkResult r = vkEnumeratePhysicalDevices(instance_, &count, nullptr);
  if (meansNoDriver(r) || (r == VK_SUCCESS && count == 0))
    throw NoDeviceError(
        "no Vulkan physical device found (vkEnumeratePhysicalDevices: " + vkResultName(r) + ", " +
        std::to_string(count) + " devices); is a Vulkan driver installed?");
  ENGINE_VK_CHECK(r);
  std::vector<VkPhysicalDevice> devices(count);
  r = vkEnumeratePhysicalDevices(instance_, &count, devices.data());
  if (r != VK_INCOMPLETE) ENGINE_VK_CHECK(r);
  devices.resize(count);

  std::string rejected;
  int bestRank = -1;
  for (VkPhysicalDevice pd : devices) {
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(pd, &props);
    auto reject = [&](const std::string& why) {
      rejected += std::string("\n  ") + props.deviceName + ": " + why;
    };
    if (props.apiVersion < VK_API_VERSION_1_3) {
      reject("Vulkan 1.3 not supported");
      continue;
    }
    auto f13 = detail::vkStruct<VkPhysicalDeviceVulkan13Features>(
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES);
    auto f2 = detail::vkStruct<VkPhysicalDeviceFeatures2>(
        VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &f13);
    vkGetPhysicalDeviceFeatures2(pd, &f2);
    if (!f13.dynamicRendering || !f13.synchronization2) {
      reject("dynamicRendering or synchronization2 missing");
      continue;
    }
    if (desc.presentation) {
      uint32_t extCount = 0;
      ENGINE_VK_CHECK(vkEnumerateDeviceExtensionProperties(pd, nullptr, &extCount, nullptr));
      std::vector<VkExtensionProperties> exts(extCount);
      ENGINE_VK_CHECK(vkEnumerateDeviceExtensionProperties(pd, nullptr, &extCount, exts.data()));
      if (!hasExtension(exts, VK_KHR_SWAPCHAIN_EXTENSION_NAME)) {
        reject("VK_KHR_swapchain missing");
        continue;
      }
    }
    uint32_t familyCount = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &familyCount, nullptr);
    std::vector<VkQueueFamilyProperties> families(familyCount);
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &familyCount, families.data());
    int family = -1;
    for (uint32_t i = 0; i < familyCount && family < 0; ++i) {
      const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
      if ((families[i].queueFlags & need) != need) continue;
      if (desc.presentation && desc.presentSupport && !desc.presentSupport(instance_, pd, i))
        continue;
      family = static_cast<int>(i);
    }
    if (family < 0) {
      reject("no graphics+compute queue family (with presentation if requested)");
      continue;
    }
    const int rank = deviceTypeRank(props.deviceType);
    if (rank > bestRank) {
      bestRank = rank;
      physicalDevice_ = pd;
      properties_ = props;
      queueFamily_ = static_cast<uint32_t>(family);
      timestampValidBits_ = families[family].timestampValidBits;
    }
  }
  if (physicalDevice_ == VK_NULL_HANDLE)
    throw NoDeviceError("no Vulkan device meets the engine's requirements:" + rejected);
}

void Context::createDevice(const ContextDesc& desc) {
  auto s13 = detail::vkStruct<VkPhysicalDeviceVulkan13Features>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES);
  auto s12 = detail::vkStruct<VkPhysicalDeviceVulkan12Features>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, &s13);
  auto s11 = detail::vkStruct<VkPhysicalDeviceVulkan11Features>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES, &s12);
  auto supported = detail::vkStruct<VkPhysicalDeviceFeatures2>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &s11);
  vkGetPhysicalDeviceFeatures2(physicalDevice_, &supported);

  auto e13 = detail::vkStruct<VkPhysicalDeviceVulkan13Features>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES);
  e13.dynamicRendering = VK_TRUE;
  e13.synchronization2 = VK_TRUE;
  // glslang's SPIR-V 1.6 declares compute workgroup sizes with LocalSizeId, which needs it.
  e13.maintenance4 = s13.maintenance4;
  auto e12 = detail::vkStruct<VkPhysicalDeviceVulkan12Features>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, &e13);
  e12.shaderOutputLayer = s12.shaderOutputLayer;
  auto e11 = detail::vkStruct<VkPhysicalDeviceVulkan11Features>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES, &e12);
  e11.multiview = s11.multiview;
  auto enabled = detail::vkStruct<VkPhysicalDeviceFeatures2>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &e11);
  enabled.features.depthClamp = supported.features.depthClamp;
  enabled.features.depthBiasClamp = supported.features.depthBiasClamp;
  enabled.features.fillModeNonSolid = supported.features.fillModeNonSolid;
  enabled.features.samplerAnisotropy = supported.features.samplerAnisotropy;
  enabled.features.geometryShader = supported.features.geometryShader;
  enabled.features.shaderStorageImageExtendedFormats =
      supported.features.shaderStorageImageExtendedFormats;

  features_.depthClamp = enabled.features.depthClamp;
  features_.depthBiasClamp = enabled.features.depthBiasClamp;
  features_.fillModeNonSolid = enabled.features.fillModeNonSolid;
  features_.samplerAnisotropy = enabled.features.samplerAnisotropy;
  features_.geometryShader = enabled.features.geometryShader;
  features_.shaderStorageImageExtendedFormats = enabled.features.shaderStorageImageExtendedFormats;
  features_.multiview = e11.multiview;
  features_.shaderOutputLayer = e12.shaderOutputLayer;
  features_.timestamps = timestampValidBits_ > 0;

  const float priority = 1.0f;
  auto queueInfo =
      detail::vkStruct<VkDeviceQueueCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
  queueInfo.queueFamilyIndex = queueFamily_;
  queueInfo.queueCount = 1;
  queueInfo.pQueuePriorities = &priority;

  std::vector<const char*> extensions;
  if (desc.presentation) extensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
  {  // Conservative rasterisation, where the device has it (the shadow module's thin casters).
    uint32_t count = 0;
    vkEnumerateDeviceExtensionProperties(physicalDevice_, nullptr, &count, nullptr);
    std::vector<VkExtensionProperties> available(count);
    vkEnumerateDeviceExtensionProperties(physicalDevice_, nullptr, &count, available.data());
    features_.conservativeRasterization =
        hasExtension(available, VK_EXT_CONSERVATIVE_RASTERIZATION_EXTENSION_NAME);
    if (features_.conservativeRasterization) {
      extensions.push_back(VK_EXT_CONSERVATIVE_RASTERIZATION_EXTENSION_NAME);
    }
  }

  auto info = detail::vkStruct<VkDeviceCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, &enabled);
  info.queueCreateInfoCount = 1;
  info.pQueueCreateInfos = &queueInfo;
  info.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  info.ppEnabledExtensionNames = extensions.data();
  ENGINE_VK_CHECK(vkCreateDevice(physicalDevice_, &info, nullptr, &device_));
  pinVulkanLibraries();
  vkGetDeviceQueue(device_, queueFamily_, 0, &queue_);
  setDebugName(device_, device_, "engine.device");
  setDebugName(device_, queue_, "engine.queue");

  auto poolInfo =
      detail::vkStruct<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
  poolInfo.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  poolInfo.queueFamilyIndex = queueFamily_;
  ENGINE_VK_CHECK(vkCreateCommandPool(device_, &poolInfo, nullptr, &immediatePool_));
  setDebugName(device_, immediatePool_, "engine.immediate.pool");
  auto fenceInfo = detail::vkStruct<VkFenceCreateInfo>(VK_STRUCTURE_TYPE_FENCE_CREATE_INFO);
  ENGINE_VK_CHECK(vkCreateFence(device_, &fenceInfo, nullptr, &immediateFence_));
  setDebugName(device_, immediateFence_, "engine.immediate.fence");

  allocator_ = std::make_unique<Allocator>(physicalDevice_, device_);
}

void Context::submitAndWait(const std::function<void(VkCommandBuffer)>& record) {
  auto alloc =
      detail::vkStruct<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
  alloc.commandPool = immediatePool_;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkAllocateCommandBuffers(device_, &alloc, &cmd));
  struct FreeOnExit {
    VkDevice device;
    VkCommandPool pool;
    VkCommandBuffer cmd;
    ~FreeOnExit() { vkFreeCommandBuffers(device, pool, 1, &cmd); }
  } freeOnExit{device_, immediatePool_, cmd};
  setDebugName(device_, cmd, "engine.immediate.cmd");

  auto begin =
      detail::vkStruct<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  ENGINE_VK_CHECK(vkBeginCommandBuffer(cmd, &begin));
  record(cmd);
  ENGINE_VK_CHECK(vkEndCommandBuffer(cmd));

  auto cmdInfo =
      detail::vkStruct<VkCommandBufferSubmitInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO);
  cmdInfo.commandBuffer = cmd;
  auto submit = detail::vkStruct<VkSubmitInfo2>(VK_STRUCTURE_TYPE_SUBMIT_INFO_2);
  submit.commandBufferInfoCount = 1;
  submit.pCommandBufferInfos = &cmdInfo;
  ENGINE_VK_CHECK(vkQueueSubmit2(queue_, 1, &submit, immediateFence_));
  ENGINE_VK_CHECK(vkWaitForFences(device_, 1, &immediateFence_, VK_TRUE, UINT64_MAX));
  ENGINE_VK_CHECK(vkResetFences(device_, 1, &immediateFence_));
}

void Context::waitIdle() {
  ENGINE_VK_CHECK(vkDeviceWaitIdle(device_));
}

void Context::shutdown() noexcept {
  if (device_ != VK_NULL_HANDLE) {
    vkDeviceWaitIdle(device_);  // best effort: a lost device is destroyed all the same
    allocator_.reset();
    if (immediateFence_) vkDestroyFence(device_, immediateFence_, nullptr);
    if (immediatePool_) vkDestroyCommandPool(device_, immediatePool_, nullptr);
    immediateFence_ = VK_NULL_HANDLE;
    immediatePool_ = VK_NULL_HANDLE;
    vkDestroyDevice(device_, nullptr);
    device_ = VK_NULL_HANDLE;
    queue_ = VK_NULL_HANDLE;
  }
  if (instance_ != VK_NULL_HANDLE) {
    if (messenger_ != VK_NULL_HANDLE) {
      auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
          vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
      if (destroy) destroy(instance_, messenger_, nullptr);
      messenger_ = VK_NULL_HANDLE;
    }
    if (debugUtils_) detail::loadDebugUtils(VK_NULL_HANDLE);
    vkDestroyInstance(instance_, nullptr);
    instance_ = VK_NULL_HANDLE;
  }
  physicalDevice_ = VK_NULL_HANDLE;
}

}  // namespace engine
