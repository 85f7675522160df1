// Across a blend band the shadow factor changes smoothly: csm.glsl evaluated in a compute shader
// (tests/gpu/shadow_probe.comp) at exact points on the plane along a line that runs through the
// band, beside the shadow edge of a rail that lies along the view direction.
#include <gtest/gtest.h>

#include <csm_shaders/selection_probe.comp.spv.h>
#include <csm_shaders/shadow_probe.comp.spv.h>
#include <engine/debug.hpp>
#include <engine/errors.hpp>
#include <engine/memory.hpp>
#include <engine/pipeline.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <span>

#include "shadow_scene.hpp"

namespace csm_test {
namespace {

template <class T>
T vkStruct(VkStructureType type) {
  T v{};
  v.sType = type;
  return v;
}

/// A compute pipeline over csm.glsl: set 0 = points and results, set 1 = the renderer's set.
class Probe {
 public:
  /// `shader`: shadow_probe.comp (one float per point) by default, or another probe over the same
  /// interface writing `resultFloats` floats per point.
  Probe(engine::Context& ctx, VkDescriptorSetLayout shadowLayout, csm::PcfKernel kernel, bool blend,
        uint32_t maxPoints, std::span<const uint32_t> shader = shadow_probe_comp_spv,
        uint32_t resultFloats = 1)
      : ctx_(ctx),
        resultFloats_(resultFloats),
        points_(ctx, maxPoints * sizeof(glm::vec4), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                engine::MemoryUsage::Upload, "probe.points"),
        results_(ctx, maxPoints * sizeof(float) * resultFloats, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                 engine::MemoryUsage::Readback, "probe.results") {
    VkDevice dev = ctx.device();
    const VkDescriptorSetLayoutBinding b[2] = {
        {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
        {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}};
    layout_ = engine::createDescriptorSetLayout(dev, b, "probe.layout");
    VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2};
    auto pi = vkStruct<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
    pi.maxSets = 1;
    pi.poolSizeCount = 1;
    pi.pPoolSizes = &size;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    ENGINE_VK_CHECK(vkCreateDescriptorPool(dev, &pi, nullptr, &pool));
    pool_ = engine::DeviceHandle<VkDescriptorPool>(dev, pool, vkDestroyDescriptorPool);
    engine::setDebugName(dev, pool, "probe.pool");
    VkDescriptorSetLayout l = layout_.get();
    auto ai = vkStruct<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
    ai.descriptorPool = pool;
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &l;
    ENGINE_VK_CHECK(vkAllocateDescriptorSets(dev, &ai, &set_));
    VkDescriptorBufferInfo infos[2] = {{points_.handle(), 0, VK_WHOLE_SIZE},
                                       {results_.handle(), 0, VK_WHOLE_SIZE}};
    VkWriteDescriptorSet w[2]{};
    for (uint32_t i = 0; i < 2; ++i) {
      w[i] = vkStruct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
      w[i].dstSet = set_;
      w[i].dstBinding = i;
      w[i].descriptorCount = 1;
      w[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      w[i].pBufferInfo = &infos[i];
    }
    vkUpdateDescriptorSets(dev, 2, w, 0, nullptr);

    VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, 32};
    const VkDescriptorSetLayout sets[2] = {layout_.get(), shadowLayout};
    auto li = vkStruct<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
    li.setLayoutCount = 2;
    li.pSetLayouts = sets;
    li.pushConstantRangeCount = 1;
    li.pPushConstantRanges = &range;
    VkPipelineLayout pl = VK_NULL_HANDLE;
    ENGINE_VK_CHECK(vkCreatePipelineLayout(dev, &li, nullptr, &pl));
    pipelineLayout_ = engine::DeviceHandle<VkPipelineLayout>(dev, pl, vkDestroyPipelineLayout);
    engine::setDebugName(dev, pl, "probe.pipelineLayout");

    const auto module = engine::createShaderModule(dev, shader, "probe.comp");
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
    ci.layout = pl;
    VkPipeline p = VK_NULL_HANDLE;
    ENGINE_VK_CHECK(vkCreateComputePipelines(dev, VK_NULL_HANDLE, 1, &ci, nullptr, &p));
    pipeline_ = engine::DeviceHandle<VkPipeline>(dev, p, vkDestroyPipeline);
    engine::setDebugName(dev, p, "probe.pipeline");
  }

