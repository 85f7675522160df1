// The prefiltered filters' moment image (ShadowSettings::kernel vsm, evsm or msm): a mip-mapped
// RGBA32F 2D array (RG32F for vsm where the device stores it) beside the depth array, one layer per
// cascade, and its resolve after every shadow pass: csm_moments.comp turns depths into moments and
// blurs them separably into level 0 (one dispatch per layer: each workgroup blurs its tile along x
// in shared memory, then along y), then a second pass builds the mips (2x2 means). The lighting set
// binds it at CSM_BINDING_MOMENTS through a trilinear sampler (clamped, or REPEAT for cached
// cascades, whose layers are addressed toroidally like the depth layers).
//
// After a cached pass the resolve is partial: only the tiles (kMomentTile texels square) that
// the rectangles the pass changed touch, widened by the blur, are converted, blurred and
// re-mipped; every other texel already holds what a full resolve would write (the shader computes
// each texel from the depths and uniforms alone, so the two agree bit for bit: test
// CacheWorld.*). Otherwise (uncached passes, a new image, new blur or exponents) it is full.
#include <algorithm>
#include <bit>
#include <span>
#include <string>

#include <csm_shaders/csm_moments.comp.spv.h>
#include <csm_shaders/csm_moments_q16.comp.spv.h>
#include <csm_shaders/csm_moments_rg.comp.spv.h>

#include "csm/cache_rects.hpp"
#include "csm/moments.hpp"
#include "shadow_renderer_impl.hpp"
#include "vk_util.hpp"

