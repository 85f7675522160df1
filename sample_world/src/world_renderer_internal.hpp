// What the world renderer's files share (world_renderer.cpp: set-up, frames, the shadow pass
// and the reduction; world_lighting.cpp: the lighting paths; world_overlay.cpp: the overlay).
#pragma once

#include <vulkan/vulkan.h>

#include <array>
#include <glm/glm.hpp>

namespace world {

// std140 block WorldFrame of world.vert / world.frag.
struct WorldFrameGpu {
  glm::mat4 viewProjCr;
  glm::vec4 lightDirection;
  glm::vec4 lightColor;
  glm::vec4 ambientColor;
  glm::uvec4 overlay;
  glm::mat4 invViewProjCr;
};
static_assert(sizeof(WorldFrameGpu) == 192);

constexpr VkClearColorValue kSkyColor{{0.55f, 0.68f, 0.86f, 1.0f}};

// The G-buffer's formats, in attachment order (world_gbuffer.frag's outputs).
constexpr std::array<VkFormat, 3> kGBufferFormats = {
    VK_FORMAT_R8G8B8A8_UNORM, VK_FORMAT_R16G16B16A16_SFLOAT, VK_FORMAT_R32_SFLOAT};

}  // namespace world
