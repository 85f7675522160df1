// Everything the consumer does with the CSM module, in one place: this file and
// shadows_integration.cpp are the whole integration (the test counts their lines).
#pragma once

#include <vulkan/vulkan.h>

#include <csm/core.hpp>
#include <csm/vulkan/shadow_renderer.hpp>
#include <memory>
#include <string>
#include <vector>

/// One caster mesh of the host: where its vertices and indices live, and where it is placed.
struct HostCaster {
  csm::vk::MeshDraw draw;
  glm::dvec3 translationWs;
  glm::dvec3 boundsMinWs, boundsMaxWs;
};

class ConsumerShadows {
 public:
  /// Creates the renderer on the host's device; returns an error message or "".
  std::string init(VkPhysicalDevice gpu, VkDevice device, std::uint32_t queueFamily,
                   bool debugUtils, const std::vector<HostCaster>& casters,
                   const csm::AabbWs& sceneBounds);
  /// Per frame, before the host's lighting pass: cascades for this camera, culling, and the
  /// shadow pass recorded into the host's command buffer.
  std::string record(VkCommandBuffer cmd, const csm::Camera& camera,
                     const csm::DirectionalLight& light);
  /// The set layout the host's lighting pipeline declares at set CSM_SET, and the set to bind.
  VkDescriptorSetLayout setLayout() const { return renderer_->lightingSetLayout(); }
  VkDescriptorSet set() const { return renderer_->lightingSet(); }
  const csm::CascadeFrame& frame() const { return frame_; }
  const csm::ShadowSettings& settings() const { return settings_; }

 private:
  std::unique_ptr<csm::vk::ShadowRenderer> renderer_;
  csm::ShadowSettings settings_;
  csm::CasterSet casterSet_;
  std::vector<csm::vk::MeshDraw> meshes_;
  std::vector<csm::vk::CasterInstance> instances_;
  csm::AabbWs sceneBounds_{};
  csm::CascadeHistory history_;
  csm::CascadeFrame frame_;
  csm::CullResult cull_;
};
