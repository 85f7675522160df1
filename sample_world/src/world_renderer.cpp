// The sample world's renderer (see world_renderer.hpp).
#include "sample_world/world_renderer.hpp"

#include <csm_shaders/overlay_2d.frag.spv.h>
#include <csm_shaders/overlay_2d.vert.spv.h>
#include <csm_shaders/world.frag.spv.h>
#include <csm_shaders/world.vert.spv.h>
#include <csm_shaders/world_deferred.frag.spv.h>
#include <csm_shaders/world_deferred.vert.spv.h>
#include <csm_shaders/world_gbuffer.frag.spv.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "csm/gpu_layout.hpp"
#include "engine/debug.hpp"
#include "engine/errors.hpp"
#include "glue/camera.hpp"
#include "glue/shadow_host.hpp"
#include "glue/vk_util.hpp"
#include "world_renderer_internal.hpp"

namespace world {

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

engine::MeshRange upload(engine::MeshStore& store, const MeshData& m) {
  std::vector<engine::Vertex> v(m.positions.size());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = {m.positions[i], m.normals[i]};
  return store.upload(v, m.indices);
}

// The 6 planes (inward normals, camera-relative) of a camera's frustum.
std::array<glm::dvec4, 6> frustumPlanes(const engine::Camera& cam) {
  const glm::dmat4 vp = glm::dmat4(cam.viewProjectionCr());
  const glm::dvec4 r0(vp[0][0], vp[1][0], vp[2][0], vp[3][0]);
  const glm::dvec4 r1(vp[0][1], vp[1][1], vp[2][1], vp[3][1]);
  const glm::dvec4 r2(vp[0][2], vp[1][2], vp[2][2], vp[3][2]);
  const glm::dvec4 r3(vp[0][3], vp[1][3], vp[2][3], vp[3][3]);
  // Vulkan clip: -w <= x, y <= w and 0 <= z <= w.
  return {r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2, r3 - r2};
}

bool boxVisible(const std::array<glm::dvec4, 6>& planes, const csm::AabbWs& b,
                const glm::dvec3& cameraWs) {
  const glm::dvec3 lo = b.minWs - cameraWs, hi = b.maxWs - cameraWs;
  for (const glm::dvec4& p : planes) {
    const glm::dvec3 v(p.x > 0 ? hi.x : lo.x, p.y > 0 ? hi.y : lo.y, p.z > 0 ? hi.z : lo.z);
    if (glm::dot(glm::dvec3(p), v) + p.w < 0.0) return false;
  }
  return true;
}

double boxDistance(const csm::AabbWs& b, const glm::dvec3& p) {
  const glm::dvec3 d = glm::max(glm::max(b.minWs - p, p - b.maxWs), glm::dvec3(0.0));
  return glm::length(d);
}

}  // namespace

WorldRenderer::WorldRenderer(engine::Context& ctx, const World& world, VkFormat colorFormat,
                             VkFormat depthFormat, std::optional<float> momentAnisotropy)
    : ctx_(&ctx), world_(&world), colorFormat_(colorFormat), depthFormat_(depthFormat) {
  uploadMeshes(world);
  buildViewGroups(world);
  buildClosedMeshes(world);
  setUpShadowView(world, momentAnisotropy);
  createFrameResources();
  createGBufferResources();
  createPipelines();
}

void WorldRenderer::uploadMeshes(const World& world) {
  // ---- Meshes: every asset LOD and every caster-cluster LOD in one store -------------------
  std::uint64_t vertices = 0, indices = 0;
  for (const MeshAsset& a : world.meshes) {
    for (const MeshData& m : a.lods) vertices += m.positions.size(), indices += m.indices.size();
  }
  for (const CasterCluster& c : world.clusters) {
    for (const MeshData& m : c.lods) vertices += m.positions.size(), indices += m.indices.size();
  }
  if (vertices > 0xffffffffull || indices > 0xffffffffull) {
    throw std::runtime_error("world too large for 32-bit mesh indices");
  }
  meshes_ =
      std::make_unique<engine::MeshStore>(*ctx_, static_cast<std::uint32_t>(vertices + 64),
                                          static_cast<std::uint32_t>(indices + 64), "world.meshes");
  for (const MeshAsset& a : world.meshes) {
    std::array<engine::MeshRange, kLodCount> r{};
    for (std::uint32_t l = 0; l < kLodCount; ++l) r[l] = upload(*meshes_, a.lods[l]);
    assetRanges_.push_back(r);
  }
  for (const CasterCluster& c : world.clusters) {
    std::array<engine::MeshRange, kLodCount> r{};
    if (c.asset >= 0) {
      r = assetRanges_[static_cast<std::size_t>(c.asset)];
    } else {
      for (std::uint32_t l = 0; l < kLodCount; ++l) r[l] = upload(*meshes_, c.lods[l]);
    }
    clusterRanges_.push_back(r);
  }
}

