#include "engine/debug.hpp"
#include "vk_struct.hpp"

#include <atomic>
#include <cstdio>
#include <string>

static_assert(sizeof(void*) == 8, "setDebugName assumes 64-bit non-dispatchable handles");

namespace engine {
namespace {

std::atomic<uint64_t> gWarnings{0};
std::atomic<uint64_t> gErrors{0};

// Entry points of VK_EXT_debug_utils, loaded by the Context that enabled the extension.
std::atomic<PFN_vkSetDebugUtilsObjectNameEXT> gSetName{nullptr};
std::atomic<PFN_vkCmdBeginDebugUtilsLabelEXT> gBeginLabel{nullptr};
std::atomic<PFN_vkCmdEndDebugUtilsLabelEXT> gEndLabel{nullptr};

}  // namespace

ValidationCounts validationCounts() noexcept {
  return {gWarnings.load(), gErrors.load()};
}

uint64_t validationMessageCount() noexcept {
  return gWarnings.load() + gErrors.load();
}

void resetValidationCounts() noexcept {
  gWarnings = 0;
  gErrors = 0;
}

void setDebugNameRaw(VkDevice device, VkObjectType type, uint64_t handle, std::string_view name) {
  PFN_vkSetDebugUtilsObjectNameEXT fn = gSetName.load();
  if (!fn || device == VK_NULL_HANDLE || handle == 0) return;
  const std::string owned(name);  // the API wants a NUL-terminated string
  auto info = detail::vkStruct<VkDebugUtilsObjectNameInfoEXT>(
      VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT);
  info.objectType = type;
  info.objectHandle = handle;
  info.pObjectName = owned.c_str();
  fn(device, &info);  // returns VK_SUCCESS or out-of-memory only; a missing name is harmless
}

ScopedLabel::ScopedLabel(VkCommandBuffer cmd, std::string_view name, const float (&color)[4])
    : cmd_(cmd) {
  PFN_vkCmdBeginDebugUtilsLabelEXT fn = gBeginLabel.load();
  if (!fn || !gEndLabel.load()) {
    cmd_ = VK_NULL_HANDLE;
    return;
  }
  const std::string owned(name);
  auto label = detail::vkStruct<VkDebugUtilsLabelEXT>(VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT);
  label.pLabelName = owned.c_str();
  for (int i = 0; i < 4; ++i) label.color[i] = color[i];
  fn(cmd_, &label);
}

ScopedLabel::~ScopedLabel() {
  if (cmd_ != VK_NULL_HANDLE) gEndLabel.load()(cmd_);
}

namespace detail {

void loadDebugUtils(VkInstance instance) noexcept {
  if (instance == VK_NULL_HANDLE) {
    gSetName = nullptr;
    gBeginLabel = nullptr;
    gEndLabel = nullptr;
    return;
  }
  gSetName = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
      vkGetInstanceProcAddr(instance, "vkSetDebugUtilsObjectNameEXT"));
  gBeginLabel = reinterpret_cast<PFN_vkCmdBeginDebugUtilsLabelEXT>(
      vkGetInstanceProcAddr(instance, "vkCmdBeginDebugUtilsLabelEXT"));
  gEndLabel = reinterpret_cast<PFN_vkCmdEndDebugUtilsLabelEXT>(
      vkGetInstanceProcAddr(instance, "vkCmdEndDebugUtilsLabelEXT"));
}

VKAPI_ATTR VkBool32 VKAPI_CALL debugMessengerCallback(
    VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT types,
    const VkDebugUtilsMessengerCallbackDataEXT* data, void* /*user*/) {
  const char* kind = "info";
  if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
    ++gErrors;
    kind = "error";
  } else if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
    ++gWarnings;
    kind = "warning";
  } else {
    return VK_FALSE;
  }
  const char* type = (types & VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT)    ? "validation"
                     : (types & VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT) ? "performance"
                                                                                 : "general";
  std::fprintf(stderr, "[vulkan %s %s] %s\n", type, kind,
               data && data->pMessage ? data->pMessage : "(no message)");
  return VK_FALSE;  // never abort the call
}

}  // namespace detail
}  // namespace engine