namespace csm::vk {

namespace {

// What the moment image needs of its format: sampled with linear filtering, and stored by the
// resolve.
constexpr VkFormatFeatureFlags kMomentFeatures = VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT |
                                                 VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT |
                                                 VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT;

struct MomentPush {
  std::uint32_t pass = 0;
  std::uint32_t kernel = 0;
  float blurM = 0.0f;
  std::uint32_t layer = 0;
  std::int32_t origin[2] = {0, 0};  // the rectangle of the layer this dispatch covers
  std::int32_t extent[2] = {0, 0};
};

// The partial resolve's granularity: the changed texels are rounded out to tiles this wide (a
// power of two, larger than CSM_MOMENT_MAX_BLUR_TEXELS). Levels 1..log2(kMomentTile) of a tile
// are exact sub-rectangles; the levels below are rebuilt whole for a changed layer.
constexpr std::int32_t kMomentTile = 32;
static_assert(kMomentTile > CSM_MOMENT_MAX_BLUR_TEXELS);
constexpr std::uint32_t kMomentTileLevels = 5;  // log2(kMomentTile)

// Workgroups of csm_moments.comp over `extent` texels: pass 0's cover CSM_MOMENT_GROUP_X x
// (CSM_MOMENT_GROUP_Y x CSM_MOMENT_ROWS) texels, pass 2's (the mips) one texel an invocation.
void dispatchMoments(VkCommandBuffer cmd, std::uint32_t pass, const std::int32_t extent[2]) {
  const std::int32_t rows = pass == 0 ? CSM_MOMENT_GROUP_Y * CSM_MOMENT_ROWS : CSM_MOMENT_GROUP_Y;
  vkCmdDispatch(cmd, std::uint32_t((extent[0] + CSM_MOMENT_GROUP_X - 1) / CSM_MOMENT_GROUP_X),
                std::uint32_t((extent[1] + rows - 1) / rows), 1);
}

// Marks the tiles of the texels [x0, x1) x [y0, y1) of a toroidal layer of `tiles` tiles a side
// (coordinates may run past its edges: they wrap).
void markTiles(std::vector<std::uint8_t>& mark, std::int32_t tiles, std::int32_t x0,
               std::int32_t y0, std::int32_t x1, std::int32_t y1) {
  if (x0 >= x1 || y0 >= y1) return;
  auto tileOf = [](std::int32_t t) { return std::int32_t(csm::floorDiv(t, kMomentTile)); };
  std::int32_t tx0 = tileOf(x0), tx1 = tileOf(x1 - 1) + 1;
  std::int32_t ty0 = tileOf(y0), ty1 = tileOf(y1 - 1) + 1;
  if (tx1 - tx0 >= tiles) tx0 = 0, tx1 = tiles;
  if (ty1 - ty0 >= tiles) ty0 = 0, ty1 = tiles;
  for (std::int32_t ty = ty0; ty < ty1; ++ty) {
    const std::int64_t row = csm::floorMod(ty, tiles);
    for (std::int32_t tx = tx0; tx < tx1; ++tx) {
      mark[std::size_t(row) * std::size_t(tiles) + std::size_t(csm::floorMod(tx, tiles))] = 1;
    }
  }
}

// The marked tiles as texel rectangles: runs along each row, merged with the same run of the
// rows below.
void tileRects(const std::vector<std::uint8_t>& mark, std::int32_t tiles,
               std::vector<std::array<std::int32_t, 4>>& out) {
  out.clear();
  std::vector<std::size_t> open;  // rectangles of `out` that end at the previous row
  std::vector<std::size_t> next;
  for (std::int32_t ty = 0; ty < tiles; ++ty) {
    next.clear();
    for (std::int32_t tx = 0; tx < tiles;) {
      if (mark[std::size_t(ty) * tiles + tx] == 0) {
        ++tx;
        continue;
      }
      std::int32_t end = tx;
      while (end < tiles && mark[std::size_t(ty) * tiles + end] != 0) ++end;
      const std::int32_t x0 = tx * kMomentTile, x1 = end * kMomentTile;
      const auto same = std::find_if(open.begin(), open.end(), [&](std::size_t k) {
        return out[k][0] == x0 && out[k][2] == x1;
      });
      if (same != open.end()) {
        out[*same][3] += kMomentTile;
        next.push_back(*same);
      } else {
        out.push_back({x0, ty * kMomentTile, x1, (ty + 1) * kMomentTile});
        next.push_back(out.size() - 1);
      }
      tx = end;
    }
    std::swap(open, next);
  }
}

std::uint64_t rectArea(const std::vector<std::array<std::int32_t, 4>>& rects) noexcept {
  std::uint64_t sum = 0;
  for (const auto& r : rects) sum += std::uint64_t(r[2] - r[0]) * std::uint64_t(r[3] - r[1]);
  return sum;
}

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

// The resolve's set layout (the uniform block, the depth map, the mip source and destination as
// storage images), its pipeline layout and compute pipeline, and the trilinear samplers.
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
  // The resolve writes RGBA32F; a second build of it writes RG32F (vsm's two moments), which
  // needs shaderStorageImageExtendedFormats.
  auto pipeline = [&](std::span<const std::uint32_t> code, VkPipeline* out,
                      const char* name) -> Status {
    VkShaderModule module = VK_NULL_HANDLE;
    auto mi = vkInit<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
    mi.codeSize = code.size_bytes();
    mi.pCode = code.data();
    CSM_VK_TRY(vkCreateShaderModule(dev, &mi, nullptr, &module));
    auto ci = vkInit<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
    ci.stage = vkInit<VkPipelineShaderStageCreateInfo>(
        VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
    ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    ci.stage.module = module;
    ci.stage.pName = "main";
    ci.layout = momentPipelineLayout_;
    const VkResult r = vkCreateComputePipelines(dev, device_.pipelineCache, 1, &ci, nullptr, out);
    vkDestroyShaderModule(dev, module, nullptr);
    if (r != VK_SUCCESS) return vkError(r, "vkCreateComputePipelines(csm moments)");
    setName(handleBits(*out), VK_OBJECT_TYPE_PIPELINE, name);
    return {};
  };
  Status ps = pipeline(csm_moments_comp_spv, &momentPipeline_, "csm moment resolve");
  if (ps.ok() && device_.storageImageExtendedFormatsEnabled) {
    ps = pipeline(csm_moments_rg_comp_spv, &momentPipelineRg_, "csm moment resolve (RG32F)");
    if (ps.ok()) {
      ps = pipeline(csm_moments_q16_comp_spv, &momentPipelineQ16_,
                    "csm moment resolve (RGBA16, quantised)");
    }
  }
  if (!ps.ok()) return ps;
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
    // Anisotropic where the host enabled it (DeviceInfo::maxSamplerAnisotropy, checked by init).
    if (device_.maxSamplerAnisotropy > 1.0f) {
      ci.anisotropyEnable = VK_TRUE;
      ci.maxAnisotropy = device_.maxSamplerAnisotropy;
    }
    CSM_VK_TRY(vkCreateSampler(dev, &ci, nullptr, &momentSampler_));
    setName(handleBits(momentSampler_), VK_OBJECT_TYPE_SAMPLER, "csm moment sampler");
    ci.addressModeU = VK_SAMPLER_ADDRESS_MODE_REPEAT;
    ci.addressModeV = VK_SAMPLER_ADDRESS_MODE_REPEAT;
    CSM_VK_TRY(vkCreateSampler(dev, &ci, nullptr, &wrapMomentSampler_));
    setName(handleBits(wrapMomentSampler_), VK_OBJECT_TYPE_SAMPLER, "csm moment sampler (wrap)");
  }
  return {};
}

// Where the host enabled shaderStorageImageExtendedFormats and the device samples, filters and
// stores the format: RG32F for vsm (two moments), RGBA16_UNORM for msm with msmMomentBits = 64
// (quantised); else RGBA32F (buildMomentImages checks it).
VkFormat ShadowRenderer::Impl::momentFormatFor(PcfKernel kernel,
                                               std::uint32_t msmMomentBits) const {
  auto supported = [&](VkFormat format) {
    VkFormatProperties fp{};
    vkGetPhysicalDeviceFormatProperties(device_.physicalDevice, format, &fp);
    return (fp.optimalTilingFeatures & kMomentFeatures) == kMomentFeatures;
  };
  if (kernel == PcfKernel::kVsm && momentPipelineRg_ != VK_NULL_HANDLE &&
      supported(VK_FORMAT_R32G32_SFLOAT)) {
    return VK_FORMAT_R32G32_SFLOAT;
  }
  if (kernel == PcfKernel::kMsm && msmMomentBits == 64 && momentPipelineQ16_ != VK_NULL_HANDLE &&
      supported(VK_FORMAT_R16G16B16A16_UNORM)) {
    return VK_FORMAT_R16G16B16A16_UNORM;
  }
  return VK_FORMAT_R32G32B32A32_SFLOAT;
}

VkPipeline ShadowRenderer::Impl::momentPipelineFor(VkFormat format) const noexcept {
  if (format == VK_FORMAT_R32G32_SFLOAT) return momentPipelineRg_;
  if (format == VK_FORMAT_R16G16B16A16_UNORM) return momentPipelineQ16_;
  return momentPipeline_;
}

void ShadowRenderer::Impl::destroyMomentResources() noexcept {
  VkDevice dev = device_.device;
  vkDestroyPipeline(dev, momentPipeline_, nullptr);
  vkDestroyPipeline(dev, momentPipelineRg_, nullptr);
  vkDestroyPipeline(dev, momentPipelineQ16_, nullptr);
  momentPipelineRg_ = VK_NULL_HANDLE;
  momentPipelineQ16_ = VK_NULL_HANDLE;
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
  for (VkImageView v : {m.sampledView, m.storageView}) vkDestroyImageView(dev, v, nullptr);
  for (VkImageView v : m.levelViews) vkDestroyImageView(dev, v, nullptr);
  vkDestroyImage(dev, m.image, nullptr);
  vkFreeMemory(dev, m.memory, nullptr);
  m = MomentImages{};  // the set is freed with its pool
}

// The moment image of `settings` (prefiltered kernels only) and the resolve's sets,
// allocated from `pool` (the lighting set's, which lives with the images).
Status ShadowRenderer::Impl::buildMomentImages(const ShadowSettings& settings,
                                               std::uint32_t msmMomentBits, VkDescriptorPool pool,
                                               MomentImages& out) {
  VkDevice dev = device_.device;
  const VkFormat format = momentFormatFor(settings.kernel, msmMomentBits);
  VkFormatProperties fp{};
  vkGetPhysicalDeviceFormatProperties(device_.physicalDevice, format, &fp);
  if ((fp.optimalTilingFeatures & kMomentFeatures) != kMomentFeatures) {
    return Status(ErrorCode::kUnsupportedFormat,
                  fmt("settings.kernel = %s needs VK_FORMAT_R32G32B32A32_SFLOAT with linear "
                      "filtering and storage (features 0x%x of 0x%x): allowed a "
                      "percentage-closer kernel on this device",
                      kernelName(settings.kernel), unsigned(fp.optimalTilingFeatures),
                      unsigned(kMomentFeatures)));
  }
  MomentImages m;
  m.kernel = settings.kernel;
  m.format = format;
  m.levels = static_cast<std::uint32_t>(std::bit_width(settings.resolution));
  auto fail = [&](Status st) {
    destroyMomentImages(m);
    return st;
  };
  auto ci = vkInit<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
  ci.imageType = VK_IMAGE_TYPE_2D;
  ci.format = format;
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
  VkMemoryRequirements req{};
  vkGetImageMemoryRequirements(dev, m.image, &req);
  Status s = allocate(req, &m.memory, "csm moments memory");
  if (!s.ok()) return fail(s);
  r = vkBindImageMemory(dev, m.image, m.memory, 0);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkBindImageMemory(csm moments)"));

  auto vi = vkInit<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
  vi.viewType = VK_IMAGE_VIEW_TYPE_2D_ARRAY;
  vi.format = format;
  vi.image = m.image;
  vi.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, m.levels, 0, settings.cascadeCount};
  r = vkCreateImageView(dev, &vi, nullptr, &m.sampledView);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImageView(csm moments)"));
  vi.subresourceRange.levelCount = 1;
  r = vkCreateImageView(dev, &vi, nullptr, &m.storageView);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImageView(csm moments level 0)"));
  for (std::uint32_t level = 1; level < m.levels; ++level) {
    vi.subresourceRange.baseMipLevel = level;
    r = vkCreateImageView(dev, &vi, nullptr, &m.levelViews[level]);
    if (r != VK_SUCCESS) return fail(vkError(r, "vkCreateImageView(csm moments level)"));
  }

