// Internal: how every render target starts a frame (headless_target.cpp, window_target.cpp).
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>

#include "engine/memory.hpp"
#include "engine/render_target.hpp"

namespace engine::detail {

/// The images a frame renders into.
struct FrameImages {
  VkImage colorImage = VK_NULL_HANDLE;
  VkImageView colorView = VK_NULL_HANDLE;
  VkFormat colorFormat = VK_FORMAT_UNDEFINED;
  const Image* depth = nullptr;
  VkFormat depthFormat = VK_FORMAT_UNDEFINED;
  VkExtent2D extent{0, 0};
};

/// Records the frame-start barriers into `cmd` and returns the Frame. The previous contents of
/// both images are discarded (UNDEFINED): the colour image becomes a colour attachment after
/// `colorSrcStage` / `colorSrcAccess` (the previous use of that image), the depth image a depth
/// attachment after the previous frame's depth writes.
Frame startFrame(VkCommandBuffer cmd, uint32_t slot, uint64_t number, const FrameImages& images,
                 VkPipelineStageFlags2 colorSrcStage, VkAccessFlags2 colorSrcAccess);

}  // namespace engine::detail