void WorldRenderer::buildClosedMeshes(const World& world) {
  closedMesh_.assign(assetRanges_.size(), false);
  for (std::size_t a = 0; a < world.meshes.size(); ++a) closedMesh_[a] = world.meshes[a].closed;
  // A placement that mirrors (negative determinant) turns the winding: draw both faces.
  for (const Object& ob : world.objects) {
    if (glm::determinant(ob.linear) <= 0.0f) closedMesh_[ob.mesh] = false;
  }
  closedMesh_[cubeMesh_] = isClosedOutward([&] {
    MeshData m;
    std::vector<engine::Vertex> v;
    engine::makeCube(v, m.indices);
    for (const engine::Vertex& x : v) m.positions.push_back(x.position);
    return m;
  }());
}

void WorldRenderer::buildViewGroups(const World& world) {
  // ---- View culling groups ------------------------------------------------------------------
  const std::uint32_t chunks = world.chunksPerSide * world.chunksPerSide;
  chunkBounds_.assign(chunks, {glm::dvec3(1e300), glm::dvec3(-1e300)});
  chunkObjects_.resize(chunks);
  for (std::uint32_t k = 0; k < world.objects.size(); ++k) {
    const Object& ob = world.objects[k];
    chunkObjects_[ob.chunk].push_back(k);
    chunkBounds_[ob.chunk].minWs = glm::min(chunkBounds_[ob.chunk].minWs, ob.boundsWs.minWs);
    chunkBounds_[ob.chunk].maxWs = glm::max(chunkBounds_[ob.chunk].maxWs, ob.boundsWs.maxWs);
  }
  // Dynamic casters: a unit cube asset after the world's meshes.
  {
    std::vector<engine::Vertex> v;
    std::vector<std::uint32_t> idx;
    engine::makeCube(v, idx);
    const engine::MeshRange cube = meshes_->upload(v, idx);
    cubeMesh_ = static_cast<std::uint32_t>(assetRanges_.size());
    assetRanges_.push_back({cube, cube, cube});
    // Six vehicles on circles of 12-90 m about the camera's ground point (cars and trucks),
    // and a crane jib swinging 25 m above the ground 45 m from it.
    movers_ = {
        {12.0, 0.020, 0.0, {4.5, 1.6, 2.0}, false},  {22.0, -0.012, 1.0, {4.5, 1.6, 2.0}, false},
        {35.0, 0.009, 2.0, {9.0, 3.2, 2.6}, false},  {50.0, -0.007, 3.0, {4.5, 1.6, 2.0}, false},
        {70.0, 0.005, 4.0, {12.0, 3.6, 2.6}, false}, {90.0, -0.004, 5.0, {4.5, 1.6, 2.0}, false},
        {30.0, 0.01, 0.0, {30.0, 1.2, 1.2}, true}};
  }
  maxInstances_ = static_cast<std::uint32_t>(world.objects.size() + movers_.size());
  bucketObjects_.resize(world.meshes.size() * kLodCount);
}

void WorldRenderer::setUpShadowView(const World& world, std::optional<float> momentAnisotropy) {
  // ---- Shadow renderer ----------------------------------------------------------------------
  static_assert(kLodCount <= csm::vk::kMaxCasterLods);
  shadow_ = glue::createShadowView(*ctx_, momentAnisotropy);
  std::vector<csm::vk::MeshDraw> draws;
  std::vector<csm::vk::CasterInstance> instances;
  std::vector<csm::AabbWs> bounds;
  for (std::size_t k = 0; k < world.clusters.size(); ++k) {
    csm::vk::CasterInstance in;
    in.mesh = static_cast<std::uint32_t>(draws.size());
    in.translationWs = world.clusters[k].originWs;
    in.thin = world.clusters[k].thin;
    in.thinWidthM = world.clusters[k].thinWidthM;
    in.closed = world.clusters[k].closed;
    for (std::uint32_t l = 1; l < kLodCount; ++l) {
      in.lodErrorM[l - 1] = world.clusters[k].lodErrorM[l];
    }
    for (std::uint32_t l = 0; l < kLodCount; ++l) {
      const engine::MeshRange& r = clusterRanges_[k][l];
      csm::vk::MeshDraw d;
      d.vertexBuffer = meshes_->vertexBuffer();
      d.indexBuffer = meshes_->indexBuffer();
      d.firstIndex = r.firstIndex;
      d.indexCount = r.indexCount;
      d.vertexOffset = r.vertexOffset;
      if (l > 0) in.lodMeshes[l - 1] = static_cast<std::uint32_t>(draws.size());
      draws.push_back(d);
    }
    instances.push_back(in);
    bounds.push_back(world.clusters[k].boundsWs);
  }
  // The movers' casters follow the static clusters (one mesh, drawn at every LOD).
  staticCasters_ = instances.size();
  csm::vk::MeshDraw cubeDraw;
  cubeDraw.vertexBuffer = meshes_->vertexBuffer();
  cubeDraw.indexBuffer = meshes_->indexBuffer();
  cubeDraw.firstIndex = assetRanges_[cubeMesh_][0].firstIndex;
  cubeDraw.indexCount = assetRanges_[cubeMesh_][0].indexCount;
  cubeDraw.vertexOffset = assetRanges_[cubeMesh_][0].vertexOffset;
  const std::uint32_t cubeDrawIndex = static_cast<std::uint32_t>(draws.size());
  draws.push_back(cubeDraw);
  for (std::size_t k = 0; k < movers_.size(); ++k) {
    csm::vk::CasterInstance in;
    in.mesh = cubeDrawIndex;
    in.dynamic = true;
    in.closed = closedMesh_[cubeMesh_];
    instances.push_back(in);
    bounds.push_back({glm::dvec3(0.0), glm::dvec3(1.0)});
  }
  casterInstances_ = instances;
  casterBounds_ = bounds;
  csm::vk::Status casterStatus = shadow_->setCasters(draws, instances, bounds);
  if (casterStatus.ok()) casterStatus = shadow_->setSceneBounds(&world.boundsWs);
  if (!casterStatus.ok()) throw std::runtime_error("ShadowView: " + casterStatus.message());
}