  auto ai = vkInit<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  ai.descriptorPool = pool;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &momentSetLayout_;
  r = vkAllocateDescriptorSets(dev, &ai, &m.set);
  if (r != VK_SUCCESS) return fail(vkError(r, "vkAllocateDescriptorSets(csm moments)"));
  setName(handleBits(m.set), VK_OBJECT_TYPE_DESCRIPTOR_SET, "csm moment set");
  for (std::uint32_t level = 1; level < m.levels; ++level) {
    r = vkAllocateDescriptorSets(dev, &ai, &m.mipSets[level]);
    if (r != VK_SUCCESS) return fail(vkError(r, "vkAllocateDescriptorSets(csm moment mips)"));
    setName(handleBits(m.mipSets[level]), VK_OBJECT_TYPE_DESCRIPTOR_SET, "csm moment mip set");
  }
  out = m;
  return {};
}

// The resolve's set: the uniform block, the depth array (nearest) and level 0. Binding 2, the mip
// pass's source, is never read by the blur; it holds the smallest level (a valid descriptor that
// is not level 0 itself: an alias of the written level reads as a hazard to validation).
void ShadowRenderer::Impl::writeMomentSet() const {
  if (moments_.set == VK_NULL_HANDLE) return;
  VkDescriptorBufferInfo bi{uniformBuffer_, 0, sizeof(CsmUniforms)};
  VkDescriptorImageInfo depth{depthSampler_, arrayView_, sampledLayout()};
  VkDescriptorImageInfo level0{VK_NULL_HANDLE, moments_.storageView, VK_IMAGE_LAYOUT_GENERAL};
  VkDescriptorImageInfo unread{VK_NULL_HANDLE, moments_.levelViews[moments_.levels - 1],
                               VK_IMAGE_LAYOUT_GENERAL};
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
  w[2].pImageInfo = &unread;
  w[3].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  w[3].pImageInfo = &level0;
  vkUpdateDescriptorSets(device_.device, 4, w, 0, nullptr);
  // The mip sets: the same uniform block and depth map (never read by the downsampling pass),
  // level k - 1 as the source and level k as the destination.
  for (std::uint32_t level = 1; level < moments_.levels; ++level) {
    const VkDescriptorImageInfo src{
        VK_NULL_HANDLE, level == 1 ? moments_.storageView : moments_.levelViews[level - 1],
        VK_IMAGE_LAYOUT_GENERAL};
    const VkDescriptorImageInfo dst{VK_NULL_HANDLE, moments_.levelViews[level],
                                    VK_IMAGE_LAYOUT_GENERAL};
    for (VkWriteDescriptorSet& x : w) x.dstSet = moments_.mipSets[level];
    w[2].pImageInfo = &src;
    w[3].pImageInfo = &dst;
    vkUpdateDescriptorSets(device_.device, 4, w, 0, nullptr);
  }
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

// The rectangles a resolve recomputes in each layer, tile-aligned: blurred into level 0 (pass 0
// reads the depths of the blur's reach around them itself) and re-mipped. Empty: the layer is
// unchanged.
struct ShadowRenderer::Impl::MomentRegions {
  std::array<LayerRects, kMaxCascades> rects{};
  std::array<bool, kMaxCascades> whole{};
};

// The partial resolve's regions after a cached pass: what the pass changed (momentRects_),
// widened by the blur's reach, and, where a layer's wrap offset moved (the box moved, so texels
// near its edges now read other neighbours or the far plane), the bands along the box's edges.
// Those bands lie within the reach of the rows and columns the move exposed (a toroidal layer's
// opposite box edges are neighbours), so they add nothing today; they keep the resolve exact
// should a box ever move without re-rendering what it exposes.
// False: a full resolve is needed (first resolve of the image, new blur or exponents, an uncached
// pass).
bool ShadowRenderer::Impl::planMomentRegions(MomentRegions& plan) const {
  const MomentImages& m = moments_;
  if (!momentPartial_ || !m.resolved || m.blurM != float(settings_.momentBlurM) ||
      m.evsmPositive != uniforms_.moments.z || m.evsmNegative != uniforms_.moments.w) {
    return false;
  }
  const std::int32_t res = static_cast<std::int32_t>(resolution_);
  const std::int32_t tiles = res / kMomentTile;
  std::vector<std::uint8_t> mark(std::size_t(tiles) * tiles);
  for (std::uint32_t i = 0; i < layerCount_; ++i) {
    const CsmCascadeGpu& c = uniforms_.cascades[i];
    const bool whole = ((momentWholeMask_ >> i) & 1u) != 0 || m.texelM[i] != c.texelSizeM;
    if (whole) {
      plan.whole[i] = true;
      plan.rects[i].assign(1, {0, 0, res, res});
      continue;
    }
    // The blur's reach in texels (the shader's ceil(radius), and one more against rounding).
    const float radius = momentBlurRadiusTexels(settings_.momentBlurM, c.texelSizeM);
    const std::int32_t reach = radius > 0.0f ? static_cast<std::int32_t>(std::ceil(radius)) + 1 : 0;
    std::fill(mark.begin(), mark.end(), std::uint8_t(0));
    for (const auto& r : momentRects_[i]) {
      markTiles(mark, tiles, r[0] - reach, r[1] - reach, r[2] + reach, r[3] + reach);
    }
    if (reach > 0 && c.wrapOffset.x != m.wrapOffset[i].x) {
      const std::int32_t ox = static_cast<std::int32_t>(c.wrapOffset.x);
      markTiles(mark, tiles, ox - reach, 0, ox + reach, res);
    }
    if (reach > 0 && c.wrapOffset.y != m.wrapOffset[i].y) {
      const std::int32_t oy = static_cast<std::int32_t>(c.wrapOffset.y);
      markTiles(mark, tiles, 0, oy - reach, res, oy + reach);
    }
    tileRects(mark, tiles, plan.rects[i]);
    if (rectArea(plan.rects[i]) * 4 >= 3 * std::uint64_t(res) * std::uint64_t(res)) {
      plan.whole[i] = true;  // most of the layer: one dispatch is cheaper
      plan.rects[i].assign(1, {0, 0, res, res});
    }
  }
  return true;
}

// Pass 0 over each layer's rectangles (every texel without a plan): depths to moments, blurred
// into level 0. No layer reads what another writes: no barrier between them.
void ShadowRenderer::Impl::recordMomentDispatches(VkCommandBuffer cmd, const MomentRegions* plan) {
  const std::uint32_t layers = layerCount_;
  const std::int32_t res = static_cast<std::int32_t>(resolution_);
  const LayerRects all(1, {0, 0, res, res});
  // The mips (recordMomentMips) run on the same pipeline.
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, momentPipelineFor(moments_.format));
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, momentPipelineLayout_, 0, 1,
                          &moments_.set, 0, nullptr);
  MomentPush push;
  push.pass = 0;
  push.kernel = static_cast<std::uint32_t>(moments_.kernel);
  push.blurM = static_cast<float>(settings_.momentBlurM);
  for (std::uint32_t layer = 0; layer < layers; ++layer) {
    const LayerRects& rects = plan != nullptr ? plan->rects[layer] : all;
    push.layer = layer;
    for (const auto& r : rects) {
      push.origin[0] = r[0];
      push.origin[1] = r[1];
      push.extent[0] = r[2] - r[0];
      push.extent[1] = r[3] - r[1];
      vkCmdPushConstants(cmd, momentPipelineLayout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push),
                         &push);
      dispatchMoments(cmd, push.pass, push.extent);
    }
    cacheStats_[layer].momentTexels = rectArea(rects);
  }
}

