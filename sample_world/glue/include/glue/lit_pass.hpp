// The lit pass that samples the shadows: Lambert + Blinn-Phong under one directional light, drawn
// with the engine's meshes and pipelines, shadowed through csm.glsl (lit.frag) from the module's
// lighting descriptor set (set 1). It lives in the glue, not the engine, because its fragment
// shader includes csm.glsl: the engine knows nothing of cascades.
#pragma once

#include <vulkan/vulkan.h>

#include <csm/gpu_layout.hpp>
#include <cstdint>
#include <glm/glm.hpp>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "engine/memory.hpp"
#include "engine/mesh_store.hpp"
#include "engine/pipeline.hpp"

namespace engine {
class Context;
class GpuTimer;
struct Frame;
}  // namespace engine

namespace glue {

/// Descriptor set index lit.frag reads the shadow resources from (CSM_SET in lit.frag).
inline constexpr uint32_t kLitShadowSet = 1;

/// What a LitPass pipeline is built for.
struct LitPassDesc {
  VkFormat colorFormat = VK_FORMAT_R8G8B8A8_UNORM;
  VkFormat depthFormat = VK_FORMAT_D32_SFLOAT;
  /// Layout of the shadow resources set (set 1), from the host's shadow module. Required.
  VkDescriptorSetLayout shadowSetLayout = VK_NULL_HANDLE;
  /// Specialization constants of the fragment shader as (constant_id, value): the shadow
  /// module's variants (PCF kernel, blend mode).
  std::vector<std::pair<uint32_t, uint32_t>> specialization;
};

/// Per-frame inputs of the lit pass.
struct LitFrame {
  /// Camera-relative world -> clip (engine::Camera::viewProjectionCr()).
  glm::mat4 viewProjCr{1.0f};
  /// The camera position the draws are made relative to.
  glm::dvec3 cameraPositionWs{0.0};
  /// Direction the light travels (normalised in the shader).
  glm::vec3 lightDirectionWs{0.0f, -1.0f, 0.0f};
  glm::vec3 lightColor{1.0f};
  glm::vec3 ambientColor{0.2f};
  float specularStrength = 0.25f;
  float shininess = 32.0f;
};

/// One mesh placed in the world: model = translate(translationWs) * linearWs.
struct LitDraw {
  engine::MeshRange mesh;
  glm::dvec3 translationWs{0.0};
  glm::mat3 linearWs{1.0f};
  glm::vec4 color{1.0f};
};

/// The pipeline, its per-frame uniform buffer and descriptor set.
class LitPass {
 public:
  /// Builds the pipeline (throws engine::VulkanError or std::invalid_argument on failure).
  LitPass(engine::Context& ctx, const LitPassDesc& desc);
  ~LitPass();
  LitPass(const LitPass&) = delete;
  LitPass& operator=(const LitPass&) = delete;

  /// Records the upload of the frame's uniforms (vkCmdUpdateBuffer with barriers that order it
  /// after earlier frames' reads). Outside any rendering, before draw().
  void prepare(VkCommandBuffer cmd, const LitFrame& frame);
  /// Records the draws inside the host's dynamic rendering: binds the pipeline, set 0 (frame)
  /// and `shadowSet` at kLitShadowSet, the mesh store's buffers, then one draw per entry.
  void draw(VkCommandBuffer cmd, const engine::MeshStore& meshes, VkDescriptorSet shadowSet,
            std::span<const LitDraw> draws, VkExtent2D extent) const;

 private:
  engine::Context* ctx_;
  engine::GraphicsPipeline pipeline_;
  engine::DeviceHandle<VkDescriptorSetLayout> frameLayout_;
  engine::DeviceHandle<VkDescriptorPool> pool_;
  VkDescriptorSet frameSet_ = VK_NULL_HANDLE;
  engine::Buffer frameBuffer_;
  glm::dvec3 cameraPositionWs_{0.0};
};

/// The lit pass of one csm.glsl variant (PCF kernel; blend band on or off; PCSS taps, 0 = the
/// shader's default) for these formats, sampling the module's lighting set (`lightingSetLayout`).
[[nodiscard]] std::unique_ptr<LitPass> makeLitPass(engine::Context& ctx, VkFormat colorFormat,
                                                   VkFormat depthFormat,
                                                   VkDescriptorSetLayout lightingSetLayout,
                                                   csm::PcfKernel kernel, bool blend,
                                                   uint32_t pcssTaps = 0);

/// Records a timed lit pass into `frame` (the benchmarks' and the measurements' timing loop):
/// the uniforms, then inside timer scope "lit" a rendering cleared to the sky colour and the draws.
void recordTimedLitPass(LitPass& lit, engine::GpuTimer& timer, const engine::Frame& frame,
                        const LitFrame& litFrame, const engine::MeshStore& meshes,
                        VkDescriptorSet lightingSet, std::span<const LitDraw> draws);

}  // namespace glue
