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

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Ray (o, d) against a sphere: nearest t > tMin, or +inf.
double raySphere(const glm::dvec3& o, const glm::dvec3& d, const SphereWs& s, double tMin) {
  const glm::dvec3 oc = o - s.centerWs;
  const double b = glm::dot(oc, d);
  const double c = glm::dot(oc, oc) - s.radiusM * s.radiusM;
  const double disc = b * b - c * glm::dot(d, d);
  if (disc < 0.0) return kInf;
  const double sq = std::sqrt(disc);
  const double dd = glm::dot(d, d);
  const double t0 = (-b - sq) / dd;
  const double t1 = (-b + sq) / dd;
  if (t0 > tMin) return t0;
  if (t1 > tMin) return t1;
  return kInf;
}

// Ray against an AABB (slabs): nearest t > tMin, or +inf.
double rayBox(const glm::dvec3& o, const glm::dvec3& d, const csm::AabbWs& b, double tMin) {
  double t0 = -kInf, t1 = kInf;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-300) {
      if (o[a] < b.minWs[a] || o[a] > b.maxWs[a]) return kInf;
      continue;
    }
    double ta = (b.minWs[a] - o[a]) / d[a];
    double tb = (b.maxWs[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1) return kInf;
  if (t0 > tMin) return t0;
  if (t1 > tMin) return t1;
  return kInf;
}

}  // namespace

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
  meshes_ = std::make_unique<engine::MeshStore>(*ctx_, 1 << 16, 1 << 18, "shadow test meshes");

  camera.positionWs = {0.0, 6.0, 6.0};
  camera.lookAt({0.0, 0.0, -12.0});
  camera.aspect = double(width) / double(height);
  camera.nearM = 0.1;
  camera.farM = 200.0;
  light.directionWs = glm::normalize(glm::dvec3(0.6, -1.0, -0.35));
  spheres = {{{-2.0, 2.2, -6.0}, 1.2}, {{3.0, 3.5, -22.0}, 2.0}};
  boxes = {{{1.5, 1.0, -9.5}, {3.5, 2.5, -7.5}},
           {{-6.0, 1.5, -30.0}, {-3.0, 3.0, -27.0}},
           // A long rail along the view direction: its shadow edge runs through every cascade.
           {{4.2, 1.5, -45.0}, {4.8, 2.0, 3.0}}};

  view_ = glue::createShadowView(*ctx_);
}

ShadowScene::~ShadowScene() {
  if (ctx_) ctx_->waitIdle();
  litPasses_.clear();
  second_.reset();
  view_.reset();
  meshes_.reset();
  target_.reset();
  if (ctx_) ctx_->shutdown();
}

csm::Camera ShadowScene::csmCamera() const {
  return glue::toCsmCamera(camera);
}

void ShadowScene::buildScene() {
  std::vector<engine::Vertex> v;
  std::vector<uint32_t> idx;
  // Ground: a 2 x 2 quad in xz scaled by the instance.
  v = {{{-1, 0, -1}, {0, 1, 0}},
       {{1, 0, -1}, {0, 1, 0}},
       {{1, 0, 1}, {0, 1, 0}},
       {{-1, 0, 1}, {0, 1, 0}}};
  idx = {0, 2, 1, 0, 3, 2};
  planeMesh_ = meshes_->upload(v, idx);
  engine::makeSphere(v, idx, 96, 48);
  sphereMesh_ = meshes_->upload(v, idx);
  engine::makeCube(v, idx);
  cubeMesh_ = meshes_->upload(v, idx);

  auto meshDraw = [&](const engine::MeshRange& m) {
    csm::vk::MeshDraw d;
    d.vertexBuffer = meshes_->vertexBuffer();
    d.indexBuffer = meshes_->indexBuffer();
    d.firstIndex = m.firstIndex;
    d.indexCount = m.indexCount;
    d.vertexOffset = m.vertexOffset;
    return d;
  };
  casterMeshes_ = {meshDraw(planeMesh_), meshDraw(sphereMesh_), meshDraw(cubeMesh_)};
  std::vector<csm::vk::CasterInstance>& casters = casters_;
  std::vector<csm::AabbWs>& bounds = casterBounds_;
  auto add = [&](uint32_t mesh, const engine::MeshRange& range, const glm::dvec3& t,
                 const glm::dvec3& scale, const glm::vec4& color, const csm::AabbWs& box) {
    const glm::mat3 linear(glm::vec3(scale.x, 0, 0), glm::vec3(0, scale.y, 0),
                           glm::vec3(0, 0, scale.z));
    casters.push_back({mesh, t, linear});
    litDraws_.push_back({range, t, linear, color});
    bounds.push_back(box);
  };
  // The ground receives and casts (so that self-shadowing acne would show).
  add(0, planeMesh_, planeCenterWs, {planeHalfM, 1.0, planeHalfM}, {0.8f, 0.8f, 0.8f, 1.0f},
      {planeCenterWs - glm::dvec3(planeHalfM, 0.0, planeHalfM),
       planeCenterWs + glm::dvec3(planeHalfM, 0.0, planeHalfM)});
  for (const SphereWs& s : spheres) {
    add(1, sphereMesh_, s.centerWs, glm::dvec3(s.radiusM), {0.9f, 0.3f, 0.2f, 1.0f},
        {s.centerWs - glm::dvec3(s.radiusM), s.centerWs + glm::dvec3(s.radiusM)});
  }
  for (const csm::AabbWs& b : boxes) {
    add(2, cubeMesh_, 0.5 * (b.minWs + b.maxWs), b.maxWs - b.minWs, {0.2f, 0.4f, 0.9f, 1.0f}, b);
  }
  sceneBounds.minWs = planeCenterWs - glm::dvec3(planeHalfM, 0.0, planeHalfM);
  sceneBounds.maxWs = planeCenterWs + glm::dvec3(planeHalfM, 6.0, planeHalfM);
  csm::vk::Status s = view_->setCasters(casterMeshes_, casters, bounds);
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
  if (s.ok()) s = second_->setCasters(casterMeshes_, casters_, casterBounds_);
  if (s.ok()) s = second_->setSceneBounds(&sceneBounds);
  if (!s.ok()) throw std::runtime_error("second ShadowView: " + s.message());
}