// The mips from level 0: each level from the one above it (pass 2: the mean of 2x2 texels), over
// the changed tiles' texels on the levels where a tile is at least a texel, over the whole level
// below that (for the changed layers; every layer without a plan). A compute pass rather than
// blits: lavapipe's linear blit of a sub-rectangle rounds differently from the whole level's, and
// the partial resolve must write what the full one writes, bit for bit.
void ShadowRenderer::Impl::recordMomentMips(VkCommandBuffer cmd, const MomentRegions* plan) {
  const std::uint32_t layers = layerCount_;
  const std::int32_t res = static_cast<std::int32_t>(resolution_);
  auto mem = vkInit<VkMemoryBarrier2>(VK_STRUCTURE_TYPE_MEMORY_BARRIER_2);
  mem.srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  mem.srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
  mem.dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  mem.dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_READ_BIT;
  MomentPush push;
  push.pass = 2;
  push.kernel = static_cast<std::uint32_t>(moments_.kernel);
  auto dispatch = [&](std::uint32_t layer, std::int32_t x0, std::int32_t y0, std::int32_t x1,
                      std::int32_t y1) {  // level texels
    push.layer = layer;
    push.origin[0] = x0;
    push.origin[1] = y0;
    push.extent[0] = x1 - x0;
    push.extent[1] = y1 - y0;
    vkCmdPushConstants(cmd, momentPipelineLayout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push),
                       &push);
    dispatchMoments(cmd, push.pass, push.extent);
  };
  for (std::uint32_t level = 1; level < moments_.levels; ++level) {
    const std::int32_t side = std::max(res >> level, 1);
    barrier(cmd, {}, &mem);  // the level above written before it is read
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, momentPipelineLayout_, 0, 1,
                            &moments_.mipSets[level], 0, nullptr);
    for (std::uint32_t layer = 0; layer < layers; ++layer) {
      if (plan != nullptr && plan->rects[layer].empty()) continue;
      if (plan == nullptr || plan->whole[layer] || level > kMomentTileLevels) {
        dispatch(layer, 0, 0, side, side);
        continue;
      }
      for (const auto& r : plan->rects[layer]) {
        dispatch(layer, r[0] >> level, r[1] >> level, r[2] >> level, r[3] >> level);
      }
    }
  }
}

