// The prefiltered filters' moment image (ShadowSettings::kernel vsm, evsm or msm): a mip-mapped
// RGBA32F 2D array beside the depth array, one layer per cascade, and its resolve after every
// shadow pass: csm_moments.comp turns depths into moments and blurs them separably (x into a
// one-level scratch image, y into level 0), then blits build the mips. The lighting set binds it
// at CSM_BINDING_MOMENTS through a trilinear sampler (clamped, or REPEAT for cached cascades,
// whose layers are addressed toroidally like the depth layers).
//
// The resolve is full: every texel of every layer, every shadow pass (with the cache on too; a
// resolve of only the rectangles the pass changed is not built yet).
#include <algorithm>
#include <bit>
#include <span>
#include <string>

#include <csm_shaders/csm_moments.comp.spv.h>

#include "csm/moments.hpp"
#include "shadow_renderer_impl.hpp"
#include "vk_util.hpp"

namespace csm::vk {

namespace {

constexpr VkFormat kMomentFormat = VK_FORMAT_R32G32B32A32_SFLOAT;

struct MomentPush {
  std::uint32_t pass = 0;
  std::uint32_t kernel = 0;
  float blurM = 0.0f;
  std::uint32_t layer = 0;
};

VkImageMemoryBarrier2 imageBarrier(VkImage image, std::uint32_t baseLevel, std::uint32_t levels,
                                   std::uint32_t layers) {
  auto b = vkInit<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2);
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, baseLevel, levels, 0, layers};
  return b;
}

void barrier(VkCommandBuffer cmd, std::span<const VkImageMemoryBarrier2> images,
             const VkMemoryBarrier2* memory = nullptr) {
  auto dep = vkInit<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.imageMemoryBarrierCount = static_cast<std::uint32_t>(images.size());
  dep.pImageMemoryBarriers = images.data();
  dep.memoryBarrierCount = memory ? 1u : 0u;
  dep.pMemoryBarriers = memory;
  vkCmdPipelineBarrier2(cmd, &dep);
}

}  // namespace