void WorldRenderer::createFrameResources() {
  // ---- Per-frame resources --------------------------------------------------------------------
  VkDevice dev = ctx_->device();
  const VkDescriptorSetLayoutBinding binding{
      0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1,
      VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
  frameLayout_ =
      engine::createDescriptorSetLayout(dev, std::span(&binding, 1), "world.frameLayout");
  pool_ = glue::detail::makeDescriptorPool(dev, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER,
                                           engine::kFramesInFlight, "world.pool",
                                           engine::kFramesInFlight);
  for (std::uint32_t s = 0; s < engine::kFramesInFlight; ++s) {
    Slot& slot = slots_[s];
    const std::string n = "world.slot" + std::to_string(s);
    slot.frameUniforms =
        engine::Buffer(*ctx_, sizeof(WorldFrameGpu), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                       engine::MemoryUsage::Upload, n + ".uniforms");
    slot.instances = engine::Buffer(*ctx_, sizeof(Instance) * std::max(1u, maxInstances_),
                                    VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, engine::MemoryUsage::Upload,
                                    n + ".instances");
    slot.overlay = engine::Buffer(*ctx_, sizeof(OverlayVertex) * kMaxOverlayVertices,
                                  VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, engine::MemoryUsage::Upload,
                                  n + ".overlay");
    slot.frameSet =
        glue::detail::allocateDescriptorSet(dev, pool_, frameLayout_, (n + ".frameSet").c_str());
    VkDescriptorBufferInfo bi{slot.frameUniforms.handle(), 0, sizeof(WorldFrameGpu)};
    VkWriteDescriptorSet w{};
    w.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    w.dstSet = slot.frameSet;
    w.descriptorCount = 1;
    w.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    w.pBufferInfo = &bi;
    vkUpdateDescriptorSets(dev, 1, &w, 0, nullptr);
  }
}

void WorldRenderer::createGBufferResources() {
  VkDevice dev = ctx_->device();
  std::array<VkDescriptorSetLayoutBinding, 3> bindings{};
  for (std::uint32_t b = 0; b < bindings.size(); ++b) {
    bindings[b] = {b, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT,
                   nullptr};
  }
  gbufferLayout_ = engine::createDescriptorSetLayout(dev, bindings, "world.gbufferLayout");
  gbufferPool_ = glue::detail::makeDescriptorPool(dev, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                                                  3 * engine::kFramesInFlight, "world.gbufferPool",
                                                  engine::kFramesInFlight);
  // Read with texelFetch only: nearest, no mips.
  VkSamplerCreateInfo sci{};
  sci.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
  sci.magFilter = sci.minFilter = VK_FILTER_NEAREST;
  sci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  sci.addressModeU = sci.addressModeV = sci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  VkSampler sampler = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreateSampler(dev, &sci, nullptr, &sampler));
  gbufferSampler_ = engine::DeviceHandle<VkSampler>(dev, sampler, vkDestroySampler);
  engine::setDebugName(dev, sampler, "world.gbufferSampler");
  for (std::uint32_t s = 0; s < engine::kFramesInFlight; ++s) {
    const std::string name = "world.slot" + std::to_string(s) + ".gbufferSet";
    slots_[s].gbufferSet =
        glue::detail::allocateDescriptorSet(dev, gbufferPool_, gbufferLayout_, name.c_str());
  }
}

