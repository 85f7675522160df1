// csm::DepthFormat (csm/names.hpp: its one spelling, "d32" / "d16") <-> the VkFormat of
// RendererOptions::depthFormat.
#pragma once

#include <vulkan/vulkan.h>

#include "csm/names.hpp"

namespace csm::vk {

[[nodiscard]] constexpr VkFormat toVkFormat(DepthFormat format) noexcept {
  return format == DepthFormat::kD16 ? VK_FORMAT_D16_UNORM : VK_FORMAT_D32_SFLOAT;
}

/// The DepthFormat of a shadow-map VkFormat: D16_UNORM is kD16, anything else (D32_SFLOAT, the
/// only other format RendererOptions accepts) kD32.
[[nodiscard]] constexpr DepthFormat depthFormatOf(VkFormat format) noexcept {
  return format == VK_FORMAT_D16_UNORM ? DepthFormat::kD16 : DepthFormat::kD32;
}

/// The one spelling of a shadow-map VkFormat ("d32", "d16").
[[nodiscard]] inline const char* depthFormatName(VkFormat format) noexcept {
  return csm::depthFormatName(depthFormatOf(format));
}

}  // namespace csm::vk
