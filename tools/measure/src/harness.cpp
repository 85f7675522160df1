// The GPU side of the measurements (see harness.hpp).
#include "csm_measure/harness.hpp"

#include <csm_shaders/stability_accuracy.frag.spv.h>
#include <csm_shaders/stability_accuracy.vert.spv.h>
#include <csm_shaders/stability_probe.comp.spv.h>
#include <engine/debug.hpp>
#include <engine/errors.hpp>
#include <engine/gpu_timer.hpp>
#include <engine/headless_target.hpp>
#include <engine/lit_pass.hpp>
#include <engine/memory.hpp>
#include <engine/mesh_store.hpp>
#include <engine/pipeline.hpp>
#include <engine/render_target.hpp>
#include <sample_world/shadow_host.hpp>

#include <algorithm>
#include <cstdlib>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

namespace csm_measure {
namespace {

template <class T>
T vkStruct(VkStructureType type) {
  T v{};
  v.sType = type;
  return v;
}

// stability_accuracy.frag's constant_id: the bias uses the shading normal (1) or the facet's.
constexpr uint32_t kSpecBiasFromShadingNormal = 16;

// Push constants of stability_accuracy.vert (112 bytes, under the 128-byte minimum).
struct AccuracyPush {
  glm::mat4 modelCr;
  glm::vec4 normalToWs[3];
};
static_assert(sizeof(AccuracyPush) == 112);

// std430 element of stability_probe.comp's Points buffer.
struct ProbePointGpu {
  glm::vec4 posCr;
  glm::vec4 normalWs;
};

constexpr VkFormat kPositionFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kNormalFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kFootprintFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

engine::DeviceHandle<VkDescriptorPool> makePool(VkDevice dev, VkDescriptorType type, uint32_t n,
                                                const char* name) {
  VkDescriptorPoolSize size{type, n};
  auto pi = vkStruct<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  pi.maxSets = 1;
  pi.poolSizeCount = 1;
  pi.pPoolSizes = &size;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreateDescriptorPool(dev, &pi, nullptr, &pool));
  engine::setDebugName(dev, pool, name);
  return engine::DeviceHandle<VkDescriptorPool>(dev, pool, vkDestroyDescriptorPool);
}

VkDescriptorSet allocateSet(VkDevice dev, VkDescriptorPool pool, VkDescriptorSetLayout layout,
                            const char* name) {
  auto ai = vkStruct<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  ai.descriptorPool = pool;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &layout;
  VkDescriptorSet set = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkAllocateDescriptorSets(dev, &ai, &set));
  engine::setDebugName(dev, set, name);
  return set;
}

void writeBuffer(VkDevice dev, VkDescriptorSet set, uint32_t binding, VkDescriptorType type,
                 VkBuffer buffer) {
  VkDescriptorBufferInfo info{buffer, 0, VK_WHOLE_SIZE};
  auto w = vkStruct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
  w.dstSet = set;
  w.dstBinding = binding;
  w.descriptorCount = 1;
  w.descriptorType = type;
  w.pBufferInfo = &info;
  vkUpdateDescriptorSets(dev, 1, &w, 0, nullptr);
}

}  // namespace

engine::Camera toEngineCamera(const csm::Camera& c) {
  engine::Camera e;
  e.positionWs = c.positionWs;
  e.orientation = c.orientationWs;
  e.fovYRad = c.fovYRad;
  e.aspect = c.aspect;
  e.nearM = c.nearM;
  e.farM = c.farM;
  return e;
}

struct Harness::Probe {
  engine::DeviceHandle<VkDescriptorSetLayout> layout;
  engine::DeviceHandle<VkDescriptorPool> pool;
  VkDescriptorSet set = VK_NULL_HANDLE;
  engine::DeviceHandle<VkPipelineLayout> pipelineLayout;
  engine::Buffer points;
  engine::Buffer results;
  uint32_t capacity = 0;
};

struct Harness::ProbePipeline {
  engine::DeviceHandle<VkPipeline> pipeline;
};

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
  view_ = world::createShadowView(*ctx_);
}

Harness::~Harness() {
  if (ctx_) ctx_->waitIdle();
  litPasses_.clear();
  timer_.reset();
  timingTarget_.reset();
  accuracyPipelines_.clear();
  accuracy_.reset();
  probePipelines_.clear();
  probe_.reset();
  view_.reset();
  meshes_.reset();
  if (ctx_) ctx_->shutdown();
}