  /// Renders the shadow pass of `frame` and evaluates csmShadow at `pointsWs` (normal +Y).
  std::vector<float> run(ShadowScene& scene, const csm::CascadeFrame& frame,
                         const std::vector<glm::dvec3>& pointsWs) {
    std::vector<glm::vec4> cr;
    for (const glm::dvec3& p : pointsWs) {
      cr.emplace_back(glm::vec3(p - frame.cameraPositionWs), 1.0f);
    }
    std::memcpy(points_.mapped(), cr.data(), cr.size() * sizeof(glm::vec4));
    struct {
      glm::vec4 normal;
      uint32_t count;
      uint32_t pad[3];
    } push{{0.0f, 1.0f, 0.0f, 0.0f}, uint32_t(cr.size()), {}};
    ctx_.submitAndWait([&](VkCommandBuffer cmd) {
      const csm::CascadeFrame recorded = scene.recordShadow(cmd, csm::DebugMode::kNone);
      // The view recomputes the frame for the same camera: the probe's frame is the recorded one.
      EXPECT_EQ(recorded.splitsM, frame.splitsM);
      EXPECT_EQ(recorded.cascades[0].boxCenterWs, frame.cascades[0].boxCenterWs);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_);
      const VkDescriptorSet sets[2] = {set_, scene.renderer().lightingSet()};
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelineLayout_, 0, 2, sets, 0,
                              nullptr);
      vkCmdPushConstants(cmd, pipelineLayout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
      vkCmdDispatch(cmd, (push.count + 63) / 64, 1, 1);
      engine::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                            VK_ACCESS_2_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                            VK_ACCESS_2_HOST_READ_BIT);
    });
    std::vector<float> out(cr.size() * resultFloats_);
    std::memcpy(out.data(), results_.mapped(), out.size() * sizeof(float));
    return out;
  }

 private:
  engine::Context& ctx_;
  uint32_t resultFloats_ = 1;
  engine::Buffer points_;
  engine::Buffer results_;
  engine::DeviceHandle<VkDescriptorSetLayout> layout_;
  engine::DeviceHandle<VkDescriptorPool> pool_;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
  engine::DeviceHandle<VkPipelineLayout> pipelineLayout_;
  engine::DeviceHandle<VkPipeline> pipeline_;
};

double maxJump(const std::vector<float>& s, size_t begin, size_t end) {
  double m = 0.0;
  for (size_t i = begin + 1; i < end; ++i) m = std::max(m, double(std::abs(s[i] - s[i - 1])));
  return m;
}

TEST(ShadowBlendBand, NoJumpAcrossTheBandLargerThanTheKernelStep) {
  {
    ShadowScene scene;
    csm::ShadowSettings settings;
    settings.cascadeCount = 2;
    settings.resolution = 1024;
    settings.shadowDistanceM = 60.0;
    settings.blendBand = 0.3;
    CSM_ASSERT_OK(scene.update(settings));
    const csm::CascadeFrame frame = scene.computeFrame();
    ASSERT_FALSE(frame.cascades[0].empty);
    ASSERT_FALSE(frame.cascades[1].empty);
    const double split = frame.splitsM[1];
    const double bandStart = split - settings.blendBand * (split - frame.splitsM[0]);
    const double texel1 = frame.cascades[1].texelSizeM();

    // The rail's shadow edge on the plane (the +x side: the light travels toward +x).
    const csm::AabbWs rail = scene.boxes.back();
    const glm::dvec3 l = glm::normalize(scene.light.directionWs);
    const double edgeX = rail.maxWs.x + rail.maxWs.y * (l.x / -l.y);

    // Points on the plane with a given view depth and x: the camera looks along -z and down.
    const glm::dvec3 cam = scene.camera.positionWs;
    const glm::dvec3 fwd = scene.camera.forwardWs();
    auto atDepth = [&](double x, double depth) {
      // depth = dot((x, 0, z) - cam, fwd) -> z
      const double z = cam.z + (depth - (x - cam.x) * fwd.x - (0.0 - cam.y) * fwd.y) / fwd.z;
      return glm::dvec3(x, 0.0, z);
    };
    const int n = 800;
    const double from = bandStart - 1.0, to = split + 1.0;
    const double spacing = (to - from) / (n - 1);

    for (csm::PcfKernel kernel :
         {csm::PcfKernel::k1Tap, csm::PcfKernel::kTent3, csm::PcfKernel::kTent5,
          csm::PcfKernel::kTent7, csm::PcfKernel::kPoisson16}) {
      SCOPED_TRACE(csm::kernelName(kernel));
      const double offset = 0.35 * texel1 * csm::kernelRadiusTexels(kernel);
      std::vector<glm::dvec3> points;
      // Along the view direction, inside the shadow near its edge, through the band.
      for (int i = 0; i < n; ++i) points.push_back(atDepth(edgeX - offset, from + spacing * i));
      // Across the edge at the same spacing, once in each cascade: the kernel's own steps.
      for (double depth : {bandStart - 0.5, split + 0.5}) {
        for (int i = 0; i < n; ++i) {
          points.push_back(atDepth(edgeX - 0.5 * n * spacing + spacing * i, depth));
        }
      }
      std::vector<float> s, hard;
      {
        Probe probe(scene.context(), scene.renderer().lightingSetLayout(), kernel, true,
                    uint32_t(points.size()));
        s = probe.run(scene, frame, points);
      }
      {
        Probe probe(scene.context(), scene.renderer().lightingSetLayout(), kernel, false,
                    uint32_t(points.size()));
        hard = probe.run(scene, frame, points);
      }
      const double kernelStep = std::max(maxJump(s, n, 2 * n), maxJump(s, 2 * n, 3 * n));
      // The band: samples with view depth in [bandStart, split].
      const size_t b0 = size_t(std::ceil((bandStart - from) / spacing));
      const size_t b1 = std::min(size_t(std::floor((split - from) / spacing)) + 2, size_t(n));
      const double bandJump = maxJump(s, b0, b1);
      const double hardJump = maxJump(hard, b0, b1);
      std::printf(
          "%-10s kernel step %.4f, largest jump in the band: blended %.4f, hard %.4f"
          " (s %.3f -> %.3f)\n",
          csm::kernelName(kernel), kernelStep, bandJump, hardJump, s[b0], s[b1 - 1]);
      EXPECT_GT(kernelStep, 0.0) << "the probe line must cross the shadow edge";
      EXPECT_LE(bandJump, kernelStep + 1e-3);
      // The test can fail: without the blend the switch is a larger jump.
      EXPECT_GT(hardJump, bandJump);
    }
  }
  EXPECT_EQ(validationMessages(), 0u);
}

