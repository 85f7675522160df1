#include "engine/errors.hpp"

#include <cstdio>
#include <exception>

namespace engine {

std::string vkResultName(VkResult result) {
  switch (result) {
#define ENGINE_CASE(x) \
  case x:              \
    return #x;
    ENGINE_CASE(VK_SUCCESS)
    ENGINE_CASE(VK_NOT_READY)
    ENGINE_CASE(VK_TIMEOUT)
    ENGINE_CASE(VK_EVENT_SET)
    ENGINE_CASE(VK_EVENT_RESET)
    ENGINE_CASE(VK_INCOMPLETE)
    ENGINE_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
    ENGINE_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    ENGINE_CASE(VK_ERROR_INITIALIZATION_FAILED)
    ENGINE_CASE(VK_ERROR_DEVICE_LOST)
    ENGINE_CASE(VK_ERROR_MEMORY_MAP_FAILED)
    ENGINE_CASE(VK_ERROR_LAYER_NOT_PRESENT)
    ENGINE_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
    ENGINE_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
    ENGINE_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
    ENGINE_CASE(VK_ERROR_TOO_MANY_OBJECTS)
    ENGINE_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
    ENGINE_CASE(VK_ERROR_FRAGMENTED_POOL)
    ENGINE_CASE(VK_ERROR_UNKNOWN)
    ENGINE_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
    ENGINE_CASE(VK_ERROR_INVALID_EXTERNAL_HANDLE)
    ENGINE_CASE(VK_ERROR_FRAGMENTATION)
    ENGINE_CASE(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
    ENGINE_CASE(VK_PIPELINE_COMPILE_REQUIRED)
    ENGINE_CASE(VK_ERROR_SURFACE_LOST_KHR)
    ENGINE_CASE(VK_ERROR_NATIVE_WINDOW_IN_USE_KHR)
    ENGINE_CASE(VK_SUBOPTIMAL_KHR)
    ENGINE_CASE(VK_ERROR_OUT_OF_DATE_KHR)
    ENGINE_CASE(VK_ERROR_INCOMPATIBLE_DISPLAY_KHR)
    ENGINE_CASE(VK_ERROR_VALIDATION_FAILED_EXT)
    ENGINE_CASE(VK_ERROR_INVALID_SHADER_NV)
#undef ENGINE_CASE
    default:
      return "VkResult(" + std::to_string(static_cast<int>(result)) + ")";
  }
}

VulkanError::VulkanError(VkResult result, const std::string& what)
    : std::runtime_error(what), result_(result) {}

void throwVulkanError(VkResult result, const char* call, const char* file, int line) {
  std::string message = std::string(call) + " failed with " + vkResultName(result) + " at " + file +
                        ":" + std::to_string(line);
  throw VulkanError(result, message);
}

int runMain(const std::function<int()>& body) noexcept {
  try {
    return body();
  } catch (const NoDeviceError& e) {
    std::fprintf(stderr, "no Vulkan device: %s\n", e.what());
    return kExitNoDevice;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  } catch (...) {
    std::fprintf(stderr, "error: unknown exception\n");
    return 1;
  }
}

}  // namespace engine