void Harness::setScene(const Scene& scene) {
  ctx_->waitIdle();
  uint64_t vertices = 0, indices = 0;
  for (const MeshData& m : scene.meshes()) {
    vertices += m.vertices.size();
    indices += m.indices.size();
  }
  meshes_ = std::make_unique<engine::MeshStore>(*ctx_, uint32_t(vertices + 16),
                                                uint32_t(indices + 16), "measure meshes");
  meshDraws_.clear();
  std::vector<engine::MeshRange> ranges;
  for (const MeshData& m : scene.meshes()) {
    const engine::MeshRange r = meshes_->upload(m.vertices, m.indices);
    ranges.push_back(r);
    csm::vk::MeshDraw d;
    d.vertexBuffer = meshes_->vertexBuffer();
    d.indexBuffer = meshes_->indexBuffer();
    d.firstIndex = r.firstIndex;
    d.indexCount = r.indexCount;
    d.vertexOffset = r.vertexOffset;
    meshDraws_.push_back(d);
  }
  instances_ = scene.instances();
  casters_.clear();
  for (const Instance& in : instances_) {
    casters_.push_back({in.mesh, in.translationWs, in.linearWs});
    casters_.back().thin = in.thin;
  }
  casterSet_ = scene.casterSet();
  const csm::AabbWs bounds = scene.boundsWs();
  meshRanges_ = std::move(ranges);
  csm::vk::Status s = view_->setCasters(meshDraws_, casters_, casterSet_);
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
      if (m >= meshDraws_.size()) {
        throw std::invalid_argument("setCasterLods: instance " + std::to_string(i) + " mesh " +
                                    std::to_string(m) + " is out of range: allowed [0, " +
                                    std::to_string(meshDraws_.size()) + ")");
      }
    }
  }
  // LOD 0 of the module's instance is the instance's LOD-0 mesh; LODs off: the own mesh only.
  std::vector<csm::vk::CasterInstance> casters = casters_;
  for (size_t i = 0; i < lodMeshes.size(); ++i) {
    casters[i].mesh = lodMeshes[i][0];
    for (uint32_t k = 1; k < csm::vk::kMaxCasterLods; ++k) {
      casters[i].lodMeshes[k - 1] = k < lodMeshes[i].size() ? lodMeshes[i][k] : csm::vk::kNoMesh;
      casters[i].lodErrorM[k - 1] = !lodErrorM.empty() && k < lodErrorM[i].size()
                                        ? lodErrorM[i][k]
                                        : csm::vk::kUnknownLodError;
    }
  }
  csm::vk::Status s = view_->setCasters(meshDraws_, casters, casterSet_);
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
      options.renderMode != csm::vk::RenderMode::kLayered && settings.stabilize) {
    withLods.cache = true;
  }
  const csm::vk::Status s = view_->setSettings(settings, withLods);
  if (s.ok()) options_ = withLods;
  return s;
}

uint64_t Harness::shadowMapBytes() const {
  const csm::ShadowSettings& settings = view_->settings();
  return uint64_t(settings.resolution) * settings.resolution * settings.cascadeCount *
         engine::bytesPerTexel(view_->renderer().depthFormat());
}

csm::CascadeFrame Harness::computeFrame(const csm::Camera& camera,
                                        const csm::DirectionalLight& light,
                                        csm::CascadeHistory& history) {
  csm::Result<csm::CascadeFrame> frame = view_->computeFrame(camera, light, &history);
  if (!frame.ok()) throw std::runtime_error("computeCascades: " + frame.error().message());
  return frame.value();
}

void Harness::recordShadow(VkCommandBuffer cmd, const csm::CascadeFrame& frame) {
  view_->setUniformOptions({});
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
      shadowTriangles_ += meshDraws_[casters[i].meshForLod(lod)].indexCount / 3;
    }
  }
}

// ---- probe ----------------------------------------------------------------------------------

