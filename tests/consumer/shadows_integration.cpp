#include "shadows_integration.hpp"

#include "scene.hpp"

std::string ConsumerShadows::init(VkPhysicalDevice gpu, VkDevice device, std::uint32_t queueFamily,
                                  bool debugUtils, const std::vector<HostCaster>& casters,
                                  const csm::AabbWs& sceneBounds) {
  // The device the host made, and the features it enabled.
  csm::vk::DeviceInfo info;
  info.physicalDevice = gpu;
  info.device = device;
  info.queueFamily = queueFamily;
  info.depthClampEnabled = true;
  info.debugUtilsEnabled = debugUtils;
  // The host's vertices: float3 position then float3 normal.
  csm::vk::VertexLayout layout;
  layout.stride = 24;
  layout.positionOffset = 0;

  csm::vk::Status status;
  renderer_ = csm::vk::ShadowRenderer::create(info, layout, &status);
  if (!renderer_) return status.message();

  settings_.cascadeCount = scene::kCascades;
  settings_.resolution = scene::kResolution;
  settings_.shadowDistanceM = scene::kShadowDistanceM;
  if (csm::vk::Status s = renderer_->update(settings_); !s) return s.message();

  // Caster bounds for culling; instance i of the renderer is caster i of the set.
  for (const HostCaster& c : casters) {
    auto added = casterSet_.addBox(c.boundsMinWs, c.boundsMaxWs);
    if (!added) return added.error().message();
    instances_.push_back(
        {static_cast<std::uint32_t>(meshes_.size()), c.translationWs, glm::mat3(1.0f)});
    meshes_.push_back(c.draw);
  }
  casterSet_.build();
  sceneBounds_ = sceneBounds;
  return "";
}

std::string ConsumerShadows::record(VkCommandBuffer cmd, const csm::Camera& camera,
                                    const csm::DirectionalLight& light) {
  auto frame = csm::computeCascades(settings_, camera, light, &sceneBounds_, &history_);
  if (!frame) return frame.error().message();
  frame_ = frame.value();
  csm::cullCasters(casterSet_, frame_, settings_.minCasterTexels, cull_);
  const csm::vk::CasterList list{meshes_, instances_};
  if (csm::vk::Status s = renderer_->recordShadowPass(cmd, frame_, list, &cull_); !s) {
    return s.message();
  }
  return "";
}
