// Everything the consumer does with the CSM module besides the per-frame calls and the lighting
// shader: this file (the test counts its lines, plus every line of main.cpp that uses the view).
#pragma once

#include <vulkan/vulkan.h>

#include <csm/core.hpp>
#include <csm/vulkan/shadow_view.hpp>
#include <memory>
#include <span>
#include <stdexcept>
#include <vector>

#include "scene.hpp"

/// The module's view on the host's device, given the scene: the host's caster meshes, all placed
/// at `originWs`, with their world bounds. Throws std::runtime_error with the module's message.
inline std::unique_ptr<csm::vk::ShadowView> createShadows(VkPhysicalDevice gpu, VkDevice device,
                                                          std::uint32_t family, VkQueue queue,
                                                          std::span<const csm::vk::MeshDraw> meshes,
                                                          std::span<const csm::AabbWs> boundsWs,
                                                          const glm::dvec3& originWs,
                                                          const csm::AabbWs& sceneBounds) {
  // The device the host made, the queue it submits to, and the features it enabled.
  const csm::vk::DeviceInfo info{.physicalDevice = gpu,
                                 .device = device,
                                 .queueFamily = family,
                                 .queue = queue,
                                 .depthClampEnabled = true};
  // The host's vertices: float3 position (VertexLayout::positionOffset 0) then float3 normal.
  const csm::vk::VertexLayout layout{.stride = 24};

  csm::vk::Status s;
  auto view = csm::vk::ShadowView::create(info, layout, &s);
  const csm::ShadowSettings settings{.cascadeCount = scene::kCascades,
                                     .resolution = scene::kResolution,
                                     .shadowDistanceM = scene::kShadowDistanceM};
  // The receiver fit: the cascades follow what the host's depth buffer shows (recordReceiverDepth).
  const csm::vk::RendererOptions options{.receiverFit = csm::vk::ReceiverFit::kSplitsAndBoxes};
  if (view) s = view->setSettings(settings, options);

  // Instance i draws mesh i (one LOD here; CasterInstance::lodMeshes names coarser ones).
  std::vector<csm::vk::CasterInstance> instances;
  for (std::uint32_t i = 0; i < meshes.size(); ++i) instances.push_back({i, originWs});
  if (s) s = view->setCasters(meshes, instances, boundsWs);
  if (s) s = view->setSceneBounds(&sceneBounds);
  if (!s) throw std::runtime_error(s.message());
  return view;
}
