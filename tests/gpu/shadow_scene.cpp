// Shared fixture of the shadow GPU tests (see shadow_scene.hpp).
#include "shadow_scene.hpp"

#include <gtest/gtest.h>
#include <engine/debug.hpp>
#include <engine/render_target.hpp>
#include <glue/camera.hpp>
#include <glue/shadow_host.hpp>

#include <cmath>
#include <filesystem>
#include <limits>

namespace csm_test {

uint64_t validationMessages() {
  return engine::validationMessageCount();
}

ShadowScene::ShadowScene(uint32_t width, uint32_t height) {
  engine::resetValidationCounts();
  engine::ContextDesc desc;
  desc.appName = "csm shadow tests";
  desc.validation = true;
  ctx_ = std::make_unique<engine::Context>(desc);
  engine::HeadlessDesc hd;
  hd.extent = {width, height};
  target_ = std::make_unique<engine::HeadlessTarget>(*ctx_, hd);

  camera.positionWs = {0.0, 6.0, 6.0};
  camera.lookAt({0.0, 0.0, -12.0});
  camera.aspect = double(width) / double(height);
  camera.nearM = 0.1;
  camera.farM = 200.0;
  light.directionWs = glm::normalize(glm::dvec3(0.6, -1.0, -0.35));
  shapes.spheres = {{{-2.0, 2.2, -6.0}, 1.2}, {{3.0, 3.5, -22.0}, 2.0}};
  shapes.boxes = {{{1.5, 1.0, -9.5}, {3.5, 2.5, -7.5}},
                  {{-6.0, 1.5, -30.0}, {-3.0, 3.0, -27.0}},
                  // A long rail along the view direction: its shadow edge runs through every
                  // cascade.
                  {{4.2, 1.5, -45.0}, {4.8, 2.0, 3.0}}};

  view_ = glue::createShadowView(*ctx_);
}

ShadowScene::~ShadowScene() {
  if (ctx_) ctx_->waitIdle();
  litPasses_.clear();
  second_.reset();
  view_.reset();
  gpu_.store.reset();
  target_.reset();
  if (ctx_) ctx_->shutdown();
}

csm::Camera ShadowScene::csmCamera() const {
  return glue::toCsmCamera(camera);
}

void ShadowScene::buildScene() {
  geometry_ = shapes.scene();
  gpu_ = glue::uploadScene(*ctx_, geometry_, "shadow test meshes");
  const glm::dvec3& planeCenterWs = shapes.planeCenterWs;
  const double planeHalfM = shapes.planeHalfM;
  sceneBounds.minWs = planeCenterWs - glm::dvec3(planeHalfM, 0.0, planeHalfM);
  sceneBounds.maxWs = planeCenterWs + glm::dvec3(planeHalfM, 6.0, planeHalfM);
  csm::vk::Status s = view_->setCasters(gpu_.meshDraws, gpu_.casters, casterBounds());
  if (s.ok()) s = view_->setSceneBounds(&sceneBounds);
  if (!s.ok()) throw std::runtime_error("ShadowView: " + s.message());
  built_ = true;
}

csm::vk::Status ShadowScene::update(const csm::ShadowSettings& settings,
                                    const csm::vk::RendererOptions& options) {
  if (!built_) buildScene();
  csm::vk::Status s = view_->setSettings(settings, options);
  if (s.ok()) view_->resetHistory();
  return s;
}

namespace {

// The kernel's size in metres or in texels is a setting of the view (ShadowSettings::
// worldSpaceKernel): changed in place, the history and the image kept.
void useWorldSpaceKernel(csm::vk::ShadowView& view, bool on) {
  if (view.settings().worldSpaceKernel == on) return;
  csm::ShadowSettings settings = view.settings();
  settings.worldSpaceKernel = on;
  const csm::vk::Status s = view.setSettings(settings);
  if (!s.ok()) throw std::runtime_error("ShadowView::setSettings: " + s.message());
}

}  // namespace

Rendered ShadowScene::render(csm::PcfKernel kernel, csm::DebugMode debug, bool blend,
                             bool worldSpaceKernel) {
  FrameHooks hooks;
  hooks.debug = debug;
  hooks.blend = blend;
  hooks.worldSpaceKernel = worldSpaceKernel;
  return renderFrame(kernel, hooks);
}

void ShadowScene::enableSecondView() {
  if (!built_) buildScene();
  second_ = glue::createShadowView(*ctx_);
  csm::vk::Status s = second_->setSettings(view_->settings(), view_->options());
  if (s.ok()) s = second_->setCasters(gpu_.meshDraws, gpu_.casters, casterBounds());
  if (s.ok()) s = second_->setSceneBounds(&sceneBounds);
  if (!s.ok()) throw std::runtime_error("second ShadowView: " + s.message());
}

void ShadowScene::destroyView() {
  view_.reset();
}

Rendered ShadowScene::renderFrame(csm::PcfKernel kernel, const FrameHooks& hooks) {
  if (!built_) buildScene();
  auto key = std::make_pair(static_cast<uint32_t>(kernel), hooks.blend ? 1u : 0u);
  const csm::vk::LightingSpecialization& spec = view_->lightingSpecialization();
  if (hooks.viewSpecialization) {
    // Distinct from every (kernel, blend) key: the high bit, then the constants' values.
    key = {0x80000000u | spec.value(CSM_SPEC_KERNEL) | spec.value(CSM_SPEC_BLEND) << 8,
           spec.value(CSM_SPEC_PCSS_TAPS)};
  }
  auto& lit = litPasses_[key];
  if (!lit) {
    glue::LitPassDesc desc;
    desc.colorFormat = target_->colorFormat();
    desc.depthFormat = target_->depthFormat();
    desc.shadowSetLayout = view_->lightingSetLayout();
    if (hooks.viewSpecialization) {
      for (const csm::SpecConstant& c : spec.constants())
        desc.specialization.push_back({c.id, c.value});
    } else {
      desc.specialization = {{CSM_SPEC_KERNEL, key.first}, {CSM_SPEC_BLEND, key.second}};
    }
    lit = std::make_unique<glue::LitPass>(*ctx_, desc);
  }

  Rendered out;
  std::optional<engine::Frame> f = target_->beginFrame();
  if (!f) throw std::runtime_error("beginFrame returned no frame");
  csm::CascadeFrame secondFrame;
  if (second_) {
    // Split screen: the second view records into the same command buffer, first.
    useWorldSpaceKernel(*second_, hooks.worldSpaceKernel);
    second_->setDebugMode(hooks.debug);
    csm::Camera c = csmCamera();
    c.positionWs = secondCamera.positionWs;
    c.orientationWs = secondCamera.orientation;
    const csm::vk::Status s = second_->record(f->cmd, c, light);
    if (!s.ok()) throw std::runtime_error("second ShadowView::record: " + s.message());
    secondFrame = second_->frame();
  }
  if (hooks.shadowPass) out.frame = recordShadow(f->cmd, hooks.debug, hooks.worldSpaceKernel);
  const bool useSecond = second_ && hooks.litFromSecond;
  const engine::Camera& litCamera = useSecond ? secondCamera : camera;
  if (useSecond) out.frame = secondFrame;
  glue::LitFrame lf;
  lf.viewProjCr = litCamera.viewProjectionCr();
  lf.cameraPositionWs = litCamera.positionWs;
  lf.lightDirectionWs = glm::vec3(light.directionWs);
  lit->prepare(f->cmd, lf);
  engine::beginRendering(*f, VkClearColorValue{{0.1f, 0.1f, 0.15f, 1.0f}});
  lit->draw(f->cmd, *gpu_.store, useSecond ? second_->lightingSet() : view_->lightingSet(),
            gpu_.litDraws, f->extent);
  vkCmdEndRendering(f->cmd);
  if (hooks.beforeSubmit) hooks.beforeSubmit();
  target_->endFrame();
  if (hooks.afterSubmit) hooks.afterSubmit();
  out.image = target_->readback();
  return out;
}

csm::CascadeFrame ShadowScene::computeFrame() {
  if (!built_) buildScene();
  csm::Result<csm::CascadeFrame> frame = view_->computeFrame(csmCamera(), light);
  if (!frame.ok()) throw std::runtime_error("computeFrame: " + frame.error().message());
  return frame.value();
}

csm::CascadeFrame ShadowScene::recordShadow(VkCommandBuffer cmd, csm::DebugMode debug,
                                            bool worldSpaceKernel) {
  if (!built_) buildScene();
  useWorldSpaceKernel(*view_, worldSpaceKernel);
  view_->setDebugMode(debug);
  const csm::vk::Status s = view_->record(cmd, csmCamera(), light);
  if (!s.ok()) throw std::runtime_error("ShadowView::record: " + s.message());
  return view_->frame();
}

ShadowScene::Hit ShadowScene::trace(uint32_t x, uint32_t y) const {
  const glm::dmat4 inv = glm::inverse(glm::dmat4(camera.viewProjectionCr()));
  const VkExtent2D e = target_->extent();
  const glm::dvec4 ndc((x + 0.5) / e.width * 2.0 - 1.0, (y + 0.5) / e.height * 2.0 - 1.0, 0.5, 1.0);
  const glm::dvec4 p = inv * ndc;
  const glm::dvec3 d = glm::normalize(glm::dvec3(p) / p.w);
  const glm::dvec3 o = camera.positionWs;
  const glue::AnalyticShapes::RayHit ray = shapes.intersect(o, d);
  Hit hit;
  hit.plane = ray.plane;
  hit.hit = ray.t < std::numeric_limits<double>::infinity();
  if (hit.hit) hit.posWs = o + ray.t * d;
  return hit;
}

bool ShadowScene::shadowedAnalytic(const glm::dvec3& posWs) const {
  return shapes.occluded(posWs, -glm::normalize(light.directionWs));
}

bool ShadowScene::farFromEdge(const glm::dvec3& posWs, double radiusM,
                              const csm::CascadeFrame& frame) const {
  const bool here = shadowedAnalytic(posWs);
  const glm::dvec3 right = frame.lightBasisWs[0];
  const glm::dvec3 up = frame.lightBasisWs[1];
  for (double r : {radiusM, 0.5 * radiusM}) {
    for (int k = 0; k < 16; ++k) {
      const double a = 2.0 * glm::pi<double>() * k / 16.0;
      const glm::dvec3 q = posWs + r * (std::cos(a) * right + std::sin(a) * up);
      if (shadowedAnalytic(q) != here) return false;
    }
  }
  return true;
}

std::string ShadowScene::saveArtefact(const engine::CpuImage& image,
                                      const std::string& name) const {
  const std::filesystem::path dir = CSM_TEST_ARTEFACT_DIR;
  std::filesystem::create_directories(dir);
  const std::string path = (dir / (name + ".png")).string();
  engine::writePng(path, image);
  return path;
}

Agreement compareWithAnalytic(const ShadowScene& scene, const Rendered& r) {
  Agreement a;
  scene.forEachGroundPixel(
      r.image.width, r.image.height, [&](uint32_t x, uint32_t y, const glm::dvec3& posWs) {
        const csm::CascadeSelection sel = scene.selection(r.frame, posWs);
        if (sel.index < 0) return;
        double texel = r.frame.cascades[sel.index].texelSizeM();
        if (sel.blendIndex >= 0)
          texel = std::max(texel, r.frame.cascades[sel.blendIndex].texelSizeM());
        if (!scene.farFromEdge(posWs, 2.0 * texel, r.frame)) return;
        const bool analytic = scene.shadowedAnalytic(posWs);
        const bool gpu = r.image.at(x, y)[0] < 128;
        ++a.compared;
        a.shadowed += analytic ? 1 : 0;
        a.agreed += analytic == gpu ? 1 : 0;
      });
  return a;
}

csm::ShadowSettings testSettings(uint32_t cascades, uint32_t resolution) {
  csm::ShadowSettings s;
  s.cascadeCount = cascades;
  s.resolution = resolution;
  s.shadowDistanceM = 60.0;
  return s;
}

}  // namespace csm_test