void Harness::ensureProbeBuffers(uint32_t count) {
  VkDevice dev = ctx_->device();
  if (!probe_) {
    probe_ = std::make_unique<Probe>();
    const VkDescriptorSetLayoutBinding b[2] = {
        {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
        {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}};
    probe_->layout = engine::createDescriptorSetLayout(dev, b, "measure.probe.layout");
    probe_->pool = makePool(dev, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2, "measure.probe.pool");
    probe_->set = allocateSet(dev, probe_->pool, probe_->layout, "measure.probe.set");
    VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, 16};
    const VkDescriptorSetLayout sets[2] = {probe_->layout.get(), view_->lightingSetLayout()};
    auto li = vkStruct<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
    li.setLayoutCount = 2;
    li.pSetLayouts = sets;
    li.pushConstantRangeCount = 1;
    li.pPushConstantRanges = &range;
    VkPipelineLayout pl = VK_NULL_HANDLE;
    ENGINE_VK_CHECK(vkCreatePipelineLayout(dev, &li, nullptr, &pl));
    engine::setDebugName(dev, pl, "measure.probe.pipelineLayout");
    probe_->pipelineLayout =
        engine::DeviceHandle<VkPipelineLayout>(dev, pl, vkDestroyPipelineLayout);
  }
  if (count <= probe_->capacity) return;
  ctx_->waitIdle();
  const uint32_t capacity = std::max(count, 1024u);
  probe_->points = engine::Buffer(*ctx_, VkDeviceSize(capacity) * sizeof(ProbePointGpu),
                                  VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, engine::MemoryUsage::Upload,
                                  "measure.probe.points");
  probe_->results = engine::Buffer(*ctx_, VkDeviceSize(capacity) * 2 * sizeof(glm::vec4),
                                   VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                   engine::MemoryUsage::Readback, "measure.probe.results");
  writeBuffer(dev, probe_->set, 0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, probe_->points.handle());
  writeBuffer(dev, probe_->set, 1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, probe_->results.handle());
  probe_->capacity = capacity;
}

Harness::ProbePipeline& Harness::probePipeline(csm::PcfKernel kernel, bool blend) {
  auto& p = probePipelines_[{uint32_t(kernel), blend}];
  if (p) return *p;
  VkDevice dev = ctx_->device();
  p = std::make_unique<ProbePipeline>();
  const auto module =
      engine::createShaderModule(dev, stability_probe_comp_spv, "stability_probe.comp");
  const uint32_t values[2] = {uint32_t(kernel), blend ? 1u : 0u};
  const VkSpecializationMapEntry entries[2] = {{CSM_SPEC_KERNEL, 0, 4}, {CSM_SPEC_BLEND, 4, 4}};
  VkSpecializationInfo spec{2, entries, sizeof(values), values};
  auto ci = vkStruct<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
  ci.stage = vkStruct<VkPipelineShaderStageCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
  ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  ci.stage.module = module;
  ci.stage.pName = "main";
  ci.stage.pSpecializationInfo = &spec;
  ci.layout = probe_->pipelineLayout;
  VkPipeline pipeline = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreateComputePipelines(dev, VK_NULL_HANDLE, 1, &ci, nullptr, &pipeline));
  engine::setDebugName(
      dev, pipeline,
      std::string("measure.probe.") + csm::kernelName(kernel) + (blend ? ".blend" : ".switch"));
  p->pipeline = engine::DeviceHandle<VkPipeline>(dev, pipeline, vkDestroyPipeline);
  return *p;
}

