// The GPU side of the measurements: one engine::Context (validation on in tests), the shadow
// renderer over a measurement Scene, and three ways to look at csm.glsl's answer:
//   probe()          the shadow function at fixed receiver points (compute, glue::ShadowProbe)
//   renderAccuracy() a rasterised frame whose every receiver pixel reports its position, normal,
//                    shadow factor, cascade and footprint (stability_accuracy.vert/frag)
//   timeFrame()      the shadow pass and the glue's lit pass with timestamp queries
// Everything is blocking (one submission at a time): measurements, not a frame loop.
#pragma once

#include <csm/core.hpp>
#include <csm/gpu_layout.hpp>
#include <csm/vulkan/shadow_renderer.hpp>
#include <engine/camera.hpp>
#include <engine/context.hpp>
#include <engine/image_io.hpp>
#include <engine/mesh_store.hpp>
#include <glue/gpu_scene.hpp>
#include <glue/shadow_probe.hpp>
#include "csm/vulkan/shadow_view.hpp"

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "csm_measure/scene.hpp"

namespace engine {
class HeadlessTarget;
class GpuTimer;
}  // namespace engine
namespace glue {
class LitPass;
}  // namespace glue

namespace csm_measure {

/// What a Harness is created with.
struct HarnessDesc {
  /// Validation layers (with synchronization validation); tests keep it on.
  bool validation = true;
  const char* appName = "csm_measure";
  /// The moment sampler's anisotropy (vsm, evsm, msm); empty: the sample world's default (8x on
  /// a GPU that allows it, 1 = trilinear on a CPU device such as lavapipe).
  std::optional<float> momentAnisotropy;
  /// The accuracy pass's prefiltered filters (vsm, evsm, msm) read the mip of each pixel's
  /// footprint, as the sample world's lit pass does (stability_accuracy_lod.frag); false: level 0
  /// at every pixel (stability_accuracy.frag). The percentage-closer kernels read the same either
  /// way.
  bool implicitLod = false;
};

/// csm.glsl's answer at one receiver point (the shared GPU probe's result).
using ProbeResult = glue::ProbeResult;

/// One receiver pixel of an accuracy frame.
struct PixelSample {
  uint32_t x = 0, y = 0;
  glm::dvec3 posWs{0.0};  ///< camera position + the pixel's camera-relative position
  glm::vec3 normalWs{0.0f};
  float shadow = 1.0f;
  int cascade = -1;
  int blendCascade = -1;
  float blendWeight = 0.0f;
  float footprintM = 0.0f;  ///< square root of the pixel's area on the surface
};

/// GPU and CPU time of one frame.
struct FrameTimings {
  double shadowGpuMs = 0.0;  ///< the shadow pass (every cascade)
  double litGpuMs = 0.0;     ///< the engine's lit pass (shading + shadow sampling)
  double cpuMs = 0.0;        ///< computeCascades + cullCasters + recording the shadow pass
};

class Harness {
 public:
  /// Creates the context and the renderer. Throws engine::NoDeviceError without a device.
  explicit Harness(const HarnessDesc& desc = {});
  /// Waits for the device, destroys everything and shuts the context down (validation messages
  /// raised during destruction are counted by then).
  ~Harness();
  Harness(const Harness&) = delete;
  Harness& operator=(const Harness&) = delete;

  engine::Context& context() { return *ctx_; }
  csm::vk::ShadowRenderer& renderer() { return view_->renderer(); }
  csm::vk::ShadowView& view() { return *view_; }

  /// Uploads the scene's meshes and builds its caster list (replacing any previous scene).
  /// Caster LODs are off until setCasterLods().
  void setScene(const Scene& scene);
  /// Caster LODs, through the module's (CasterInstance::lodMeshes, RendererOptions::cascadeLod):
  /// the shadow pass's cascade c draws instance i with mesh
  /// `lodMeshes[i][min(cascadeLod[c], lodMeshes[i].size() - 1)]` (meshes of the scene that no
  /// instance needs to use, e.g. simplified copies) instead of the instance's own mesh. The
  /// accuracy and lit passes and the ray tracer keep the instances' (full-detail) meshes. An
  /// empty `lodMeshes` turns LODs off (every cascade draws the instances' meshes). Throws
  /// std::invalid_argument for a size or mesh index out of range (at most
  /// csm::vk::kMaxCasterLods LODs).
  /// `lodErrorM[i][l]` (optional, one list per instance) is LOD l's error in metres
  /// (CasterInstance::lodErrorM; RendererOptions::lodMaxErrorTexels of configure() chooses by it).
  void setCasterLods(std::vector<std::vector<uint32_t>> lodMeshes,
                     const std::array<uint32_t, csm::kMaxCascades>& cascadeLod,
                     const std::vector<std::vector<float>>& lodErrorM = {});
  /// Triangles the last recorded shadow pass drew, summed over its cascades.
  uint64_t shadowTriangles() const { return shadowTriangles_; }
  /// Applies shadow settings and renderer options.
  csm::vk::Status configure(const csm::ShadowSettings& settings,
                            const csm::vk::RendererOptions& options = {});
  const csm::ShadowSettings& settings() const { return view_->settings(); }
  /// HarnessDesc::implicitLod: whether the prefiltered filters read the footprint's mip.
  bool implicitLod() const { return implicitLod_; }

  /// The visible receivers' view-depth range computeFrame (and timeFrame) pass to
  /// computeCascades for receiver-driven splits; nothing (the default) = the full range.
  void setReceiverRange(std::optional<csm::ReceiverDepthRange> range) {
    view_->setReceiverDepthRange(range);
  }

