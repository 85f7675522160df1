// Errors of the Vulkan renderer: returned, never thrown across the API.
#pragma once

#include <vulkan/vulkan.h>

#include <string>
#include <utility>

namespace csm::vk {

/// Why a call of the renderer was refused or failed.
enum class ErrorCode {
  kOk = 0,
  /// A call made before the one it depends on (record before update, ...).
  kWrongOrder,
  /// Settings, options or a frame that do not pass validation or do not match each other.
  kInvalidArgument,
  /// A visible-list entry or caster that names a caster or mesh that does not exist.
  kIndexOutOfRange,
  /// Resolution or layer count above what the device allows.
  kDeviceLimit,
  /// Depth format the device cannot render and sample with a comparison sampler.
  kUnsupportedFormat,
  /// A Vulkan call returned an error (the VkResult is in Status::vkResult).
  kVulkan,
};

/// The outcome of a call: ok(), or a code with a message naming what was wrong and what is
/// allowed. A refused call leaves the renderer as it was, still usable.
class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(ErrorCode code, std::string message, VkResult vkResult = VK_SUCCESS)
      : code_(code), message_(std::move(message)), vkResult_(vkResult) {}

  /// True when the call succeeded.
  [[nodiscard]] bool ok() const noexcept { return code_ == ErrorCode::kOk; }
  explicit operator bool() const noexcept { return ok(); }
  [[nodiscard]] ErrorCode code() const noexcept { return code_; }
  /// Empty when ok().
  [[nodiscard]] const std::string& message() const noexcept { return message_; }
  /// The failing VkResult for ErrorCode::kVulkan, VK_SUCCESS otherwise.
  [[nodiscard]] VkResult vkResult() const noexcept { return vkResult_; }

 private:
  ErrorCode code_ = ErrorCode::kOk;
  std::string message_;
  VkResult vkResult_ = VK_SUCCESS;
};

/// The enumerator name of a VkResult ("VK_ERROR_OUT_OF_DEVICE_MEMORY"), or "VkResult(<n>)" for
/// one this build does not know. For messages (the module does not depend on the engine's).
[[nodiscard]] std::string vkResultName(VkResult result);

/// Name of an error code ("wrong order", ...), for messages.
[[nodiscard]] const char* errorCodeName(ErrorCode code) noexcept;

}  // namespace csm::vk