std::vector<ProbeResult> Harness::probe(const csm::CascadeFrame& frame,
                                        std::span<const Receiver> receivers, csm::PcfKernel kernel,
                                        bool blend) {
  const uint32_t count = uint32_t(receivers.size());
  ensureProbeBuffers(count);
  ProbePipeline& pipeline = probePipeline(kernel, blend);
  auto* points = static_cast<ProbePointGpu*>(probe_->points.mapped());
  for (uint32_t i = 0; i < count; ++i) {
    // Camera-relative in double, rounded to float once.
    points[i].posCr = glm::vec4(glm::vec3(receivers[i].posWs - frame.cameraPositionWs), 1.0f);
    points[i].normalWs = glm::vec4(receivers[i].normalWs, 0.0f);
  }
  ctx_->submitAndWait([&](VkCommandBuffer cmd) {
    recordShadow(cmd, frame);
    engine::ScopedLabel label(cmd, "measure probe");
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline.pipeline);
    const VkDescriptorSet sets[2] = {probe_->set, view_->lightingSet()};
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, probe_->pipelineLayout, 0, 2, sets,
                            0, nullptr);
    const uint32_t push[4] = {count, 0, 0, 0};
    vkCmdPushConstants(cmd, probe_->pipelineLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push),
                       push);
    vkCmdDispatch(cmd, (count + 63) / 64, 1, 1);
    engine::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_WRITE_BIT,
                          VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
  });
  std::vector<ProbeResult> out(count);
  const auto* r = static_cast<const glm::vec4*>(probe_->results.mapped());
  for (uint32_t i = 0; i < count; ++i) {
    const glm::vec4& a = r[2 * i];
    out[i].shadow = a.x;
    out[i].cascade = int(std::lround(a.y));
    out[i].blendCascade = int(std::lround(a.z));
    out[i].blendWeight = a.w;
    out[i].depthGapM = r[2 * i + 1].x;
  }
  return out;
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
    accuracy_->pool = makePool(dev, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, "measure.accuracy.pool");
    accuracy_->set = allocateSet(dev, accuracy_->pool, accuracy_->layout, "measure.accuracy.set");
    accuracy_->frameUniforms =
        engine::Buffer(*ctx_, sizeof(glm::mat4), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                       engine::MemoryUsage::Upload, "measure.accuracy.frameUniforms");
    writeBuffer(dev, accuracy_->set, 0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER,
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
  const auto frag =
      engine::createShaderModule(dev, stability_accuracy_frag_spv, "stability_accuracy.frag");
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
  const engine::Camera cam = toEngineCamera(camera);
  const glm::mat4 viewProjCr = cam.viewProjectionCr();
  std::memcpy(accuracy_->frameUniforms.mapped(), &viewProjCr, sizeof(viewProjCr));
  AccuracyTargets& t = *accuracy_;
  ctx_->submitAndWait([&](VkCommandBuffer cmd) {
    recordShadow(cmd, frame);
    for (auto& image : t.images) {
      engine::imageBarrier(cmd, image.handle(), VK_IMAGE_ASPECT_COLOR_BIT,
                           VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE,
                           VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                           VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                           VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
    }
    engine::imageBarrier(
        cmd, t.depth.handle(), VK_IMAGE_ASPECT_DEPTH_BIT,
        VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
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
      meshes_->bind(cmd);
      for (const Instance& in : instances_) {
        AccuracyPush push{};
        push.modelCr = glm::mat4(in.linearWs);
        push.modelCr[3] = glm::vec4(glm::vec3(in.translationWs - camera.positionWs), 1.0f);
        const glm::mat3 normalMatrix = glm::transpose(glm::inverse(in.linearWs));
        for (int i = 0; i < 3; ++i) push.normalToWs[i] = glm::vec4(normalMatrix[i], 0.0f);
        vkCmdPushConstants(cmd, pipeline.pipeline.layout, VK_SHADER_STAGE_VERTEX_BIT, 0,
                           sizeof(push), &push);
        const engine::MeshRange& m = meshRanges_[in.mesh];
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
  });

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
      p.posWs = camera.positionWs + glm::dvec3(glm::vec3(pos[i]));
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
    engine::LitPassDesc desc;
    desc.colorFormat = timingTarget_->colorFormat();
    desc.depthFormat = timingTarget_->depthFormat();
    desc.shadowSetLayout = view_->lightingSetLayout();
    desc.specialization = {{CSM_SPEC_KERNEL, uint32_t(kernel)}, {CSM_SPEC_BLEND, blend ? 1u : 0u}};
    lit = std::make_unique<engine::LitPass>(*ctx_, desc);
  }
  std::vector<engine::LitDraw> draws;
  draws.reserve(instances_.size());
  for (const Instance& in : instances_) {
    draws.push_back({meshRanges_[in.mesh], in.translationWs, in.linearWs, in.color});
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
  const engine::Camera cam = toEngineCamera(camera);
  engine::LitFrame lf;
  lf.viewProjCr = cam.viewProjectionCr();
  lf.cameraPositionWs = camera.positionWs;
  lf.lightDirectionWs = glm::vec3(light.directionWs);
  lit->prepare(f->cmd, lf);
  timer_->begin(f->cmd, "lit");
  engine::beginRendering(*f, VkClearColorValue{{0.1f, 0.1f, 0.15f, 1.0f}});
  lit->draw(f->cmd, *meshes_, view_->lightingSet(), draws, f->extent);
  vkCmdEndRendering(f->cmd);
  timer_->end(f->cmd, "lit");
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