  /// The view's frame for `camera` with the caller's `history` (scene bounds applied); throws
  /// std::runtime_error naming the refused field on invalid input.
  csm::CascadeFrame computeFrame(const csm::Camera& camera, const csm::DirectionalLight& light,
                                 csm::CascadeHistory& history);

  /// Renders the shadow pass of `frame` and evaluates csm.glsl at the receivers (positions made
  /// camera-relative in double against the frame's camera). `pixels` (empty, or one per
  /// receiver): the screen pixels handed to csmShadow (glue::ProbePoint::pixel).
  std::vector<ProbeResult> probe(const csm::CascadeFrame& frame,
                                 std::span<const Receiver> receivers, csm::PcfKernel kernel,
                                 bool blend = true, std::span<const glm::vec2> pixels = {});

  /// Which normal renderAccuracy's bias uses: the facet normal (csmGeometricNormal, false: what
  /// the hosts pass) or the interpolated shading normal (true: the bias before facet normals, to
  /// compare with).
  void setBiasFromShadingNormal(bool shading) { biasFromShadingNormal_ = shading; }

  /// Renders the shadow pass and an accuracy frame of `extent` pixels for `camera`; returns
  /// every pixel a surface covers. `shadowImage` (optional) receives the shadow factor as grey
  /// (background dark blue) for people to look at. With receiver-marked tiles
  /// (RendererOptions::tiles, or CSM_SHADOW_TILES=1): `kernel` becomes the settings' kernel,
  /// and the frame is rendered once to find its pixels, then again with every static texel
  /// invalidated and the tiles those pixels mark (receiverTileMarks()) as the view's marks, so
  /// each partial cascade holds exactly its marked tiles: what a view whose marks are current
  /// samples. The second render is returned.
  std::vector<PixelSample> renderAccuracy(const csm::Camera& camera, const csm::CascadeFrame& frame,
                                          VkExtent2D extent, csm::PcfKernel kernel,
                                          bool blend = true,
                                          engine::CpuImage* shadowImage = nullptr);

  /// One timed frame at `extent`: computes cascades, culls, records the shadow pass and the lit
  /// pass, waits, and returns GPU (timestamp queries) and CPU (steady_clock) times. Empty GPU
  /// times (0) on devices without timestamps.
  FrameTimings timeFrame(const csm::Camera& camera, const csm::DirectionalLight& light,
                         csm::CascadeHistory& history, VkExtent2D extent, csm::PcfKernel kernel,
                         bool blend = true);

  /// With tiles: which pixels of renderAccuracy()'s first render mark the tiles they sample
  /// (every pixel by default; empty restores that). The tests leave some out to show that a
  /// missing mark changes the image (the fallback), so their comparison can fail.
  void setTileMarkFilter(std::function<bool(uint32_t x, uint32_t y)> filter) {
    tileMarkFilter_ = std::move(filter);
  }

  /// The tiles that receivers at `receiversWs` sample in `frame` at the current settings
  /// (csm::markReceiverTiles per receiver; the CPU form of the GPU's marking, which marks per
  /// block of pixels and so at least these).
  csm::ReceiverTileMarks receiverTileMarks(const csm::CascadeFrame& frame,
                                           std::span<const glm::dvec3> receiversWs) const;

  /// Bytes of the shadow map at the current settings and format, the moment images of a
  /// prefiltered filter included.
  uint64_t shadowMapBytes() const;

 private:
  struct AccuracyPipeline;
  struct AccuracyTargets;
  void recordShadow(VkCommandBuffer cmd, const csm::CascadeFrame& frame);
  AccuracyPipeline& accuracyPipeline(csm::PcfKernel kernel, bool blend);
  // renderAccuracy's stages: the pass into the three targets (and their copies to the readback
  // buffers), then the readback into samples (and the shadow-factor image).
  void recordAccuracyPass(VkCommandBuffer cmd, const glm::dvec3& cameraWs, VkExtent2D extent,
                          AccuracyPipeline& pipeline);
  std::vector<PixelSample> readAccuracySamples(const glm::dvec3& cameraWs, VkExtent2D extent,
                                               engine::CpuImage* shadowImage) const;
  void ensureAccuracyTargets(VkExtent2D extent);
  void ensureTimingTarget(VkExtent2D extent);

  std::unique_ptr<engine::Context> ctx_;
  // The scene on the GPU (destroyed after the view).
  glue::GpuScene gpu_;
  std::unique_ptr<csm::vk::ShadowView> view_;
  csm::vk::RendererOptions options_{};

  std::vector<Instance> instances_;
  csm::CasterSet casterSet_;
  std::array<uint32_t, csm::kMaxCascades> cascadeLod_{};
  uint64_t shadowTriangles_ = 0;
  std::function<bool(uint32_t, uint32_t)> tileMarkFilter_;
  bool tilesMarked_ = false;  // tiles: probe() or renderAccuracy() has set marks since configure()

  std::unique_ptr<glue::ShadowProbe> probe_;
  std::unique_ptr<AccuracyTargets> accuracy_;
  // Key: kernel | 0x100 when the bias uses the shading normal; blend.
  std::map<std::pair<uint32_t, bool>, std::unique_ptr<AccuracyPipeline>> accuracyPipelines_;
  bool biasFromShadingNormal_ = false;
  bool implicitLod_ = false;

  std::unique_ptr<engine::HeadlessTarget> timingTarget_;
  std::unique_ptr<engine::GpuTimer> timer_;
  std::map<std::pair<uint32_t, bool>, std::unique_ptr<glue::LitPass>> litPasses_;
};

}  // namespace csm_measure