// The resolve's set layout (the uniform block, the depth map, the scratch and level 0 as storage
// images), its pipeline layout and compute pipeline, and the trilinear samplers.
Status ShadowRenderer::Impl::createMomentResources() {
  VkDevice dev = device_.device;
  {
    const VkShaderStageFlags c = VK_SHADER_STAGE_COMPUTE_BIT;
    VkDescriptorSetLayoutBinding b[4]{};
    b[0] = {0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, c, nullptr};
    b[1] = {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, c, nullptr};
    b[2] = {2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, c, nullptr};
    b[3] = {3, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, c, nullptr};
    auto ci = vkInit<VkDescriptorSetLayoutCreateInfo>(
        VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
    ci.bindingCount = 4;
    ci.pBindings = b;
    CSM_VK_TRY(vkCreateDescriptorSetLayout(dev, &ci, nullptr, &momentSetLayout_));
    setName(handleBits(momentSetLayout_), VK_OBJECT_TYPE_DESCRIPTOR_SET_LAYOUT,
            "csm moment set layout");
  }
  {
    VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(MomentPush)};
    auto ci = vkInit<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
    ci.setLayoutCount = 1;
    ci.pSetLayouts = &momentSetLayout_;
    ci.pushConstantRangeCount = 1;
    ci.pPushConstantRanges = &range;
    CSM_VK_TRY(vkCreatePipelineLayout(dev, &ci, nullptr, &momentPipelineLayout_));
    setName(handleBits(momentPipelineLayout_), VK_OBJECT_TYPE_PIPELINE_LAYOUT,
            "csm moment pipeline layout");
  }
  {
    VkShaderModule module = VK_NULL_HANDLE;
    auto mi = vkInit<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
    mi.codeSize = sizeof(csm_moments_comp_spv);
    mi.pCode = csm_moments_comp_spv;
    CSM_VK_TRY(vkCreateShaderModule(dev, &mi, nullptr, &module));
    auto ci = vkInit<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
    ci.stage = vkInit<VkPipelineShaderStageCreateInfo>(
        VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
    ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    ci.stage.module = module;
    ci.stage.pName = "main";
    ci.layout = momentPipelineLayout_;
    const VkResult r =
        vkCreateComputePipelines(dev, device_.pipelineCache, 1, &ci, nullptr, &momentPipeline_);
    vkDestroyShaderModule(dev, module, nullptr);
    if (r != VK_SUCCESS) return vkError(r, "vkCreateComputePipelines(csm moments)");
    setName(handleBits(momentPipeline_), VK_OBJECT_TYPE_PIPELINE, "csm moment resolve");
  }
  {
    auto ci = vkInit<VkSamplerCreateInfo>(VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO);
    ci.magFilter = VK_FILTER_LINEAR;
    ci.minFilter = VK_FILTER_LINEAR;
    ci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
    ci.addressModeU = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    ci.addressModeV = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    ci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    ci.minLod = 0.0f;
    ci.maxLod = VK_LOD_CLAMP_NONE;
    CSM_VK_TRY(vkCreateSampler(dev, &ci, nullptr, &momentSampler_));
    setName(handleBits(momentSampler_), VK_OBJECT_TYPE_SAMPLER, "csm moment sampler");
    ci.addressModeU = VK_SAMPLER_ADDRESS_MODE_REPEAT;
    ci.addressModeV = VK_SAMPLER_ADDRESS_MODE_REPEAT;
    CSM_VK_TRY(vkCreateSampler(dev, &ci, nullptr, &wrapMomentSampler_));
    setName(handleBits(wrapMomentSampler_), VK_OBJECT_TYPE_SAMPLER, "csm moment sampler (wrap)");
  }
  return {};
}

void ShadowRenderer::Impl::destroyMomentResources() noexcept {
  VkDevice dev = device_.device;
  vkDestroyPipeline(dev, momentPipeline_, nullptr);
  vkDestroyPipelineLayout(dev, momentPipelineLayout_, nullptr);
  vkDestroyDescriptorSetLayout(dev, momentSetLayout_, nullptr);
  vkDestroySampler(dev, momentSampler_, nullptr);
  vkDestroySampler(dev, wrapMomentSampler_, nullptr);
  momentPipeline_ = VK_NULL_HANDLE;
  momentPipelineLayout_ = VK_NULL_HANDLE;
  momentSetLayout_ = VK_NULL_HANDLE;
  momentSampler_ = VK_NULL_HANDLE;
  wrapMomentSampler_ = VK_NULL_HANDLE;
}

void ShadowRenderer::Impl::destroyMomentImages(MomentImages& m) noexcept {
  VkDevice dev = device_.device;
  for (VkImageView v : {m.sampledView, m.storageView, m.scratchView}) {
    vkDestroyImageView(dev, v, nullptr);
  }
  vkDestroyImage(dev, m.image, nullptr);
  vkDestroyImage(dev, m.scratch, nullptr);
  vkFreeMemory(dev, m.memory, nullptr);
  vkFreeMemory(dev, m.scratchMemory, nullptr);
  m = MomentImages{};  // the set is freed with its pool
}

// The moment and scratch images of `settings` (prefiltered kernels only) and the resolve's set,
// allocated from `pool` (the lighting set's, which lives with the images).
Status ShadowRenderer::Impl::buildMomentImages(const ShadowSettings& settings,
                                               VkDescriptorPool pool, MomentImages& out) {
  VkDevice dev = device_.device;
  VkFormatProperties fp{};
  vkGetPhysicalDeviceFormatProperties(device_.physicalDevice, kMomentFormat, &fp);
  const VkFormatFeatureFlags need = VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT |
                                    VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT |
                                    VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT |
                                    VK_FORMAT_FEATURE_BLIT_SRC_BIT | VK_FORMAT_FEATURE_BLIT_DST_BIT;
  if ((fp.optimalTilingFeatures & need) != need) {
    return Status(
        ErrorCode::kUnsupportedFormat,
        fmt("settings.kernel = %s needs VK_FORMAT_R32G32B32A32_SFLOAT with linear "
            "filtering, storage and blits (features 0x%x of 0x%x): allowed a "
            "percentage-closer kernel on this device",
            kernelName(settings.kernel), unsigned(fp.optimalTilingFeatures), unsigned(need)));
  }
  MomentImages m;
  m.kernel = settings.kernel;
  m.levels = static_cast<std::uint32_t>(std::bit_width(settings.resolution));
  auto fail = [&](Status st) {
    destroyMomentImages(m);
    return st;
  };
  auto ci = vkInit<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
  ci.imageType = VK_IMAGE_TYPE_2D;
  ci.format = kMomentFormat;
  ci.extent = {settings.resolution, settings.resolution, 1};
  ci.mipLevels = m.levels;
  ci.arrayLayers = settings.cascadeCount;
  ci.samples = VK_SAMPLE_COUNT_1_BIT;
  ci.tiling = VK_IMAGE_TILING_OPTIMAL;
  ci.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_STORAGE_BIT |
             VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  ci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  ci.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkResult r = vkCreateImage(dev, &ci, nullptr, &m.image);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImage(csm moments)"));
  setName(handleBits(m.image), VK_OBJECT_TYPE_IMAGE, "csm moments");
  ci.mipLevels = 1;
  ci.arrayLayers = 1;  // the layers are resolved one after the other
  ci.usage = VK_IMAGE_USAGE_STORAGE_BIT;
  r = vkCreateImage(dev, &ci, nullptr, &m.scratch);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImage(csm moment scratch)"));
  setName(handleBits(m.scratch), VK_OBJECT_TYPE_IMAGE, "csm moment scratch");
  VkMemoryRequirements req{};
  vkGetImageMemoryRequirements(dev, m.image, &req);
  Status s = allocate(req, &m.memory, "csm moments memory");
  if (!s.ok()) return fail(s);
  r = vkBindImageMemory(dev, m.image, m.memory, 0);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkBindImageMemory(csm moments)"));
  vkGetImageMemoryRequirements(dev, m.scratch, &req);
  s = allocate(req, &m.scratchMemory, "csm moment scratch memory");
  if (!s.ok()) return fail(s);
  r = vkBindImageMemory(dev, m.scratch, m.scratchMemory, 0);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkBindImageMemory(csm moment scratch)"));

  auto vi = vkInit<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
  vi.viewType = VK_IMAGE_VIEW_TYPE_2D_ARRAY;
  vi.format = kMomentFormat;
  vi.image = m.image;
  vi.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, m.levels, 0, settings.cascadeCount};
  r = vkCreateImageView(dev, &vi, nullptr, &m.sampledView);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImageView(csm moments)"));
  vi.subresourceRange.levelCount = 1;
  r = vkCreateImageView(dev, &vi, nullptr, &m.storageView);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImageView(csm moments level 0)"));
  vi.image = m.scratch;
  vi.subresourceRange.layerCount = 1;
  r = vkCreateImageView(dev, &vi, nullptr, &m.scratchView);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImageView(csm moment scratch)"));

  auto ai = vkInit<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  ai.descriptorPool = pool;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &momentSetLayout_;
  r = vkAllocateDescriptorSets(dev, &ai, &m.set);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkAllocateDescriptorSets(csm moments)"));
  setName(handleBits(m.set), VK_OBJECT_TYPE_DESCRIPTOR_SET, "csm moment set");
  out = m;
  return {};
}

