// The one GPU probe of csm.glsl (shaders/shadow_probe.comp): the shadow function and the cascade
// selection evaluated in compute at given camera-relative receiver points, one invocation per
// point, through the same code path as a lighting shader. Used by the GPU tests (tests/gpu) and
// the measurement harness (tools/measure: shimmer, csm_tradeoff).
#pragma once

#include <vulkan/vulkan.h>

#include <csm/gpu_layout.hpp>
#include <cstdint>
#include <glm/glm.hpp>
#include <map>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "engine/memory.hpp"
#include "engine/pipeline.hpp"

namespace engine {
class Context;
}  // namespace engine

namespace glue {

/// One receiver point: its position relative to the camera the shadow pass was recorded for
/// (computed in double, rounded to float once) and its unit world normal.
struct ProbePoint {
  glm::vec3 posCr{0.0f};
  glm::vec3 normalWs{0.0f, 1.0f, 0.0f};
  /// The screen pixel a lighting shader would pass to csmShadow's third argument (where the
  /// receiver projects in this frame, so it moves with the camera); negative: the point's index.
  /// csm.glsl no longer reads it; the shimmer measure passes it so that a filter whose noise
  /// followed the screen would show as a crawl.
  glm::vec2 pixel{-1.0f, -1.0f};
};

/// csm.glsl's answer at one receiver point.
struct ProbeResult {
  float shadow = 1.0f;    ///< 1 lit, 0 shadowed
  int cascade = -1;       ///< selected cascade, -1 outside every cascade
  int blendCascade = -1;  ///< cascade blended in across the band, -1 none
  float blendWeight = 0.0f;
  /// Smallest |receiver depth - stored depth| (m) over the 5x5 texels around the receiver in its
  /// cascade (1e30 outside every cascade): below rounding noise the point sits on a depth tie.
  float depthGapM = 1e30f;
  /// The view depth csm.glsl selects the cascade with (csmViewDepth, m).
  float viewDepthM = 0.0f;
};

/// The probe's buffers, descriptor set and one compute pipeline per (kernel, blend) variant.
class ShadowProbe {
 public:
  /// `lightingSetLayout`: the shadow module's lighting set layout (bound at set 1).
  ShadowProbe(engine::Context& ctx, VkDescriptorSetLayout lightingSetLayout);
  ~ShadowProbe();
  ShadowProbe(const ShadowProbe&) = delete;
  ShadowProbe& operator=(const ShadowProbe&) = delete;

  /// Uploads the points (the buffers grow, after a device wait, when they are too small).
  void setPoints(std::span<const ProbePoint> points);
  /// Records the evaluation of the points set last, reading `lightingSet` (after the shadow pass
  /// in the same command buffer), and a barrier that makes the results visible to the host.
  void record(VkCommandBuffer cmd, VkDescriptorSet lightingSet, csm::PcfKernel kernel, bool blend);
  /// The results of the last recorded evaluation, once its submission has completed.
  [[nodiscard]] std::vector<ProbeResult> results() const;

 private:
  VkPipeline pipeline(csm::PcfKernel kernel, bool blend);

  engine::Context* ctx_;
  engine::DeviceHandle<VkDescriptorSetLayout> layout_;
  engine::DeviceHandle<VkDescriptorPool> pool_;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
  engine::DeviceHandle<VkPipelineLayout> pipelineLayout_;
  std::map<std::pair<uint32_t, bool>, engine::DeviceHandle<VkPipeline>> pipelines_;
  engine::Buffer points_;
  engine::Buffer results_;
  uint32_t capacity_ = 0;
  uint32_t count_ = 0;
};

}  // namespace glue
