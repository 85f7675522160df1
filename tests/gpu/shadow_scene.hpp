// Shared fixture of the shadow GPU tests: a plane with spheres and boxes above it under a
// directional light, rendered headless through csm::vk::ShadowRenderer and the engine's lit
// pass, with the analytic shadow answer computed on the CPU in double precision.
#pragma once

#include <csm/core.hpp>
#include <csm/gpu_layout.hpp>
#include <csm/vulkan/shadow_renderer.hpp>
#include <csm/vulkan/shadow_view.hpp>
#include <engine/camera.hpp>
#include <engine/context.hpp>
#include <engine/headless_target.hpp>
#include <engine/mesh_store.hpp>
#include <glue/gpu_scene.hpp>
#include <glue/lit_pass.hpp>
#include <glue/test_scene.hpp>

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

/// Asserts that a csm::vk::Status is ok, printing its message when not.
#define CSM_ASSERT_OK(expr)                               \
  do {                                                    \
    const csm::vk::Status csmStatus_ = (expr);            \
    ASSERT_TRUE(csmStatus_.ok()) << csmStatus_.message(); \
  } while (false)

namespace csm_test {

using glue::SphereWs;

/// What one render produced.
struct Rendered {
  engine::CpuImage image;
  csm::CascadeFrame frame;
};

/// The whole scene: device, target, meshes, renderer, lit pipelines (one per kernel and blend
/// mode, built on first use) and the analytic description (glue::AnalyticShapes, the shared test
/// scene, whose fields may change until the first update() or render).
class ShadowScene {
 public:
  /// Validation on; views of `width` x `height`.
  explicit ShadowScene(uint32_t width = 320, uint32_t height = 180);
  ~ShadowScene();

  /// Applies settings (and options) to the renderer; fails the calling test on error.
  csm::vk::Status update(const csm::ShadowSettings& settings,
                         const csm::vk::RendererOptions& options = {});

  /// Renders one frame with the given kernel, blend specialization and debug output.
  Rendered render(csm::PcfKernel kernel, csm::DebugMode debug, bool blend = true,
                  bool worldSpaceKernel = false);
  /// What renderFrame does besides render(): for the lifetime and split-screen tests.
  struct FrameHooks {
    csm::DebugMode debug = csm::DebugMode::kShadowFactor;
    bool blend = true;
    bool worldSpaceKernel = false;
    /// False: the lit pass samples the view without its pass this frame (out.frame default).
    bool shadowPass = true;
    /// With enableSecondView(): the lit pass renders from secondCamera with the second view.
    bool litFromSecond = false;
    /// The lit pipeline specialised with the view's own constants
    /// (ShadowView::lightingSpecialization: its settings' kernel, blend and PCSS taps) instead of
    /// `kernel` and `blend`.
    bool viewSpecialization = false;
    /// Run after recording, before the frame is submitted / right after it is submitted.
    std::function<void()> beforeSubmit;
    std::function<void()> afterSubmit;
  };
  Rendered renderFrame(csm::PcfKernel kernel, const FrameHooks& hooks);
  /// A second view of the same casters (split screen), recorded into the same command buffer
  /// as the main one each frame, for `secondCamera`. Call after update().
  void enableSecondView();
  engine::Camera secondCamera;
  /// Destroys the main view now (the lifetime test does it with a frame in flight).
  void destroyView();

  /// Computes (and culls) the cascades of the current camera, light and settings.
  csm::CascadeFrame computeFrame();
  /// Records the view's shadow pass for the scene's camera and light; returns its frame.
  /// Records the shadow pass of `frame` (computed by computeFrame()) into `cmd`.
  csm::CascadeFrame recordShadow(VkCommandBuffer cmd, csm::DebugMode debug,
                                 bool worldSpaceKernel = false);