// The resolve's set: the uniform block, the depth array (nearest), scratch and level 0.
void ShadowRenderer::Impl::writeMomentSet() const {
  if (moments_.set == VK_NULL_HANDLE) return;
  VkDescriptorBufferInfo bi{uniformBuffer_, 0, sizeof(CsmUniforms)};
  VkDescriptorImageInfo depth{depthSampler_, arrayView_, sampledLayout()};
  VkDescriptorImageInfo scratch{VK_NULL_HANDLE, moments_.scratchView, VK_IMAGE_LAYOUT_GENERAL};
  VkDescriptorImageInfo level0{VK_NULL_HANDLE, moments_.storageView, VK_IMAGE_LAYOUT_GENERAL};
  VkWriteDescriptorSet w[4]{};
  for (std::uint32_t i = 0; i < 4; ++i) {
    w[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    w[i].dstSet = moments_.set;
    w[i].dstBinding = i;
    w[i].descriptorCount = 1;
  }
  w[0].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  w[0].pBufferInfo = &bi;
  w[1].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  w[1].pImageInfo = &depth;
  w[2].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  w[2].pImageInfo = &scratch;
  w[3].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  w[3].pImageInfo = &level0;
  vkUpdateDescriptorSets(device_.device, 4, w, 0, nullptr);
}

// With the depth map's one-time clear: every moment texel holds the far plane's moments (lit)
// in the sampled layout, so a lighting pass may sample before the first shadow pass.
void ShadowRenderer::Impl::recordMomentClear(VkCommandBuffer cmd) {
  if (moments_.image == VK_NULL_HANDLE) return;
  VkImageMemoryBarrier2 b = imageBarrier(moments_.image, 0, moments_.levels, layerCount_);
  b.srcStageMask = VK_PIPELINE_STAGE_2_NONE;
  b.dstStageMask = VK_PIPELINE_STAGE_2_CLEAR_BIT;
  b.dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  b.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  barrier(cmd, {&b, 1});
  const glm::vec4 far = depthMoments(moments_.kernel, 1.0f, settings_);
  VkClearColorValue value{};
  value.float32[0] = far.x;
  value.float32[1] = far.y;
  value.float32[2] = far.z;
  value.float32[3] = far.w;
  const VkImageSubresourceRange range = b.subresourceRange;
  vkCmdClearColorImage(cmd, moments_.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &value, 1,
                       &range);
  b.srcStageMask = VK_PIPELINE_STAGE_2_CLEAR_BIT;
  b.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  b.dstStageMask = options_.consumerStages;
  b.dstAccessMask = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  b.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  b.newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  barrier(cmd, {&b, 1});
}

// After the shadow pass (the depth layers written and in the sampled layout, the uniform block
// updated): depth -> moments, blur x, blur y, mips; then the sampled layout for the consumers.
void ShadowRenderer::Impl::recordMomentResolve(VkCommandBuffer cmd) {
  if (moments_.image == VK_NULL_HANDLE) return;
  const std::uint32_t layers = layerCount_;
  // The depth writes and the uniform update before the resolve reads them; earlier readers of
  // the moments and of the scratch finish before they are overwritten (the content is discarded:
  // the resolve is full).
  auto mem = vkInit<VkMemoryBarrier2>(VK_STRUCTURE_TYPE_MEMORY_BARRIER_2);
  mem.srcStageMask = VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT |
                     VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT |
                     VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT | options_.consumerStages;
  mem.srcAccessMask =
      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT;
  mem.dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  mem.dstAccessMask = VK_ACCESS_2_UNIFORM_READ_BIT | VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  VkImageMemoryBarrier2 start[3] = {imageBarrier(moments_.image, 0, 1, layers),
                                    imageBarrier(moments_.image, 1, moments_.levels - 1, layers),
                                    imageBarrier(moments_.scratch, 0, 1, 1)};
  start[0].srcStageMask = options_.consumerStages;
  start[0].dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  start[0].dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
  start[0].oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  start[0].newLayout = VK_IMAGE_LAYOUT_GENERAL;
  start[1].srcStageMask = options_.consumerStages;
  start[1].dstStageMask = VK_PIPELINE_STAGE_2_BLIT_BIT;
  start[1].dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  start[1].oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  start[1].newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  start[2].srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  start[2].dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  start[2].dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
  start[2].oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  start[2].newLayout = VK_IMAGE_LAYOUT_GENERAL;
  barrier(cmd, start, &mem);  // levels >= 9: the resolution is at least 256

  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, momentPipeline_);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, momentPipelineLayout_, 0, 1,
                          &moments_.set, 0, nullptr);
  const std::uint32_t groups = (resolution_ + CSM_MOMENT_GROUP - 1) / CSM_MOMENT_GROUP;
  MomentPush push;
  push.kernel = static_cast<std::uint32_t>(moments_.kernel);
  push.blurM = static_cast<float>(settings_.momentBlurM);
  // Per layer: x into the scratch, then y into level 0; the scratch's reads finish before the
  // next layer overwrites it.
  VkImageMemoryBarrier2 s = imageBarrier(moments_.scratch, 0, 1, 1);
  s.srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  s.dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  s.oldLayout = VK_IMAGE_LAYOUT_GENERAL;
  s.newLayout = VK_IMAGE_LAYOUT_GENERAL;
  for (std::uint32_t layer = 0; layer < layers; ++layer) {
    push.layer = layer;
    for (std::uint32_t pass = 0; pass < 2; ++pass) {
      push.pass = pass;
      vkCmdPushConstants(cmd, momentPipelineLayout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push),
                         &push);
      vkCmdDispatch(cmd, groups, groups, 1);
      // After x: its writes before y reads; after y: its reads before the next x writes.
      s.srcAccessMask =
          pass == 0 ? VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT : VK_ACCESS_2_SHADER_STORAGE_READ_BIT;
      s.dstAccessMask =
          pass == 0 ? VK_ACCESS_2_SHADER_STORAGE_READ_BIT : VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
      if (pass == 0 || layer + 1 < layers) barrier(cmd, {&s, 1});
    }
  }

  // Level 0 -> blit source; each level from the one above it, then a blit source itself.
  VkImageMemoryBarrier2 b = imageBarrier(moments_.image, 0, 1, layers);
  b.srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  b.srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
  b.dstStageMask = VK_PIPELINE_STAGE_2_BLIT_BIT;
  b.dstAccessMask = VK_ACCESS_2_TRANSFER_READ_BIT;
  b.oldLayout = VK_IMAGE_LAYOUT_GENERAL;
  b.newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  barrier(cmd, {&b, 1});
  std::int32_t side = static_cast<std::int32_t>(resolution_);
  for (std::uint32_t level = 1; level < moments_.levels; ++level) {
    const std::int32_t next = std::max(side / 2, 1);
    VkImageBlit blit{};
    blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level - 1, 0, layers};
    blit.srcOffsets[1] = {side, side, 1};
    blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, 0, layers};
    blit.dstOffsets[1] = {next, next, 1};
    vkCmdBlitImage(cmd, moments_.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, moments_.image,
                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_LINEAR);
    b = imageBarrier(moments_.image, level, 1, layers);
    b.srcStageMask = VK_PIPELINE_STAGE_2_BLIT_BIT;
    b.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    b.dstStageMask = VK_PIPELINE_STAGE_2_BLIT_BIT;
    b.dstAccessMask = VK_ACCESS_2_TRANSFER_READ_BIT;
    b.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    b.newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    barrier(cmd, {&b, 1});
    side = next;
  }
  b = imageBarrier(moments_.image, 0, moments_.levels, layers);
  b.srcStageMask = VK_PIPELINE_STAGE_2_BLIT_BIT;
  b.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  b.dstStageMask = options_.consumerStages;
  b.dstAccessMask = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  b.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  b.newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  barrier(cmd, {&b, 1});
}

}  // namespace csm::vk