// After the shadow pass (the depth layers written and in the sampled layout, the uniform block
// updated): depth -> moments blurred along x and y, mips (of what changed after a cached pass, else
// of everything); then the sampled layout for the consumers.
void ShadowRenderer::Impl::recordMomentResolve(VkCommandBuffer cmd) {
  const bool partialPass = momentPartial_;
  momentPartial_ = false;  // the next pass fills its own rectangles
  for (CascadeCacheStats& st : cacheStats_) st.momentTexels = 0;
  if (moments_.image == VK_NULL_HANDLE) return;
  momentPartial_ = partialPass;
  MomentRegions regions;
  const bool partial = planMomentRegions(regions);
  momentPartial_ = false;
  const MomentRegions* plan = partial ? &regions : nullptr;
  // What the image holds after this resolve was computed with these.
  auto remember = [&] {
    moments_.resolved = true;
    moments_.blurM = static_cast<float>(settings_.momentBlurM);
    moments_.evsmPositive = uniforms_.moments.z;
    moments_.evsmNegative = uniforms_.moments.w;
    for (std::uint32_t i = 0; i < layerCount_; ++i) {
      moments_.texelM[i] = uniforms_.cascades[i].texelSizeM;
      moments_.wrapOffset[i] = uniforms_.cascades[i].wrapOffset;
    }
  };
  if (plan != nullptr && std::all_of(regions.rects.begin(), regions.rects.end(),
                                     [](const LayerRects& r) { return r.empty(); })) {
    remember();  // nothing changed: every moment texel is as a full resolve would write it
    return;
  }
  const std::uint32_t layers = layerCount_;
  // The depth writes and the uniform update before the resolve reads them; earlier readers of
  // the moments finish before they are overwritten (a full resolve discards the content, a
  // partial one keeps it).
  auto mem = vkInit<VkMemoryBarrier2>(VK_STRUCTURE_TYPE_MEMORY_BARRIER_2);
  mem.srcStageMask = VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT |
                     VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT |
                     VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT | options_.consumerStages;
  mem.srcAccessMask =
      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT;
  mem.dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  mem.dstAccessMask = VK_ACCESS_2_UNIFORM_READ_BIT | VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  const VkImageLayout kept =
      plan != nullptr ? VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED;
  VkImageMemoryBarrier2 start = imageBarrier(moments_.image, 0, moments_.levels, layers);
  start.srcStageMask = options_.consumerStages;
  start.dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  start.dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT;
  start.oldLayout = kept;
  start.newLayout = VK_IMAGE_LAYOUT_GENERAL;
  barrier(cmd, {&start, 1}, &mem);

  recordMomentDispatches(cmd, plan);
  recordMomentMips(cmd, plan);
  VkImageMemoryBarrier2 b = imageBarrier(moments_.image, 0, moments_.levels, layers);
  b.srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  b.srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
  b.dstStageMask = options_.consumerStages;
  b.dstAccessMask = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  b.oldLayout = VK_IMAGE_LAYOUT_GENERAL;
  b.newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  barrier(cmd, {&b, 1});
  remember();
}

}  // namespace csm::vk
