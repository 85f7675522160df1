// The one place our host engine hands its device to the shadow module: engine/ knows nothing
// of cascades and shadows/ nothing of engine/, so whatever composes both (the sample world,
// the GPU tests, the tools) creates the view or the renderer through this.
#pragma once

#include <memory>

#include "csm/vulkan/shadow_renderer.hpp"
#include "csm/vulkan/shadow_view.hpp"
#include "engine/context.hpp"

namespace glue {

/// The module's view of an engine context: its device, queue family and the features it
/// enabled (depth clamp, shaderOutputLayer, debug utils).
[[nodiscard]] csm::vk::DeviceInfo shadowDeviceInfo(const engine::Context& ctx);

/// A shadow renderer on the context's device, reading engine::Vertex positions. Throws
/// std::runtime_error with the module's message when it cannot be created.
[[nodiscard]] std::unique_ptr<csm::vk::ShadowRenderer> createShadowRenderer(
    const engine::Context& ctx);

/// A shadow view (the per-view object) on the context's device, reading engine::Vertex
/// positions. Throws std::runtime_error with the module's message when it cannot be created.
[[nodiscard]] std::unique_ptr<csm::vk::ShadowView> createShadowView(const engine::Context& ctx);

}  // namespace glue