// The GPU's cascade selection (csmSelectCascade in csm.glsl) against the CPU mirror
// (csm::selectCascade) at many points through every cascade and band: the same cascade, the same
// blended cascade and the same blend weight, except within float rounding of a boundary.
TEST(ShadowSelection, GpuIndexAndBlendWeightMatchTheCpuMirror) {
  {
    ShadowScene scene;
    csm::ShadowSettings settings;
    settings.cascadeCount = 4;
    settings.resolution = 512;
    settings.shadowDistanceM = 60.0;
    settings.blendBand = 0.25;
    CSM_ASSERT_OK(scene.update(settings));
    const csm::CascadeFrame frame = scene.computeFrame();
    const glm::dvec3 cam = scene.camera.positionWs;
    const glm::dvec3 fwd = scene.camera.forwardWs();
    const glm::dvec3 right = glm::normalize(glm::cross(fwd, glm::dvec3(0, 1, 0)));
    const glm::dvec3 up = glm::cross(right, fwd);
    // Depths from before the first split to past the last, with lateral offsets.
    const int n = 24000;
    std::vector<glm::dvec3> points;
    for (int i = 0; i < n; ++i) {
      const double depth = 1.1 * frame.shadowFarM * (i + 0.5) / n;
      const double x = 0.4 * depth * std::sin(0.37 * i), y = 0.2 * depth * std::cos(0.91 * i);
      points.push_back(cam + depth * fwd + x * right + y * up);
    }
    std::vector<float> gpu;
    {
      Probe probe(scene.context(), scene.renderer().lightingSetLayout(), csm::PcfKernel::k1Tap,
                  true, uint32_t(points.size()), selection_probe_comp_spv, 4);
      gpu = probe.run(scene, frame, points);
    }
    std::vector<double> edges;  // splits and band starts (view depth, m)
    for (uint32_t c = 0; c < frame.cascadeCount; ++c) {
      const double nearM = frame.splitsM[c], farM = frame.splitsM[c + 1];
      edges.push_back(nearM);
      edges.push_back(farM);
      edges.push_back(farM - settings.blendBand * (farM - nearM));
    }
    uint64_t compared = 0, skipped = 0, indexDiffer = 0, blendDiffer = 0, inBand = 0;
    double maxWeightDiff = 0.0;
    for (int i = 0; i < n; ++i) {
      const double depth = csm::viewDepthM(frame, points[i]);
      bool nearEdge = false;
      for (double e : edges) nearEdge = nearEdge || std::abs(depth - e) < 1e-4 * std::max(1.0, e);
      if (nearEdge) {
        ++skipped;
        continue;
      }
      const csm::CascadeSelection cpu = csm::selectCascade(frame, depth, settings.blendBand);
      const int gIndex = int(std::lround(gpu[4 * i + 0]));
      const int gBlend = int(std::lround(gpu[4 * i + 1]));
      const double gWeight = gpu[4 * i + 2];
      ++compared;
      indexDiffer += gIndex != cpu.index ? 1 : 0;
      blendDiffer += gBlend != cpu.blendIndex ? 1 : 0;
      if (cpu.blendIndex >= 0) {
        ++inBand;
        maxWeightDiff = std::max(maxWeightDiff, std::abs(gWeight - double(cpu.blendWeight)));
      } else {
        maxWeightDiff = std::max(maxWeightDiff, std::abs(gWeight));
      }
    }
    std::printf(
        "selection: %llu points compared (%llu in bands, %llu within rounding of an edge "
        "left out): index differs at %llu, blend cascade at %llu, largest weight "
        "difference %.2e\n",
        (unsigned long long)compared, (unsigned long long)inBand, (unsigned long long)skipped,
        (unsigned long long)indexDiffer, (unsigned long long)blendDiffer, maxWeightDiff);
    EXPECT_GT(compared, uint64_t(0.99 * n));
    EXPECT_GT(inBand, uint64_t(0.05 * n));  // the bands of the first three cascades
    EXPECT_EQ(indexDiffer, 0u);
    EXPECT_EQ(blendDiffer, 0u);
    EXPECT_LT(maxWeightDiff, 1e-3);
  }
  EXPECT_EQ(validationMessages(), 0u);
}

}  // namespace
}  // namespace csm_test
