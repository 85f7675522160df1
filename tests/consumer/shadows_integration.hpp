// Everything the consumer does with the CSM module besides the per-frame call and the lighting
// shader: this file and shadows_integration.cpp (the test counts their lines, plus every line of
// main.cpp that uses the view).
#pragma once

#include <vulkan/vulkan.h>

#include <csm/core.hpp>
#include <csm/vulkan/shadow_view.hpp>
#include <memory>
#include <span>

/// The module's view on the host's device, given the scene: the host's caster meshes, all placed
/// at `originWs`, with their world bounds. Throws std::runtime_error with the module's message.
std::unique_ptr<csm::vk::ShadowView> createShadows(VkPhysicalDevice gpu, VkDevice device,
                                                   std::uint32_t family, VkQueue queue,
                                                   std::span<const csm::vk::MeshDraw> meshes,
                                                   std::span<const csm::AabbWs> boundsWs,
                                                   const glm::dvec3& originWs,
                                                   const csm::AabbWs& sceneBounds);