void WorldRenderer::ensureGBuffer(Slot& slot, VkExtent2D extent) {
  if (slot.gAlbedo && slot.gbufferExtent.width == extent.width &&
      slot.gbufferExtent.height == extent.height) {
    return;
  }
  // This slot's last frame has completed (its fence passed in beginFrame): its images are free.
  const std::string n = "world.slot" + std::to_string(&slot - slots_.data()) + ".gbuffer.";
  engine::Image* images[3] = {&slot.gAlbedo, &slot.gNormals, &slot.gViewDepth};
  const char* names[3] = {"albedo", "normals", "viewDepth"};
  std::array<VkDescriptorImageInfo, 3> infos{};
  std::array<VkWriteDescriptorSet, 3> writes{};
  for (std::size_t k = 0; k < 3; ++k) {
    engine::ImageDesc d;
    d.format = kGBufferFormats[k];
    d.extent = extent;
    d.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    *images[k] = engine::Image(*ctx_, d, n + names[k]);
    infos[k] = {gbufferSampler_.get(), images[k]->view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    writes[k].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    writes[k].dstSet = slot.gbufferSet;
    writes[k].dstBinding = static_cast<std::uint32_t>(k);
    writes[k].descriptorCount = 1;
    writes[k].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    writes[k].pImageInfo = &infos[k];
  }
  vkUpdateDescriptorSets(ctx_->device(), 3, writes.data(), 0, nullptr);
  slot.gbufferExtent = extent;
}

void WorldRenderer::createPipelines() {
  // ---- Shader modules and the overlay pipelines (the lit pipeline is built by apply()) --------
  VkDevice dev = ctx_->device();
  worldVert_ = engine::createShaderModule(dev, world_vert_spv, "world.vert");
  worldFrag_ = engine::createShaderModule(dev, world_frag_spv, "world.frag");
  gbufferFrag_ = engine::createShaderModule(dev, world_gbuffer_frag_spv, "world_gbuffer.frag");
  deferredVert_ = engine::createShaderModule(dev, world_deferred_vert_spv, "world_deferred.vert");
  deferredFrag_ = engine::createShaderModule(dev, world_deferred_frag_spv, "world_deferred.frag");
  overlayVert_ = engine::createShaderModule(dev, overlay_2d_vert_spv, "overlay_2d.vert");
  overlayFrag_ = engine::createShaderModule(dev, overlay_2d_frag_spv, "overlay_2d.frag");

  const VkVertexInputBindingDescription ob{0, sizeof(OverlayVertex), VK_VERTEX_INPUT_RATE_VERTEX};
  const VkVertexInputAttributeDescription oa[] = {
      {0, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(OverlayVertex, pixel)},
      {1, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(OverlayVertex, uv)},
      {2, 0, VK_FORMAT_R32G32B32A32_SFLOAT, offsetof(OverlayVertex, color)},
      {3, 0, VK_FORMAT_R32G32B32A32_SFLOAT, offsetof(OverlayVertex, thumb)},
      {4, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(OverlayVertex, relief)},
  };
  for (int k = 0; k < 2; ++k) {
    engine::GraphicsPipelineBuilder b;
    b.vertexShader(overlayVert_)
        .fragmentShader(overlayFrag_)
        .vertexInput(std::span(&ob, 1), oa)
        .topology(k == 0 ? VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST : VK_PRIMITIVE_TOPOLOGY_LINE_LIST)
        .colorFormat(colorFormat_)
        .depthFormat(depthFormat_)
        .depthTest(false, false)
        .alphaBlend(true)
        .pushConstants(VK_SHADER_STAGE_VERTEX_BIT, sizeof(glm::vec2))
        .descriptorSetLayout(shadow_->lightingSetLayout());
    (k == 0 ? overlayTris_ : overlayLines_) =
        b.build(*ctx_, k == 0 ? "overlay.tris" : "overlay.lines");
  }
}

WorldRenderer::~WorldRenderer() {
  if (ctx_) ctx_->waitIdle();
}

std::uint64_t WorldRenderer::clusterTriangles(std::uint32_t lod) const {
  std::uint64_t t = 0;
  for (const auto& r : clusterRanges_) t += r[lod].indexCount / 3;
  return t;
}

std::optional<std::string> WorldRenderer::apply(const AppSettings& settings) {
  if (auto e = validateSettings(settings)) return e;
  csm::vk::RendererOptions options;
  options.depthFormat = settings.depth16 ? VK_FORMAT_D16_UNORM : VK_FORMAT_D32_SFLOAT;
  options.consumerStages = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  // The cache needs stabilised cascades (texels fixed in the world); the unstabilised comparison
  // mode renders every frame in full instead of being refused.
  options.cache = settings.shadowCache && settings.shadow.diagnostics.stabilize;
  options.cacheBudgetTexels = settings.cacheBudgetTexels;
  options.msmMomentBits = settings.msmMomentBits;
  options.tiles = settings.shadowTiles && options.cache;
  options.tileBudgetTexels = settings.tileBudgetTexels;
  options.thinCasterWidenTexels = settings.thinCasters ? settings.thinWidenTexels : 0.0f;
  if (settings.casterLods) {
    for (std::uint32_t c = 0; c < csm::kMaxCascades; ++c) {
      options.cascadeLod[c] = std::min(settings.cascadeLod[c], kLodCount - 1);
    }
    options.lodMaxErrorTexels = settings.lodMaxErrorTexels;
  } else {
    options.lodMaxErrorTexels = 0.0f;
  }
  // The receiver fit: the view reduces this frame's depth buffer (recordDepthRange) and fits the
  // next frames' splits, and with receiverBounds their boxes, to the receivers it shows.
  options.receiverFit = !settings.receiverSplits  ? csm::vk::ReceiverFit::kOff
                        : settings.receiverBounds ? csm::vk::ReceiverFit::kSplitsAndBoxes
                                                  : csm::vk::ReceiverFit::kSplits;
  if ((settings.tileMarks || settings.shadowTiles) && !tileReducer_) {
    csm::vk::Status made;
    tileReducer_ = csm::vk::DepthRangeReducer::create(glue::shadowDeviceInfo(*ctx_),
                                                      engine::kFramesInFlight, &made);
    if (!tileReducer_) {
      return std::string(settings.shadowTiles ? "shadow.tiles: " : "shadow.tileMarks: ") +
             made.message();
    }
  }
  const csm::vk::Status s = shadow_->setSettings(effectiveShadow(settings), options);
  if (!s.ok()) return s.message();
  const bool resetHistory =
      !applied_ || settings.shadow.cascadeCount != settings_.shadow.cascadeCount ||
      settings.shadow.diagnostics.stabilize != settings_.shadow.diagnostics.stabilize;
  settings_ = settings;
  applied_ = true;
  // (A change of the receiver fit drops the earlier ranges in the view itself.)
  if (resetHistory) shadow_->cameraCut();
  buildLitPipeline();
  return std::nullopt;
}

std::optional<std::string> WorldRenderer::setSun(const SunPose& sun) {
  // The ranges of the light.azimuth and light.elevation settings.
  const auto refuse = [](const char* key, double v, double lo, double hi) {
    char text[160];
    std::snprintf(text, sizeof(text), "%s = %g: allowed a number of degrees in [%g, %g]", key, v,
                  lo, hi);
    return std::optional<std::string>(text);
  };
  if (!(sun.azimuthDeg >= 0.0 && sun.azimuthDeg <= 360.0))
    return refuse("sun.azimuthDeg", sun.azimuthDeg, 0.0, 360.0);
  if (!(sun.elevationDeg >= 1.0 && sun.elevationDeg <= 90.0))
    return refuse("sun.elevationDeg", sun.elevationDeg, 1.0, 90.0);
  settings_.lightAzimuthDeg = sun.azimuthDeg;
  settings_.lightElevationDeg = sun.elevationDeg;
  return std::nullopt;
}

void WorldRenderer::cameraCut() {
  // The module's cut: sizes and splits start afresh instead of stepping down from the last
  // place's (every cascade's window is new there anyway), and no receiver range measured there
  // is used here.
  shadow_->cameraCut();
  if (tileReducer_) tileReducer_->invalidate();
  cutPending_ = settings_.receiverSplits || (marking() && tileReducer_);
  latestAfterCut_ = false;
}

void WorldRenderer::takeLatestReceivers() {
  // Every slot but the last filled was emptied by the cut, so the reads that follow find
  // nothing older than these results.
  latestAfterCut_ = false;
  if (settings_.receiverSplits) {
    const csm::vk::Status s = shadow_->useLatestReceiverDepth();
    if (!s.ok()) throw std::runtime_error("ShadowView::useLatestReceiverDepth: " + s.message());
  }
  if (!tileReducer_ || !shadow_->options().tiles) return;
  const auto latest = tileReducer_->read(lastTileSlot_);
  if (latest && latest->tiles.present()) shadow_->setReceiverTiles(latest->tiles);
}

std::optional<std::string> WorldRenderer::prepare(const engine::Camera& camera, FrameStats& stats) {
  camera_ = camera;
  const csm::Camera c = glue::toCsmCamera(camera);
  frameCamera_ = c;
  const csm::DirectionalLight light{lightDirection(settings_)};

  // The shadows: dynamic casters moved, cascades for this camera, the casters culled into them.
  auto t0 = Clock::now();
  moveDynamicCasters();
  const csm::vk::Status r = shadow_->compute(c, light);
  stats.cpuSetupMs = msSince(t0);
  if (!r.ok()) return r.message();
  const csm::CascadeFrame& cascades = shadow_->frame();

  t0 = Clock::now();
  // Lit pass: chunks in the view frustum, then objects; LOD by distance.
  const auto planes = frustumPlanes(camera);
  for (auto& b : bucketObjects_) b.clear();
  stats.litTriangles = 0;
  for (std::uint32_t ch = 0; ch < chunkObjects_.size(); ++ch) {
    if (chunkObjects_[ch].empty() || !boxVisible(planes, chunkBounds_[ch], camera.positionWs)) {
      continue;
    }
    for (std::uint32_t k : chunkObjects_[ch]) {
      const Object& ob = world_->objects[k];
      if (ob.kind != Kind::kTerrain && !boxVisible(planes, ob.boundsWs, camera.positionWs)) {
        continue;
      }
      const double d = boxDistance(ob.boundsWs, camera.positionWs);
      if (d > camera.farM) continue;
      // Distances where a LOD's simplification drops below about a pixel at 1080p / 60 deg.
      const double scale = ob.kind == Kind::kTerrain ? 4.0 : 1.0;
      const std::uint32_t lod = d < 150.0 * scale ? 0 : (d < 500.0 * scale ? 1 : 2);
      bucketObjects_[ob.mesh * kLodCount + lod].push_back(k);
    }
  }
  instances_.clear();
  buckets_.clear();
  // Near LODs first and the terrain last: roughly front to back, so that the depth test rejects
  // most hidden fragments before they are shaded.
  bucketOrder_.clear();
  for (std::uint32_t lod = 0; lod < kLodCount; ++lod) {
    for (int terrain = 0; terrain < 2; ++terrain) {
      for (std::uint32_t m = 0; m < world_->meshes.size(); ++m) {
        const bool isTerrain = m < world_->chunksPerSide * world_->chunksPerSide;
        if (isTerrain == (terrain == 1)) bucketOrder_.push_back(m * kLodCount + lod);
      }
    }
  }
  for (std::uint32_t b : bucketOrder_) {
    if (bucketObjects_[b].empty()) continue;
    Bucket bucket;
    bucket.mesh = b / kLodCount;
    bucket.lod = b % kLodCount;
    bucket.first = static_cast<std::uint32_t>(instances_.size());
    bucket.cullBack = settings_.cullBackFaces && closedMesh_[bucket.mesh];
    for (std::uint32_t k : bucketObjects_[b]) {
      const Object& ob = world_->objects[k];
      const glm::vec3 t(ob.translationWs - camera.positionWs);
      Instance in;
      for (int row = 0; row < 3; ++row) {
        in.rows[row] = glm::vec4(ob.linear[0][row], ob.linear[1][row], ob.linear[2][row], t[row]);
      }
      in.color = glm::vec4(ob.color, ob.receives ? 1.0f : 0.0f);
      instances_.push_back(in);
    }
    bucket.count = static_cast<std::uint32_t>(instances_.size()) - bucket.first;
    stats.litTriangles +=
        std::uint64_t(assetRanges_[bucket.mesh][bucket.lod].indexCount / 3) * bucket.count;
    buckets_.push_back(bucket);
  }
  if (!moverInstances_.empty()) {
    Bucket bucket;
    bucket.mesh = cubeMesh_;
    bucket.lod = 0;
    bucket.cullBack = settings_.cullBackFaces && closedMesh_[cubeMesh_];
    bucket.first = static_cast<std::uint32_t>(instances_.size());
    instances_.insert(instances_.end(), moverInstances_.begin(), moverInstances_.end());
    bucket.count = static_cast<std::uint32_t>(moverInstances_.size());
    stats.litTriangles += std::uint64_t(assetRanges_[cubeMesh_][0].indexCount / 3) * bucket.count;
    buckets_.push_back(bucket);
  }
  stats.litInstances = static_cast<std::uint32_t>(instances_.size());
  stats.cpuCullMs = msSince(t0);
  stats.cascades = cascades;
  stats.cascadeCount = cascades.cascadeCount;
  return std::nullopt;
}

void WorldRenderer::moveDynamicCasters() {
  const double t = double(frameCounter_++);
  const glm::dvec3 cam = camera_.positionWs;
  moverInstances_.clear();
  for (std::size_t k = 0; k < movers_.size(); ++k) {
    const Mover& m = movers_[k];
    const double a = m.phase + m.speed * t;
    glm::dvec3 at;
    double yaw;
    if (m.crane) {
      // The crane's mast stands 45 m from the camera's ground point; its jib swings about it.
      const glm::dvec3 mast(cam.x + 45.0, 0.0, cam.z + 20.0);
      at = mast + glm::dvec3(std::cos(a), 0.0, std::sin(a)) * (0.5 * m.sizeM.x);
      at.y = world_->heightAt(mast.x, mast.z) + 25.0;
      yaw = -a;
    } else {
      at = glm::dvec3(cam.x + m.radiusM * std::cos(a), 0.0, cam.z + m.radiusM * std::sin(a));
      at.y = world_->heightAt(at.x, at.z) + 0.5 * m.sizeM.y + 0.3;
      yaw = -a + (m.speed > 0 ? -1.0 : 1.0) * 1.5707963;  // along the circle
    }
    const double c = std::cos(yaw), s = std::sin(yaw);
    // The unit cube spans [-1, 1]: half extents.
    const glm::dmat3 linear =
        glm::dmat3(glm::dvec3(c, 0, -s), glm::dvec3(0, 1, 0), glm::dvec3(s, 0, c)) *
        glm::dmat3(0.5 * m.sizeM.x, 0, 0, 0, 0.5 * m.sizeM.y, 0, 0, 0, 0.5 * m.sizeM.z);
    csm::vk::CasterInstance& in = casterInstances_[staticCasters_ + k];
    in.translationWs = at;
    in.linearWs = glm::mat3(linear);
    csm::AabbWs b{glm::dvec3(1e300), glm::dvec3(-1e300)};
    for (int i = 0; i < 8; ++i) {
      const glm::dvec3 p =
          at + linear * glm::dvec3((i & 1) ? 1 : -1, (i & 2) ? 1 : -1, (i & 4) ? 1 : -1);
      b.minWs = glm::min(b.minWs, p);
      b.maxWs = glm::max(b.maxWs, p);
    }
    casterBounds_[staticCasters_ + k] = b;
    // Only this caster changed: the view refits its culling above it (a dynamic caster leaves
    // the static cache alone).
    const auto index = static_cast<std::uint32_t>(staticCasters_ + k);
    const csm::vk::Status moved = shadow_->updateCaster(shadow_->casterHandle(index), in, b);
    if (!moved.ok()) throw std::runtime_error("ShadowView::updateCaster: " + moved.message());
    Instance li;
    const glm::vec3 tr(at - cam);
    for (int row = 0; row < 3; ++row) {
      li.rows[row] =
          glm::vec4(float(linear[0][row]), float(linear[1][row]), float(linear[2][row]), tr[row]);
    }
    li.color = m.crane ? glm::vec4(0.95f, 0.75f, 0.1f, 1.0f) : glm::vec4(0.7f, 0.1f, 0.1f, 1.0f);
    moverInstances_.push_back(li);
  }
}

void WorldRenderer::record(const engine::Frame& f, engine::GpuTimer& timer, bool overlay,
                           FrameStats& stats) {
  const auto t0 = Clock::now();
  VkCommandBuffer cmd = f.cmd;
  Slot& slot = slots_[f.slot];
  recordShadowPass(cmd, timer, stats);
  recordLitPass(f, slot, timer, overlay);
  if (overlay && (settings_.overlayThumbnails || settings_.overlayMap))
    recordOverlay(f, slot, timer);
  vkCmdEndRendering(cmd);
  if (settings_.receiverSplits || marking()) recordDepthRange(f, timer, stats);
  stats.cpuRecordMs = msSince(t0);
}

void WorldRenderer::recordShadowPass(VkCommandBuffer cmd, engine::GpuTimer& timer,
                                     FrameStats& stats) {
  // ---- Shadow pass: each cascade draws its culled clusters at its LOD (the module's LODs) -----
  shadow_->setDebugMode(settings_.debug);
  const csm::CascadeFrame& cascades = shadow_->frame();
  const csm::CullResult& culled = shadow_->cull();
  stats.casters = {};
  stats.triangles = {};
  stats.lod = {};
  for (std::uint32_t c = 0; c < cascades.cascadeCount; ++c) {
    if (cascades.cascades[c].empty) continue;
    // The LOD the module draws each cluster with (schedule and texel error budget); stats.lod
    // is the range of those the cascade drew.
    const csm::vk::RendererOptions& options = shadow_->options();
    const double texelM =
        std::min(cascades.cascades[c].texelSizeLs.x, cascades.cascades[c].texelSizeLs.y);
    FrameStats::LodRange& lods = stats.lod[c];
    for (std::uint32_t k : culled.visible[c]) {
      if (k >= clusterRanges_.size()) {  // a dynamic caster (the cube, every LOD)
        ++stats.casters[c];
        stats.triangles[c] += assetRanges_[cubeMesh_][0].indexCount / 3;
        continue;
      }
      const std::uint32_t lod =
          std::min(csm::vk::casterLod(shadow_->instances()[k], options.cascadeLod[c], texelM,
                                      options.lodMaxErrorTexels),
                   kLodCount - 1);
      const engine::MeshRange& r = clusterRanges_[k][lod];
      if (r.indexCount == 0) continue;
      lods.finest = lods.clusters == 0 ? lod : std::min(lods.finest, lod);
      lods.coarsest = lods.clusters == 0 ? lod : std::max(lods.coarsest, lod);
      ++lods.clusters;
      ++stats.casters[c];
      stats.triangles[c] += r.indexCount / 3;
    }
  }
  timer.begin(cmd, "shadow");
  // Each cascade's scope runs from its hook to the next cascade's (or the pass's end), so it
  // includes the end of its render pass: where a binning rasteriser (lavapipe) does the work.
  std::string openScope;
  shadow_->setCascadeHook([&](VkCommandBuffer hookCmd, std::uint32_t cascade) {
    if (!openScope.empty()) timer.end(hookCmd, openScope);
    openScope.clear();
    if (cascade == csm::vk::kCascadeHookEnd) return;
    openScope = "shadow c" + std::to_string(cascade);
    timer.begin(hookCmd, openScope);
  });
  const csm::vk::Status s = shadow_->recordPass(cmd);
  shadow_->setCascadeHook({});
  if (!openScope.empty()) timer.end(cmd, openScope);
  timer.end(cmd, "shadow");
  if (!s.ok()) throw std::runtime_error("ShadowView::recordPass: " + s.message());
  // What was drawn: with the cache only the re-rendered texels and their casters' triangles.
  stats.texelsRendered = {};
  stats.momentTexels = {};
  stats.lagFrames = {};
  stats.tilesPartialMask = 0;
  stats.tilesDrawn = {};
  stats.tilesHeld = {};
  stats.tilesDeferred = {};
  stats.cacheBytes = shadow_->renderer().cacheBytes();
  stats.momentBytes = shadow_->renderer().momentBytes();
  for (std::uint32_t c = 0; c < cascades.cascadeCount; ++c) {
    if (cascades.cascades[c].empty) continue;
    stats.momentTexels[c] = shadow_->renderer().cacheStats()[c].momentTexels;
    if (shadow_->options().cache) {
      const csm::vk::CascadeCacheStats& cs = shadow_->renderer().cacheStats()[c];
      stats.texelsRendered[c] = cs.staticTexels;
      stats.lagFrames[c] = cs.lagFrames;
      if (cs.partial) stats.tilesPartialMask |= 1u << c;
      stats.tilesDrawn[c] = cs.tilesDrawn;
      stats.tilesHeld[c] = cs.tilesHeld;
      stats.tilesDeferred[c] = cs.tilesDeferred;
      stats.triangles[c] = cs.staticTriangles + cs.dynamicTriangles;
    } else {
      stats.texelsRendered[c] = std::uint64_t(cascades.resolution) * cascades.resolution;
    }
  }
}

void WorldRenderer::recordTileMarks(const engine::Frame& f, engine::GpuTimer& timer,
                                    FrameStats& stats) {
  // The slot of this frame in flight: its last submission has completed (the engine waited for
  // the frame's fence), so its marks are those of the depth buffer kFramesInFlight frames ago.
  stats.tilesMarked = {};
  stats.tilesMarkedFrom = 0;
  const auto previous = tileReducer_->read(f.slot);
  if (previous && previous->tiles.present()) {
    stats.tilesMarkedFrom = previous->tiles.cascadeCount;
    for (std::uint32_t c = 0; c < previous->tiles.cascadeCount; ++c) {
      stats.tilesMarked[c] = previous->tiles.markedCount(c);
    }
  }
  // Receiver-marked tiles: the next frame's shadow pass draws what these marks ask for. Without
  // a result (sky only, or a slot emptied by a cut) the marks stay; cameraCut() dropped them.
  if (shadow_->options().tiles && previous && previous->tiles.present()) {
    shadow_->setReceiverTiles(previous->tiles);
  }
  const glm::mat4& p = camera_.projection();
  csm::vk::DepthProjection dp{p[2][2], p[3][2], 1.0f};
  dp.p00 = p[0][0];
  dp.p11 = p[1][1];
  dp.p20 = p[2][0];
  dp.p21 = p[2][1];
  timer.begin(f.cmd, "tile marks");
  const csm::vk::Status s =
      tileReducer_->record(f.cmd, f.depthView, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, f.extent,
                           dp, f.slot, {&shadow_->frame(), &frameCamera_, &shadow_->settings()});
  timer.end(f.cmd, "tile marks");
  if (!s.ok()) throw std::runtime_error("DepthRangeReducer::record (tile marks): " + s.message());
  lastTileSlot_ = f.slot;
}

void WorldRenderer::recordDepthRange(const engine::Frame& f, engine::GpuTimer& timer,
                                     FrameStats& stats) {
  // The receiver fit: the view reduces this frame's depth buffer to the visible receivers' range
  // (and their light-space bounds per cascade); the frames kFramesInFlight later fit to it. The
  // tile marks: the same kind of reduction marks the tiles the visible pixels sample.
  VkCommandBuffer cmd = f.cmd;
  const VkImageAspectFlags aspect = VK_IMAGE_ASPECT_DEPTH_BIT;
  engine::imageBarrier(
      cmd, f.depthImage, aspect,
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
      VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
      VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL);
  if (settings_.receiverSplits) {
    const csm::vk::Status s = shadow_->recordReceiverDepth(
        cmd,
        {f.depthView, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, f.extent, camera_.projection()});
    if (!s.ok()) throw std::runtime_error("ShadowView::recordReceiverDepth: " + s.message());
  }
  if (marking() && tileReducer_) recordTileMarks(f, timer, stats);
  // The cut's frame has recorded its reductions: the next frame may take their results at once.
  if (cutPending_) {
    cutPending_ = false;
    latestAfterCut_ = true;
  }
  // Back to the layout the render target expects at endFrame.
  engine::imageBarrier(
      cmd, f.depthImage, aspect, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
      VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
          VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
      VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
}

}  // namespace world
