// The GPU side of the measurements (see harness.hpp).
#include "csm_measure/harness.hpp"

#include <csm_shaders/stability_accuracy.frag.spv.h>
#include <csm_shaders/stability_accuracy.vert.spv.h>
#include <csm_shaders/stability_accuracy_lod.frag.spv.h>
#include <csm/moments.hpp>
#include <csm/receiver_tiles.hpp>
#include <engine/debug.hpp>
#include <engine/errors.hpp>
#include <engine/gpu_timer.hpp>
#include <engine/headless_target.hpp>
#include <engine/memory.hpp>
#include <engine/mesh_store.hpp>
#include <engine/pipeline.hpp>
#include <engine/render_target.hpp>
#include <glue/camera.hpp>
#include <glue/lit_pass.hpp>
#include <glue/shadow_host.hpp>
#include <glue/shadow_probe.hpp>
#include <glue/vk_util.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>

namespace csm_measure {
namespace {

using glue::detail::vkStruct;

// stability_accuracy.frag's constant_id: the bias uses the shading normal (1) or the facet's.
constexpr uint32_t kSpecBiasFromShadingNormal = 16;

// Push constants of stability_accuracy.vert (112 bytes, under the 128-byte minimum).
struct AccuracyPush {
  glm::mat4 modelCr;
  glm::vec4 normalToWs[3];
};
static_assert(sizeof(AccuracyPush) == 112);

constexpr VkFormat kPositionFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kNormalFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kFootprintFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

}  // namespace

struct Harness::AccuracyPipeline {
  engine::GraphicsPipeline pipeline;
};

struct Harness::AccuracyTargets {
  engine::DeviceHandle<VkDescriptorSetLayout> layout;
  engine::DeviceHandle<VkDescriptorPool> pool;
  VkDescriptorSet set = VK_NULL_HANDLE;
  engine::Buffer frameUniforms;  // mat4 viewProjCr
  VkExtent2D extent{0, 0};
  engine::Image images[3];
  engine::Image depth;
  engine::Buffer readback[3];
};

Harness::Harness(const HarnessDesc& desc) {
  engine::ContextDesc cd;
  cd.appName = desc.appName;
  cd.validation = desc.validation;
  ctx_ = std::make_unique<engine::Context>(cd);
  view_ = glue::createShadowView(*ctx_, desc.momentAnisotropy);
  implicitLod_ = desc.implicitLod;
}

Harness::~Harness() {
  if (ctx_) ctx_->waitIdle();
  litPasses_.clear();
  timer_.reset();
  timingTarget_.reset();
  accuracyPipelines_.clear();
  accuracy_.reset();
  probe_.reset();
  view_.reset();
  gpu_.store.reset();
  if (ctx_) ctx_->shutdown();
}

void Harness::setScene(const Scene& scene) {
  ctx_->waitIdle();
  gpu_ = glue::uploadScene(*ctx_, scene, "measure meshes");
  instances_ = scene.instances();
  casterSet_ = scene.casterSet();
  const csm::AabbWs bounds = scene.boundsWs();
  csm::vk::Status s = view_->setCasters(gpu_.meshDraws, gpu_.casters, casterSet_);
  if (s.ok()) s = view_->setSceneBounds(&bounds);
  if (!s.ok()) throw std::runtime_error("ShadowView: " + s.message());
  cascadeLod_ = {};
  if (view_->renderer().ready()) {
    options_.cascadeLod = {};
    s = view_->setSettings(view_->settings(), options_);
    if (!s.ok()) throw std::runtime_error("ShadowView::setSettings: " + s.message());
  }
}

void Harness::setCasterLods(std::vector<std::vector<uint32_t>> lodMeshes,
                            const std::array<uint32_t, csm::kMaxCascades>& cascadeLod,
                            const std::vector<std::vector<float>>& lodErrorM) {
  if (!lodErrorM.empty() && lodErrorM.size() != lodMeshes.size()) {
    throw std::invalid_argument("setCasterLods: " + std::to_string(lodErrorM.size()) +
                                " LOD error lists for " + std::to_string(lodMeshes.size()) +
                                " LOD lists: one per instance or none required");
  }
  if (!lodMeshes.empty() && lodMeshes.size() != instances_.size()) {
    throw std::invalid_argument("setCasterLods: " + std::to_string(lodMeshes.size()) +
                                " LOD lists for " + std::to_string(instances_.size()) +
                                " instances: one per instance required");
  }
  for (size_t i = 0; i < lodMeshes.size(); ++i) {
    if (lodMeshes[i].empty() || lodMeshes[i].size() > csm::vk::kMaxCasterLods) {
      throw std::invalid_argument("setCasterLods: instance " + std::to_string(i) + " has " +
                                  std::to_string(lodMeshes[i].size()) +
                                  " LOD meshes: allowed [1, " +
                                  std::to_string(csm::vk::kMaxCasterLods) + "]");
    }
    for (uint32_t m : lodMeshes[i]) {
      if (m >= gpu_.meshDraws.size()) {
        throw std::invalid_argument("setCasterLods: instance " + std::to_string(i) + " mesh " +
                                    std::to_string(m) + " is out of range: allowed [0, " +
                                    std::to_string(gpu_.meshDraws.size()) + ")");
      }
    }
  }
  // LOD 0 of the module's instance is the instance's LOD-0 mesh; LODs off: the own mesh only.
  std::vector<csm::vk::CasterInstance> casters = gpu_.casters;
  for (size_t i = 0; i < lodMeshes.size(); ++i) {
    casters[i].mesh = lodMeshes[i][0];
    for (uint32_t k = 1; k < csm::vk::kMaxCasterLods; ++k) {
      casters[i].lodMeshes[k - 1] = k < lodMeshes[i].size() ? lodMeshes[i][k] : csm::vk::kNoMesh;
      casters[i].lodErrorM[k - 1] = !lodErrorM.empty() && k < lodErrorM[i].size()
                                        ? lodErrorM[i][k]
                                        : csm::vk::kUnknownLodError;
    }
  }
  csm::vk::Status s = view_->setCasters(gpu_.meshDraws, casters, casterSet_);
  cascadeLod_ = lodMeshes.empty() ? std::array<uint32_t, csm::kMaxCascades>{} : cascadeLod;
  options_.cascadeLod = cascadeLod_;
  for (uint32_t& l : options_.cascadeLod) l = std::min(l, csm::vk::kMaxCasterLods - 1);
  if (s.ok() && view_->renderer().ready()) s = view_->setSettings(view_->settings(), options_);
  if (!s.ok()) throw std::invalid_argument("setCasterLods: " + s.message());
}

csm::vk::Status Harness::configure(const csm::ShadowSettings& settings,
                                   const csm::vk::RendererOptions& options) {
  // The caster LODs of setCasterLods() stay in force.
  csm::vk::RendererOptions withLods = options;
  withLods.cascadeLod = options_.cascadeLod;
  // CSM_SHADOW_CACHE=1: every measurement through cached cascades (the stability tests run
  // once more so, ctest stability.cached.*), except where a layered pass is asked for.
  if (const char* cache = std::getenv("CSM_SHADOW_CACHE");
      cache != nullptr && std::string(cache) == "1" &&
      options.renderMode != csm::vk::RenderMode::kLayered && settings.diagnostics.stabilize) {
    withLods.cache = true;
  }
  // CSM_SHADOW_TILES=1: cached and with receiver-marked tiles wherever they are allowed (a
  // depth-comparison kernel); probe() marks the tiles its receivers sample for the next frame,
  // a frame late, as a host's reduction of its depth buffer at best would (ctest
  // stability.tiles.*). The first probe after configure() (a run starts with a jump: a camera
  // cut) marks its own frame, so the cut's fallback is not counted as shimmer.
  if (const char* tiles = std::getenv("CSM_SHADOW_TILES");
      tiles != nullptr && std::string(tiles) == "1" &&
      options.renderMode != csm::vk::RenderMode::kLayered && settings.diagnostics.stabilize &&
      !csm::isPrefiltered(settings.kernel)) {
    withLods.cache = true;
    withLods.tiles = true;
  }
  const csm::vk::Status s = view_->setSettings(settings, withLods);
  if (s.ok()) {
    options_ = withLods;
    view_->setReceiverTiles(std::nullopt);  // marks of other settings
    tilesMarked_ = false;
  }
  return s;
}

uint64_t Harness::shadowMapBytes() const {
  const csm::ShadowSettings& settings = view_->settings();
  return uint64_t(settings.resolution) * settings.resolution * settings.cascadeCount *
             engine::bytesPerTexel(view_->renderer().depthFormat()) +
         view_->renderer().momentBytes();
}

csm::CascadeFrame Harness::computeFrame(const csm::Camera& camera,
                                        const csm::DirectionalLight& light,
                                        csm::CascadeHistory& history) {
  csm::Result<csm::CascadeFrame> frame = view_->computeFrame(camera, light, &history);
  if (!frame.ok()) throw std::runtime_error("computeCascades: " + frame.error().message());
  return frame.value();
}

void Harness::recordShadow(VkCommandBuffer cmd, const csm::CascadeFrame& frame) {
  view_->setDebugMode(csm::DebugMode::kNone);
  const csm::vk::Status s = view_->record(cmd, frame);
  if (!s.ok()) throw std::runtime_error("ShadowView::record: " + s.message());
  // Triangles drawn: each cascade's culled casters at the LOD the module chose for them there.
  shadowTriangles_ = 0;
  for (uint32_t c = 0; c < frame.cascadeCount; ++c) {
    const csm::Cascade& cascade = frame.cascades[c];
    if (cascade.empty) continue;
    const std::span<const csm::vk::CasterInstance> casters = view_->instances();
    for (uint32_t i : view_->cull().visible[c]) {
      const uint32_t lod = csm::vk::casterLod(
          casters[i], options_.cascadeLod[c],
          std::min(cascade.texelSizeLs.x, cascade.texelSizeLs.y), options_.lodMaxErrorTexels);
      shadowTriangles_ += gpu_.meshDraws[casters[i].meshForLod(lod)].indexCount / 3;
    }
  }
}

// ---- probe ----------------------------------------------------------------------------------

std::vector<ProbeResult> Harness::probe(const csm::CascadeFrame& frame,
                                        std::span<const Receiver> receivers, csm::PcfKernel kernel,
                                        bool blend, std::span<const glm::vec2> pixels) {
  if (!pixels.empty() && pixels.size() != receivers.size()) {
    throw std::invalid_argument("probe: " + std::to_string(pixels.size()) + " pixels for " +
                                std::to_string(receivers.size()) + " receivers");
  }
  if (!probe_) probe_ = std::make_unique<glue::ShadowProbe>(*ctx_, view_->lightingSetLayout());
  std::vector<glue::ProbePoint> points(receivers.size());
  for (size_t i = 0; i < receivers.size(); ++i) {
    // Camera-relative in double, rounded to float once.
    points[i].posCr = glm::vec3(receivers[i].posWs - frame.cameraPositionWs);
    points[i].normalWs = receivers[i].normalWs;
    if (!pixels.empty()) points[i].pixel = pixels[i];
  }
  probe_->setPoints(points);
  // CSM_SHADOW_TILES=1: the tiles these receivers sample, for the next frame (and this one when
  // it is the first since configure()).
  std::optional<csm::ReceiverTileMarks> marks;
  if (options_.tiles) {
    std::vector<glm::dvec3> receiversWs(receivers.size());
    for (size_t i = 0; i < receivers.size(); ++i) receiversWs[i] = receivers[i].posWs;
    marks = receiverTileMarks(frame, receiversWs);
    if (!tilesMarked_) view_->setReceiverTiles(marks);
  }
  ctx_->submitAndWait([&](VkCommandBuffer cmd) {
    recordShadow(cmd, frame);
    probe_->record(cmd, view_->lightingSet(), kernel, blend);
  });
  if (marks) {
    view_->setReceiverTiles(std::move(marks));
    tilesMarked_ = true;
  }
  return probe_->results();
}

// ---- accuracy frame -------------------------------------------------------------------------

void Harness::ensureAccuracyTargets(VkExtent2D extent) {
  VkDevice dev = ctx_->device();
  if (!accuracy_) {
    accuracy_ = std::make_unique<AccuracyTargets>();
    const VkDescriptorSetLayoutBinding b{0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1,
                                         VK_SHADER_STAGE_VERTEX_BIT, nullptr};
    accuracy_->layout =
        engine::createDescriptorSetLayout(dev, std::span(&b, 1), "measure.accuracy.layout");
    accuracy_->pool = glue::detail::makeDescriptorPool(dev, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1,
                                                       "measure.accuracy.pool");
    accuracy_->set = glue::detail::allocateDescriptorSet(dev, accuracy_->pool, accuracy_->layout,
                                                         "measure.accuracy.set");
    accuracy_->frameUniforms =
        engine::Buffer(*ctx_, sizeof(glm::mat4), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                       engine::MemoryUsage::Upload, "measure.accuracy.frameUniforms");
    glue::detail::writeBufferDescriptor(dev, accuracy_->set, 0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER,
                                        accuracy_->frameUniforms.handle());
  }
  if (accuracy_->extent.width == extent.width && accuracy_->extent.height == extent.height) return;
  ctx_->waitIdle();
  const VkFormat formats[3] = {kPositionFormat, kNormalFormat, kFootprintFormat};
  const char* names[3] = {"measure.accuracy.positionShadow", "measure.accuracy.normalCascade",
                          "measure.accuracy.footprint"};
  for (int i = 0; i < 3; ++i) {
    engine::ImageDesc d;
    d.format = formats[i];
    d.extent = extent;
    d.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    accuracy_->images[i] = engine::Image(*ctx_, d, names[i]);
    accuracy_->readback[i] = engine::Buffer(
        *ctx_, VkDeviceSize(extent.width) * extent.height * engine::bytesPerTexel(formats[i]),
        VK_BUFFER_USAGE_TRANSFER_DST_BIT, engine::MemoryUsage::Readback,
        std::string(names[i]) + ".readback");
  }
  engine::ImageDesc dd;
  dd.format = kDepthFormat;
  dd.extent = extent;
  dd.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
  accuracy_->depth = engine::Image(*ctx_, dd, "measure.accuracy.depth");
  accuracy_->extent = extent;
}

Harness::AccuracyPipeline& Harness::accuracyPipeline(csm::PcfKernel kernel, bool blend) {
  auto& p = accuracyPipelines_[{uint32_t(kernel) | (biasFromShadingNormal_ ? 0x100u : 0u), blend}];
  if (p) return *p;
  p = std::make_unique<AccuracyPipeline>();
  VkDevice dev = ctx_->device();
  const auto vert =
      engine::createShaderModule(dev, stability_accuracy_vert_spv, "stability_accuracy.vert");
  const auto frag = implicitLod_ ? engine::createShaderModule(dev, stability_accuracy_lod_frag_spv,
                                                              "stability_accuracy_lod.frag")
                                 : engine::createShaderModule(dev, stability_accuracy_frag_spv,
                                                              "stability_accuracy.frag");
  const VkVertexInputBindingDescription binding = engine::MeshStore::bindingDescription();
  const VkFormat formats[3] = {kPositionFormat, kNormalFormat, kFootprintFormat};
  engine::GraphicsPipelineBuilder builder;
  builder.vertexShader(vert)
      .fragmentShader(frag)
      .vertexInput(std::span(&binding, 1), engine::MeshStore::attributeDescriptions())
      .colorFormats(formats)
      .depthFormat(kDepthFormat)
      .depthTest(true, true, VK_COMPARE_OP_LESS)
      .pushConstants(VK_SHADER_STAGE_VERTEX_BIT, sizeof(AccuracyPush))
      .descriptorSetLayout(accuracy_->layout)
      .descriptorSetLayout(view_->lightingSetLayout())
      .specialization(VK_SHADER_STAGE_FRAGMENT_BIT, CSM_SPEC_KERNEL, uint32_t(kernel))
      .specialization(VK_SHADER_STAGE_FRAGMENT_BIT, CSM_SPEC_BLEND, blend ? 1u : 0u)
      .specialization(VK_SHADER_STAGE_FRAGMENT_BIT, kSpecBiasFromShadingNormal,
                      biasFromShadingNormal_ ? 1u : 0u);
  p->pipeline = builder.build(*ctx_, std::string("measure.accuracy.") + csm::kernelName(kernel) +
                                         (blend ? ".blend" : ".switch"));
  return *p;
}

std::vector<PixelSample> Harness::renderAccuracy(const csm::Camera& camera,
                                                 const csm::CascadeFrame& frame, VkExtent2D extent,
                                                 csm::PcfKernel kernel, bool blend,
                                                 engine::CpuImage* shadowImage) {
  ensureAccuracyTargets(extent);
  AccuracyPipeline& pipeline = accuracyPipeline(kernel, blend);
  const engine::Camera cam = glue::toEngineCamera(camera);
  const glm::mat4 viewProjCr = cam.viewProjectionCr();
  std::memcpy(accuracy_->frameUniforms.mapped(), &viewProjCr, sizeof(viewProjCr));
  const auto render = [&](engine::CpuImage* image) {
    ctx_->submitAndWait([&](VkCommandBuffer cmd) {
      recordShadow(cmd, frame);
      recordAccuracyPass(cmd, camera.positionWs, extent, pipeline);
    });
    return readAccuracySamples(camera.positionWs, extent, image);
  };
  if (!options_.tiles) return render(shadowImage);
  // Receiver-marked tiles: the frame once to find its pixels, then again with the layers holding
  // only the tiles those pixels mark (every static texel invalidated, so each partial cascade
  // draws exactly its marked tiles): the steady state of a view whose marks are current. The
  // settings' kernel is the one lit with, as a host's lighting pipeline takes it from the view
  // (the marks' and the fallback's reach follow it).
  if (view_->settings().kernel != kernel) {
    csm::ShadowSettings settings = view_->settings();
    settings.kernel = kernel;
    const csm::vk::Status s = view_->setSettings(settings, options_);
    if (!s.ok()) throw std::runtime_error("renderAccuracy: " + s.message());
  }
  const std::vector<PixelSample> first = render(nullptr);
  std::vector<glm::dvec3> receivers;
  receivers.reserve(first.size());
  for (const PixelSample& p : first) {
    if (!tileMarkFilter_ || tileMarkFilter_(p.x, p.y)) receivers.push_back(p.posWs);
  }
  view_->setReceiverTiles(receiverTileMarks(frame, receivers));
  view_->invalidateAll();
  tilesMarked_ = true;
  return render(shadowImage);
}

csm::ReceiverTileMarks Harness::receiverTileMarks(const csm::CascadeFrame& frame,
                                                  std::span<const glm::dvec3> receiversWs) const {
  csm::ReceiverTileMarks marks = csm::emptyReceiverTileMarks(view_->settings(), frame);
  for (const glm::dvec3& p : receiversWs) {
    csm::markReceiverTiles(marks, p, glm::dot(p - frame.cameraPositionWs, frame.cameraForwardWs));
  }
  return marks;
}

void Harness::recordAccuracyPass(VkCommandBuffer cmd, const glm::dvec3& cameraWs, VkExtent2D extent,
                                 AccuracyPipeline& pipeline) {
  AccuracyTargets& t = *accuracy_;
  for (auto& image : t.images) {
    engine::imageBarrier(cmd, image.handle(), VK_IMAGE_ASPECT_COLOR_BIT,
                         VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE,
                         VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                         VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                         VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
  }
  engine::imageBarrier(
      cmd, t.depth.handle(), VK_IMAGE_ASPECT_DEPTH_BIT, VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
          VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
      VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
  {
    engine::ScopedLabel label(cmd, "measure accuracy pass");
    VkRenderingAttachmentInfo color[3];
    for (int i = 0; i < 3; ++i) {
      color[i] = vkStruct<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
      color[i].imageView = t.images[i].view();
      color[i].imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
      color[i].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
      color[i].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
      color[i].clearValue.color = VkClearColorValue{{0.0f, 0.0f, 0.0f, 0.0f}};
    }
    auto depth = vkStruct<VkRenderingAttachmentInfo>(VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO);
    depth.imageView = t.depth.view();
    depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    depth.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    depth.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    depth.clearValue.depthStencil = {1.0f, 0};
    auto ri = vkStruct<VkRenderingInfo>(VK_STRUCTURE_TYPE_RENDERING_INFO);
    ri.renderArea = {{0, 0}, extent};
    ri.layerCount = 1;
    ri.colorAttachmentCount = 3;
    ri.pColorAttachments = color;
    ri.pDepthAttachment = &depth;
    vkCmdBeginRendering(cmd, &ri);
    engine::setViewportAndScissor(cmd, extent);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.pipeline.pipeline);
    const VkDescriptorSet sets[2] = {t.set, view_->lightingSet()};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline.pipeline.layout, 0, 2,
                            sets, 0, nullptr);
    gpu_.store->bind(cmd);
    for (const Instance& in : instances_) {
      AccuracyPush push{};
      push.modelCr = glm::mat4(in.linearWs);
      push.modelCr[3] = glm::vec4(glm::vec3(in.translationWs - cameraWs), 1.0f);
      const glm::mat3 normalMatrix = glm::transpose(glm::inverse(in.linearWs));
      for (int i = 0; i < 3; ++i) push.normalToWs[i] = glm::vec4(normalMatrix[i], 0.0f);
      vkCmdPushConstants(cmd, pipeline.pipeline.layout, VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(push),
                         &push);
      const engine::MeshRange& m = gpu_.ranges[in.mesh];
      vkCmdDrawIndexed(cmd, m.indexCount, 1, m.firstIndex, m.vertexOffset, 0);
    }
    vkCmdEndRendering(cmd);
  }
  for (int i = 0; i < 3; ++i) {
    engine::imageBarrier(cmd, t.images[i].handle(), VK_IMAGE_ASPECT_COLOR_BIT,
                         VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                         VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
                         VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                         VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {extent.width, extent.height, 1};
    vkCmdCopyImageToBuffer(cmd, t.images[i].handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                           t.readback[i].handle(), 1, &region);
  }
  engine::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                        VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

std::vector<PixelSample> Harness::readAccuracySamples(const glm::dvec3& cameraWs, VkExtent2D extent,
                                                      engine::CpuImage* shadowImage) const {
  const AccuracyTargets& t = *accuracy_;
  const auto* pos = static_cast<const glm::vec4*>(t.readback[0].mapped());
  const auto* nrm = static_cast<const glm::vec4*>(t.readback[1].mapped());
  const auto* fp = static_cast<const glm::vec4*>(t.readback[2].mapped());
  std::vector<PixelSample> out;
  if (shadowImage) {
    shadowImage->width = extent.width;
    shadowImage->height = extent.height;
    shadowImage->rgba.assign(size_t(extent.width) * extent.height * 4, 0);
  }
  for (uint32_t y = 0; y < extent.height; ++y) {
    for (uint32_t x = 0; x < extent.width; ++x) {
      const size_t i = size_t(y) * extent.width + x;
      const bool surface = fp[i].w > 0.5f;
      if (shadowImage) {
        uint8_t* px = &shadowImage->rgba[4 * i];
        if (surface) {
          const float s = std::isfinite(pos[i].w) ? std::clamp(pos[i].w, 0.0f, 1.0f) : 0.0f;
          const auto g = uint8_t(std::lround(40.0f + 215.0f * s));
          px[0] = px[1] = px[2] = g;
        } else {
          px[0] = 20;
          px[1] = 20;
          px[2] = 60;
        }
        px[3] = 255;
      }
      if (!surface) continue;
      PixelSample p;
      p.x = x;
      p.y = y;
      p.posWs = cameraWs + glm::dvec3(glm::vec3(pos[i]));
      p.normalWs = glm::vec3(nrm[i]);
      p.shadow = pos[i].w;
      p.cascade = std::isfinite(nrm[i].w) ? int(std::lround(nrm[i].w)) : -2;
      p.blendCascade = std::isfinite(fp[i].y) ? int(std::lround(fp[i].y)) : -2;
      p.blendWeight = fp[i].z;
      p.footprintM = fp[i].x;
      out.push_back(p);
    }
  }
  return out;
}

// ---- timing ---------------------------------------------------------------------------------

void Harness::ensureTimingTarget(VkExtent2D extent) {
  if (timingTarget_ && timingTarget_->extent().width == extent.width &&
      timingTarget_->extent().height == extent.height) {
    return;
  }
  ctx_->waitIdle();
  litPasses_.clear();
  timingTarget_.reset();
  engine::HeadlessDesc hd;
  hd.extent = extent;
  timingTarget_ = std::make_unique<engine::HeadlessTarget>(*ctx_, hd);
  if (!timer_) timer_ = std::make_unique<engine::GpuTimer>(*ctx_, 4);
}

FrameTimings Harness::timeFrame(const csm::Camera& camera, const csm::DirectionalLight& light,
                                csm::CascadeHistory& history, VkExtent2D extent,
                                csm::PcfKernel kernel, bool blend) {
  ensureTimingTarget(extent);
  auto& lit = litPasses_[{uint32_t(kernel), blend}];
  if (!lit) {
    lit = glue::makeLitPass(*ctx_, timingTarget_->colorFormat(), timingTarget_->depthFormat(),
                            view_->lightingSetLayout(), kernel, blend);
  }
  FrameTimings out;
  const auto t0 = std::chrono::steady_clock::now();
  const csm::CascadeFrame frame = computeFrame(camera, light, history);
  std::optional<engine::Frame> f = timingTarget_->beginFrame();
  if (!f) throw std::runtime_error("beginFrame returned no frame");
  timer_->beginFrame(f->cmd, f->slot);
  timer_->begin(f->cmd, "shadow");
  recordShadow(f->cmd, frame);
  timer_->end(f->cmd, "shadow");
  out.cpuMs =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const engine::Camera cam = glue::toEngineCamera(camera);
  glue::LitFrame lf;
  lf.viewProjCr = cam.viewProjectionCr();
  lf.cameraPositionWs = camera.positionWs;
  lf.lightDirectionWs = glm::vec3(light.directionWs);
  glue::recordTimedLitPass(*lit, *timer_, *f, lf, *gpu_.store, view_->lightingSet(), gpu_.litDraws);
  const uint32_t slot = f->slot;
  timingTarget_->endFrame();
  timingTarget_->waitIdle();
  timer_->collect(slot);
  const auto& r = timer_->results();
  if (auto it = r.find("shadow"); it != r.end()) out.shadowGpuMs = it->second;
  if (auto it = r.find("lit"); it != r.end()) out.litGpuMs = it->second;
  return out;
}

}  // namespace csm_measure
