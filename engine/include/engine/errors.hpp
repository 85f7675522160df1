// Error handling for the engine: a checked-call macro for every VkResult, the exception types it
// throws, and the helper applications use to turn "no Vulkan device" into exit code 3.
#pragma once

#include <vulkan/vulkan.h>

#include <functional>
#include <stdexcept>
#include <string>

namespace engine {

/// Exit code of an application that found no usable Vulkan loader, driver or device.
inline constexpr int kExitNoDevice = 3;

/// The enumerator name of a VkResult ("VK_ERROR_DEVICE_LOST"), or "VkResult(<n>)" when unknown.
std::string vkResultName(VkResult result);

/// Thrown when a Vulkan call returns an error; the message names the call, the result and where.
class VulkanError : public std::runtime_error {
 public:
  /// Builds the error for `result`, with `what` the full message.
  VulkanError(VkResult result, const std::string& what);
  /// The VkResult the failing call returned.
  VkResult result() const noexcept { return result_; }

 private:
  VkResult result_;
};

/// Thrown when there is no Vulkan loader, no driver, or no device with what the engine needs.
class NoDeviceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Throws VulkanError for a failed call (or NoDeviceError for results that mean "no driver").
[[noreturn]] void throwVulkanError(VkResult result, const char* call, const char* file, int line);

/// Runs an application's body: returns its exit code; a NoDeviceError prints its message on
/// stderr and returns kExitNoDevice; any other exception prints its message and returns 1.
int runMain(const std::function<int()>& body) noexcept;

}  // namespace engine

/// Checks a VkResult-returning call: anything other than VK_SUCCESS throws engine::VulkanError
/// naming the call text and the result. (Calls whose non-error codes matter, like
/// vkAcquireNextImageKHR, check their result by hand.)
#define ENGINE_VK_CHECK(call)                                                 \
  do {                                                                        \
    const VkResult engineVkResult_ = (call);                                  \
    if (engineVkResult_ != VK_SUCCESS)                                        \
      ::engine::throwVulkanError(engineVkResult_, #call, __FILE__, __LINE__); \
  } while (false)