void ShadowScene::destroyView() {
  view_.reset();
}

Rendered ShadowScene::renderFrame(csm::PcfKernel kernel, const FrameHooks& hooks) {
  if (!built_) buildScene();
  const auto key = std::make_pair(static_cast<uint32_t>(kernel), hooks.blend ? 1u : 0u);
  auto& lit = litPasses_[key];
  if (!lit) {
    glue::LitPassDesc desc;
    desc.colorFormat = target_->colorFormat();
    desc.depthFormat = target_->depthFormat();
    desc.shadowSetLayout = view_->lightingSetLayout();
    desc.specialization = {{CSM_SPEC_KERNEL, key.first}, {CSM_SPEC_BLEND, key.second}};
    lit = std::make_unique<glue::LitPass>(*ctx_, desc);
  }

  Rendered out;
  std::optional<engine::Frame> f = target_->beginFrame();
  if (!f) throw std::runtime_error("beginFrame returned no frame");
  csm::CascadeFrame secondFrame;
  if (second_) {
    // Split screen: the second view records into the same command buffer, first.
    second_->setUniformOptions({hooks.debug, hooks.worldSpaceKernel});
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
  lit->draw(f->cmd, *meshes_, useSecond ? second_->lightingSet() : view_->lightingSet(), litDraws_,
            f->extent);
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
  view_->setUniformOptions({debug, worldSpaceKernel});
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
  Hit hit;
  double best = kInf;
  if (d.y < 0.0) {
    const double t = -o.y / d.y;
    const glm::dvec3 q = o + t * d;
    if (std::abs(q.x - planeCenterWs.x) <= planeHalfM &&
        std::abs(q.z - planeCenterWs.z) <= planeHalfM) {
      best = t;
      hit.plane = true;
    }
  }
  for (const SphereWs& s : spheres) {
    const double t = raySphere(o, d, s, 0.0);
    if (t < best) {
      best = t;
      hit.plane = false;
    }
  }
  for (const csm::AabbWs& b : boxes) {
    const double t = rayBox(o, d, b, 0.0);
    if (t < best) {
      best = t;
      hit.plane = false;
    }
  }
  hit.hit = best < kInf;
  if (hit.hit) hit.posWs = o + best * d;
  return hit;
}

bool ShadowScene::shadowedAnalytic(const glm::dvec3& posWs) const {
  const glm::dvec3 toLight = -glm::normalize(light.directionWs);
  for (const SphereWs& s : spheres) {
    if (raySphere(posWs, toLight, s, 1e-6) < kInf) return true;
  }
  for (const csm::AabbWs& b : boxes) {
    if (rayBox(posWs, toLight, b, 1e-6) < kInf) return true;
  }
  return false;
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
  for (uint32_t y = 0; y < r.image.height; ++y) {
    for (uint32_t x = 0; x < r.image.width; ++x) {
      const ShadowScene::Hit hit = scene.trace(x, y);
      if (!hit.hit || !hit.plane) continue;
      const csm::CascadeSelection sel = csm::selectCascade(
          r.frame, csm::viewDepthM(r.frame, hit.posWs), scene.settings().blendBand);
      if (sel.index < 0) continue;
      double texel = r.frame.cascades[sel.index].texelSizeM();
      if (sel.blendIndex >= 0)
        texel = std::max(texel, r.frame.cascades[sel.blendIndex].texelSizeM());
      if (!scene.farFromEdge(hit.posWs, 2.0 * texel, r.frame)) continue;
      const bool analytic = scene.shadowedAnalytic(hit.posWs);
      const bool gpu = r.image.at(x, y)[0] < 128;
      ++a.compared;
      a.shadowed += analytic ? 1 : 0;
      a.agreed += analytic == gpu ? 1 : 0;
    }
  }
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
