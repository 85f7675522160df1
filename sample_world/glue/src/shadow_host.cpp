#include "glue/shadow_host.hpp"

#include <algorithm>
#include <stdexcept>

#include "engine/mesh_store.hpp"
#include "engine/render_target.hpp"

namespace glue {

float defaultMomentAnisotropy(const engine::Context& ctx) {
  return ctx.properties().deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU ? 1.0f : kMomentAnisotropy;
}

csm::vk::DeviceInfo shadowDeviceInfo(const engine::Context& ctx,
                                     std::optional<float> momentAnisotropy) {
  csm::vk::DeviceInfo info;
  info.physicalDevice = ctx.physicalDevice();
  info.device = ctx.device();
  info.queueFamily = ctx.queueFamily();
  info.queue = ctx.queue();
  info.framesInFlight = engine::kFramesInFlight;
  info.depthClampEnabled = ctx.features().depthClamp;
  info.shaderOutputLayerEnabled = ctx.features().shaderOutputLayer;
  info.geometryShaderEnabled = ctx.features().geometryShader;
  info.conservativeRasterizationEnabled = ctx.features().conservativeRasterization;
  info.debugUtilsEnabled = ctx.debugUtilsEnabled();
  info.storageImageExtendedFormatsEnabled = ctx.features().shaderStorageImageExtendedFormats;
  info.maxSamplerAnisotropy =
      ctx.features().samplerAnisotropy
          ? std::clamp(momentAnisotropy.value_or(defaultMomentAnisotropy(ctx)), 1.0f,
                       ctx.properties().limits.maxSamplerAnisotropy)
          : 1.0f;
  return info;
}

namespace {
csm::vk::VertexLayout engineVertexLayout() {
  csm::vk::VertexLayout layout;
  layout.stride = sizeof(engine::Vertex);
  layout.positionOffset = offsetof(engine::Vertex, position);
  return layout;
}
}  // namespace

std::unique_ptr<csm::vk::ShadowView> createShadowView(const engine::Context& ctx,
                                                      std::optional<float> momentAnisotropy) {
  csm::vk::Status status;
  auto view = csm::vk::ShadowView::create(shadowDeviceInfo(ctx, momentAnisotropy),
                                          engineVertexLayout(), &status);
  if (!view) throw std::runtime_error("ShadowView::create: " + status.message());
  return view;
}

std::unique_ptr<csm::vk::ShadowRenderer> createShadowRenderer(const engine::Context& ctx) {
  csm::vk::Status status;
  auto renderer =
      csm::vk::ShadowRenderer::create(shadowDeviceInfo(ctx), engineVertexLayout(), &status);
  if (!renderer) throw std::runtime_error("ShadowRenderer::create: " + status.message());
  return renderer;
}

}  // namespace glue