  /// Nearest surface a camera ray through pixel (x, y) hits: its world point, and whether it is
  /// the ground plane (false: a caster, or nothing).
  struct Hit {
    bool hit = false;
    bool plane = false;
    glm::dvec3 posWs{0.0};
  };
  [[nodiscard]] Hit trace(uint32_t x, uint32_t y) const;
  /// Calls f(x, y, posWs) for every pixel of a `width` x `height` view whose camera ray meets
  /// the ground plane first (the receivers the analytic comparisons look at).
  template <class F>
  void forEachGroundPixel(uint32_t width, uint32_t height, F&& f) const {
    for (uint32_t y = 0; y < height; ++y) {
      for (uint32_t x = 0; x < width; ++x) {
        const Hit hit = trace(x, y);
        if (hit.hit && hit.plane) f(x, y, hit.posWs);
      }
    }
  }
  /// The cascade (and blend) that csm.glsl selects at `posWs` in `frame` (settings' blend band).
  [[nodiscard]] csm::CascadeSelection selection(const csm::CascadeFrame& frame,
                                                const glm::dvec3& posWs) const {
    return csm::selectCascade(frame, csm::viewDepthM(frame, posWs), settings().blendBand);
  }
  /// Whether the ray from `posWs` toward the light hits a caster.
  [[nodiscard]] bool shadowedAnalytic(const glm::dvec3& posWs) const;
  /// Whether every point within `radiusM` of `posWs` across the light direction has the same
  /// analytic answer as `posWs` (16 directions on rings of radius and radius / 2).
  [[nodiscard]] bool farFromEdge(const glm::dvec3& posWs, double radiusM,
                                 const csm::CascadeFrame& frame) const;

  /// Writes `image` under the build tree's test artefact folder; returns the path.
  std::string saveArtefact(const engine::CpuImage& image, const std::string& name) const;

  engine::Context& context() { return *ctx_; }
  csm::vk::ShadowRenderer& renderer() { return view_->renderer(); }
  csm::vk::ShadowView& view() { return *view_; }
  const csm::ShadowSettings& settings() const { return view_->settings(); }
  csm::Camera csmCamera() const;

  /// The casters' world bounds in the order the view gets them: the ground, spheres, boxes.
  const std::vector<csm::AabbWs>& casterBounds() const { return geometry_.instanceBounds(); }

  engine::Camera camera;
  csm::DirectionalLight light;
  csm::AabbWs sceneBounds{};
  glue::AnalyticShapes shapes;

 private:
  std::unique_ptr<engine::Context> ctx_;
  std::unique_ptr<engine::HeadlessTarget> target_;
  std::unique_ptr<csm::vk::ShadowView> view_;
  std::unique_ptr<csm::vk::ShadowView> second_;
  glue::Scene geometry_;
  glue::GpuScene gpu_;
  // By (kernel, blend), or by the view's constants (kViewSpec | their values) for
  // FrameHooks::viewSpecialization.
  std::map<std::pair<uint32_t, uint32_t>, std::unique_ptr<glue::LitPass>> litPasses_;
  bool built_ = false;

  void buildScene();
};

/// Analytic agreement of a kShadowFactor image (shared by the render and lifetime tests).
struct Agreement {
  uint64_t compared = 0;
  uint64_t agreed = 0;
  uint64_t shadowed = 0;  // compared pixels the analytic answer puts in shadow
  [[nodiscard]] double ratio() const { return compared ? double(agreed) / double(compared) : 0.0; }
};

/// Ground pixels farther than 2 texels (of their cascade, the coarser one in a blend band) from
/// the analytic shadow edge and inside the cascades: shadow factor < 0.5 <=> analytically shadowed.
Agreement compareWithAnalytic(const ShadowScene& scene, const Rendered& r);

/// Settings of the shadow tests: `cascades` of `resolution`, shadows to 60 m.
csm::ShadowSettings testSettings(uint32_t cascades, uint32_t resolution);

/// Counts validation messages (warnings + errors) seen so far in this process.
uint64_t validationMessages();

}  // namespace csm_test
