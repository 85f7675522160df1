// The one place our host engine hands its device to the shadow module: engine/ knows nothing
// of cascades and shadows/ nothing of engine/, so whatever composes both (the sample world,
// the GPU tests, the tools) creates the view or the renderer through this.
#pragma once

#include <memory>
#include <optional>

#include "csm/vulkan/shadow_renderer.hpp"
#include "csm/vulkan/shadow_view.hpp"
#include "engine/context.hpp"

namespace glue {

/// The anisotropy the sample world lets the moment sampler use on GPUs (the 8x of the common
/// engine presets and of the samples it is compared with).
inline constexpr float kMomentAnisotropy = 8.0f;

/// The moment sampler's anisotropy cap when the caller names none: kMomentAnisotropy on a GPU,
/// 1 (trilinear) on a CPU implementation, where anisotropic taps of the RGBA32F moments cost
/// minutes a frame (lavapipe: shadows/docs/prefiltered.md).
[[nodiscard]] float defaultMomentAnisotropy(const engine::Context& ctx);

/// The module's view of an engine context: its device, queue family and the features it
/// enabled (depth clamp, shaderOutputLayer, debug utils, extended storage formats, sampler
/// anisotropy: the moment sampler's maxSamplerAnisotropy is `momentAnisotropy` (else
/// defaultMomentAnisotropy) capped by the device's limit, 1 where the feature is off).
[[nodiscard]] csm::vk::DeviceInfo shadowDeviceInfo(
    const engine::Context& ctx, std::optional<float> momentAnisotropy = std::nullopt);

/// A shadow renderer on the context's device, reading engine::Vertex positions. Throws
/// std::runtime_error with the module's message when it cannot be created.
[[nodiscard]] std::unique_ptr<csm::vk::ShadowRenderer> createShadowRenderer(
    const engine::Context& ctx);

/// A shadow view (the per-view object) on the context's device, reading engine::Vertex
/// positions. Throws std::runtime_error with the module's message when it cannot be created.
[[nodiscard]] std::unique_ptr<csm::vk::ShadowView> createShadowView(
    const engine::Context& ctx, std::optional<float> momentAnisotropy = std::nullopt);

}  // namespace glue
