#include "engine/memory.hpp"

#include <algorithm>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "engine/context.hpp"
#include "engine/debug.hpp"
#include "engine/errors.hpp"
#include "vk_struct.hpp"

namespace engine {
namespace {

VkDeviceSize alignUp(VkDeviceSize value, VkDeviceSize alignment) {
  return alignment <= 1 ? value : (value + alignment - 1) / alignment * alignment;
}

// Every earlier command's writes, made visible to the copy that follows (and the reverse).
constexpr VkPipelineStageFlags2 kAll = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
constexpr VkAccessFlags2 kAllAccess = VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT;

}  // namespace

// ---------------------------------------------------------------------------------------------
// Allocator

Allocator::Allocator(VkPhysicalDevice physicalDevice, VkDevice device, VkDeviceSize blockSize)
    : device_(device), blockSize_(blockSize) {
  vkGetPhysicalDeviceMemoryProperties(physicalDevice, &props_);
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(physicalDevice, &props);
  granularity_ = std::max<VkDeviceSize>(1, props.limits.bufferImageGranularity);
  blocks_.resize(props_.memoryTypeCount);
}

Allocator::~Allocator() {
  for (auto& type : blocks_)
    for (Block& b : type)
      if (b.memory) vkFreeMemory(device_, b.memory, nullptr);  // implicitly unmaps
}

uint32_t Allocator::findMemoryType(uint32_t typeBits, MemoryUsage usage) const {
  VkMemoryPropertyFlags required = 0, preferred = 0;
  switch (usage) {
    case MemoryUsage::DeviceLocal:
      required = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
      break;
    case MemoryUsage::Upload:
      required = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
      break;
    case MemoryUsage::Readback:
      required = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
      preferred = VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
      break;
  }
  int best = -1;
  for (uint32_t i = 0; i < props_.memoryTypeCount; ++i) {
    if (!(typeBits & (1u << i))) continue;
    const VkMemoryPropertyFlags flags = props_.memoryTypes[i].propertyFlags;
    if ((flags & required) != required) continue;
    if ((flags & preferred) == preferred) return i;
    if (best < 0) best = static_cast<int>(i);
  }
  if (best < 0)
    throw std::runtime_error("no Vulkan memory type fits type bits " + std::to_string(typeBits));
  return static_cast<uint32_t>(best);
}

VkDeviceMemory Allocator::allocateMemory(uint32_t type, VkDeviceSize size, void** mapped) {
  auto info = detail::vkStruct<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
  info.allocationSize = size;
  info.memoryTypeIndex = type;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkAllocateMemory(device_, &info, nullptr, &memory));
  *mapped = nullptr;
  if (props_.memoryTypes[type].propertyFlags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT) {
    const VkResult r = vkMapMemory(device_, memory, 0, VK_WHOLE_SIZE, 0, mapped);
    if (r != VK_SUCCESS) {
      vkFreeMemory(device_, memory, nullptr);
      throwVulkanError(r, "vkMapMemory", __FILE__, __LINE__);
    }
  }
  return memory;
}

Allocation Allocator::allocate(const VkMemoryRequirements& req, MemoryUsage usage, bool linear) {
  const uint32_t type = findMemoryType(req.memoryTypeBits, usage);
  // Optimal-tiling images start and end on a granularity boundary, so no linear resource
  // can share a "page" with them, whatever lies next to them.
  const VkDeviceSize alignment = linear ? req.alignment : std::max(req.alignment, granularity_);
  const VkDeviceSize size = linear ? req.size : alignUp(req.size, granularity_);

  const VkDeviceSize heapSize = props_.memoryHeaps[props_.memoryTypes[type].heapIndex].size;
  const VkDeviceSize blockSize =
      std::max<VkDeviceSize>(std::min(blockSize_, heapSize / 8), VkDeviceSize(1) << 20);

  std::lock_guard lock(mutex_);
  if (size > blockSize / 2) {
    Allocation a;
    a.memory = allocateMemory(type, size, &a.mapped);
    setDebugName(device_, a.memory,
                 "engine.memory.type" + std::to_string(type) + ".dedicated" +
                     std::to_string(dedicatedCount_));
    a.size = size;
    a.memoryType = type;
    a.dedicated = true;
    ++dedicatedCount_;
    bytesInUse_ += size;
    return a;
  }

  auto carve = [&](Block& b, uint32_t blockIndex) -> std::optional<Allocation> {
    for (size_t i = 0; i < b.freeRanges.size(); ++i) {
      const Range r = b.freeRanges[i];
      const VkDeviceSize start = alignUp(r.offset, alignment);
      if (start + size > r.offset + r.size) continue;
      std::vector<Range> pieces;
      if (start > r.offset) pieces.push_back({r.offset, start - r.offset});
      if (start + size < r.offset + r.size)
        pieces.push_back({start + size, r.offset + r.size - start - size});
      b.freeRanges.erase(b.freeRanges.begin() + static_cast<std::ptrdiff_t>(i));
      b.freeRanges.insert(b.freeRanges.begin() + static_cast<std::ptrdiff_t>(i), pieces.begin(),
                          pieces.end());
      Allocation a;
      a.memory = b.memory;
      a.offset = start;
      a.size = size;
      a.mapped = b.mapped ? static_cast<char*>(b.mapped) + start : nullptr;
      a.memoryType = type;
      a.block = blockIndex;
      bytesInUse_ += size;
      return a;
    }
    return std::nullopt;
  };

  auto& list = blocks_[type];
  for (uint32_t i = 0; i < list.size(); ++i)
    if (auto a = carve(list[i], i)) return *a;

  Block block;
  block.memory = allocateMemory(type, blockSize, &block.mapped);
  block.size = blockSize;
  block.freeRanges.push_back({0, blockSize});
  setDebugName(
      device_, block.memory,
      "engine.memory.type" + std::to_string(type) + ".block" + std::to_string(list.size()));
  list.push_back(std::move(block));
  const uint32_t index = static_cast<uint32_t>(list.size() - 1);
  return *carve(list[index], index);
}

void Allocator::free(const Allocation& a) noexcept {
  if (!a.memory) return;
  std::lock_guard lock(mutex_);
  bytesInUse_ -= a.size;
  if (a.dedicated) {
    vkFreeMemory(device_, a.memory, nullptr);
    --dedicatedCount_;
    return;
  }
  auto& ranges = blocks_[a.memoryType][a.block].freeRanges;
  auto it = std::lower_bound(ranges.begin(), ranges.end(), a.offset,
                             [](const Range& r, VkDeviceSize off) { return r.offset < off; });
  it = ranges.insert(it, Range{a.offset, a.size});
  // Merge with the next range, then with the previous one.
  if (auto next = it + 1; next != ranges.end() && it->offset + it->size == next->offset) {
    it->size += next->size;
    ranges.erase(next);
  }
  if (it != ranges.begin()) {
    auto prev = it - 1;
    if (prev->offset + prev->size == it->offset) {
      prev->size += it->size;
      ranges.erase(it);
    }
  }
}

uint32_t Allocator::deviceMemoryCount() const {
  std::lock_guard lock(mutex_);
  uint32_t n = dedicatedCount_;
  for (const auto& type : blocks_) n += static_cast<uint32_t>(type.size());
  return n;
}

VkDeviceSize Allocator::bytesInUse() const {
  std::lock_guard lock(mutex_);
  return bytesInUse_;
}

// ---------------------------------------------------------------------------------------------
// Buffer

Buffer::Buffer(Context& ctx, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUsage memory,
               std::string_view name)
    : ctx_(&ctx), size_(size) {
  auto info = detail::vkStruct<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
  info.size = size;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  VkDevice device = ctx.device();
  ENGINE_VK_CHECK(vkCreateBuffer(device, &info, nullptr, &buffer_));
  try {
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(device, buffer_, &req);
    allocation_ = ctx.allocator().allocate(req, memory, /*linear=*/true);
    ENGINE_VK_CHECK(vkBindBufferMemory(device, buffer_, allocation_.memory, allocation_.offset));
  } catch (...) {
    reset();
    throw;
  }
  setDebugName(device, buffer_, name);
}

Buffer::~Buffer() {
  reset();
}

Buffer::Buffer(Buffer&& o) noexcept
    : ctx_(o.ctx_),
      buffer_(std::exchange(o.buffer_, VK_NULL_HANDLE)),
      size_(o.size_),
      allocation_(std::exchange(o.allocation_, Allocation{})) {}

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this != &o) {
    reset();
    ctx_ = o.ctx_;
    buffer_ = std::exchange(o.buffer_, VK_NULL_HANDLE);
    size_ = o.size_;
    allocation_ = std::exchange(o.allocation_, Allocation{});
  }
  return *this;
}

void Buffer::reset() noexcept {
  if (buffer_) vkDestroyBuffer(ctx_->device(), buffer_, nullptr);
  if (allocation_) ctx_->allocator().free(allocation_);
  buffer_ = VK_NULL_HANDLE;
  allocation_ = {};
}

// ---------------------------------------------------------------------------------------------
// Image

bool isDepthFormat(VkFormat f) noexcept {
  switch (f) {
    case VK_FORMAT_D16_UNORM:
    case VK_FORMAT_X8_D24_UNORM_PACK32:
    case VK_FORMAT_D32_SFLOAT:
    case VK_FORMAT_D16_UNORM_S8_UINT:
    case VK_FORMAT_D24_UNORM_S8_UINT:
    case VK_FORMAT_D32_SFLOAT_S8_UINT:
      return true;
    default:
      return false;
  }
}

VkImageAspectFlags aspectOf(VkFormat f) noexcept {
  switch (f) {
    case VK_FORMAT_D16_UNORM_S8_UINT:
    case VK_FORMAT_D24_UNORM_S8_UINT:
    case VK_FORMAT_D32_SFLOAT_S8_UINT:
      return VK_IMAGE_ASPECT_DEPTH_BIT | VK_IMAGE_ASPECT_STENCIL_BIT;
    default:
      return isDepthFormat(f) ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT;
  }
}

uint32_t bytesPerTexel(VkFormat f) noexcept {
  switch (f) {
    case VK_FORMAT_R8_UNORM:
      return 1;
    case VK_FORMAT_D16_UNORM:
    case VK_FORMAT_R16_SFLOAT:
    case VK_FORMAT_R8G8_UNORM:
      return 2;
    case VK_FORMAT_R8G8B8A8_UNORM:
    case VK_FORMAT_R8G8B8A8_SRGB:
    case VK_FORMAT_B8G8R8A8_UNORM:
    case VK_FORMAT_B8G8R8A8_SRGB:
    case VK_FORMAT_D32_SFLOAT:
    case VK_FORMAT_R32_SFLOAT:
    case VK_FORMAT_R32_UINT:
    case VK_FORMAT_R16G16_SFLOAT:
    case VK_FORMAT_X8_D24_UNORM_PACK32:
      return 4;
    case VK_FORMAT_R16G16B16A16_SFLOAT:
    case VK_FORMAT_R32G32_SFLOAT:
      return 8;
    case VK_FORMAT_R32G32B32A32_SFLOAT:
      return 16;
    default:
      return 0;
  }
}

Image::Image(Context& ctx, const ImageDesc& desc, std::string_view name) : ctx_(&ctx), desc_(desc) {
  auto info = detail::vkStruct<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = desc.format;
  info.extent = {desc.extent.width, desc.extent.height, 1};
  info.mipLevels = desc.mipLevels;
  info.arrayLayers = desc.layers;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = desc.usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkDevice device = ctx.device();
  ENGINE_VK_CHECK(vkCreateImage(device, &info, nullptr, &image_));
  try {
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(device, image_, &req);
    allocation_ = ctx.allocator().allocate(req, MemoryUsage::DeviceLocal, /*linear=*/false);
    ENGINE_VK_CHECK(vkBindImageMemory(device, image_, allocation_.memory, allocation_.offset));
    setDebugName(device, image_, name);
    view_ = createView(desc.viewType, 0, desc.layers, std::string(name) + ".view");
  } catch (...) {
    reset();
    throw;
  }
}

Image::~Image() {
  reset();
}

Image::Image(Image&& o) noexcept
    : ctx_(o.ctx_),
      image_(std::exchange(o.image_, VK_NULL_HANDLE)),
      view_(std::exchange(o.view_, VK_NULL_HANDLE)),
      desc_(o.desc_),
      allocation_(std::exchange(o.allocation_, Allocation{})) {}

Image& Image::operator=(Image&& o) noexcept {
  if (this != &o) {
    reset();
    ctx_ = o.ctx_;
    image_ = std::exchange(o.image_, VK_NULL_HANDLE);
    view_ = std::exchange(o.view_, VK_NULL_HANDLE);
    desc_ = o.desc_;
    allocation_ = std::exchange(o.allocation_, Allocation{});
  }
  return *this;
}

VkImageAspectFlags Image::aspect() const {
  return aspectOf(desc_.format);
}

VkImageView Image::createView(VkImageViewType type, uint32_t baseLayer, uint32_t layerCount,
                              std::string_view name) const {
  auto info = detail::vkStruct<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
  info.image = image_;
  info.viewType = type;
  info.format = desc_.format;
  info.subresourceRange = {aspect(), 0, desc_.mipLevels, baseLayer, layerCount};
  VkImageView view = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreateImageView(ctx_->device(), &info, nullptr, &view));
  setDebugName(ctx_->device(), view, name);
  return view;
}

void Image::reset() noexcept {
  if (view_) vkDestroyImageView(ctx_->device(), view_, nullptr);
  if (image_) vkDestroyImage(ctx_->device(), image_, nullptr);
  if (allocation_) ctx_->allocator().free(allocation_);
  view_ = VK_NULL_HANDLE;
  image_ = VK_NULL_HANDLE;
  allocation_ = {};
}

// ---------------------------------------------------------------------------------------------
// Barriers and transfers

void imageBarrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect,
                  VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                  VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess, VkImageLayout oldLayout,
                  VkImageLayout newLayout) {
  auto b = detail::vkStruct<VkImageMemoryBarrier2>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2);
  b.srcStageMask = srcStage;
  b.srcAccessMask = srcAccess;
  b.dstStageMask = dstStage;
  b.dstAccessMask = dstAccess;
  b.oldLayout = oldLayout;
  b.newLayout = newLayout;
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {aspect, 0, VK_REMAINING_MIP_LEVELS, 0, VK_REMAINING_ARRAY_LAYERS};
  auto dep = detail::vkStruct<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dep);
}

void memoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                   VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess) {
  auto b = detail::vkStruct<VkMemoryBarrier2>(VK_STRUCTURE_TYPE_MEMORY_BARRIER_2);
  b.srcStageMask = srcStage;
  b.srcAccessMask = srcAccess;
  b.dstStageMask = dstStage;
  b.dstAccessMask = dstAccess;
  auto dep = detail::vkStruct<VkDependencyInfo>(VK_STRUCTURE_TYPE_DEPENDENCY_INFO);
  dep.memoryBarrierCount = 1;
  dep.pMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dep);
}

void uploadBuffer(Context& ctx, const Buffer& dst, VkDeviceSize dstOffset,
                  std::span<const std::byte> data) {
  if (data.empty()) return;
  if (dstOffset + data.size() > dst.size())
    throw std::out_of_range("uploadBuffer: " + std::to_string(data.size()) + " bytes at offset " +
                            std::to_string(dstOffset) + " exceed the buffer size " +
                            std::to_string(dst.size()));
  Buffer staging(ctx, data.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUsage::Upload,
                 "engine.staging.upload");
  std::memcpy(staging.mapped(), data.data(), data.size());
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    memoryBarrier(cmd, kAll, VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
                  VK_ACCESS_2_TRANSFER_WRITE_BIT);
    const VkBufferCopy region{0, dstOffset, data.size()};
    vkCmdCopyBuffer(cmd, staging.handle(), dst.handle(), 1, &region);
    memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, kAll,
                  kAllAccess);
  });
}

std::vector<std::byte> readbackBuffer(Context& ctx, const Buffer& src, VkDeviceSize srcOffset,
                                      VkDeviceSize size) {
  if (srcOffset + size > src.size())
    throw std::out_of_range("readbackBuffer: range exceeds the buffer size");
  std::vector<std::byte> out(size);
  if (size == 0) return out;
  Buffer staging(ctx, size, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::Readback,
                 "engine.staging.readback");
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    memoryBarrier(cmd, kAll, VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
                  VK_ACCESS_2_TRANSFER_READ_BIT);
    const VkBufferCopy region{srcOffset, 0, size};
    vkCmdCopyBuffer(cmd, src.handle(), staging.handle(), 1, &region);
    memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                  VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
  });
  std::memcpy(out.data(), staging.mapped(), size);
  return out;
}

void uploadImage(Context& ctx, const Image& dst, std::span<const std::byte> texels,
                 VkImageLayout finalLayout) {
  const VkDeviceSize texel = bytesPerTexel(dst.format());
  const VkDeviceSize expected =
      texel * dst.extent().width * dst.extent().height * VkDeviceSize(dst.layers());
  if (texel == 0 || texels.size() != expected)
    throw std::invalid_argument("uploadImage: got " + std::to_string(texels.size()) +
                                " bytes, the image needs " + std::to_string(expected));
  Buffer staging(ctx, texels.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUsage::Upload,
                 "engine.staging.image_upload");
  std::memcpy(staging.mapped(), texels.data(), texels.size());
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    imageBarrier(cmd, dst.handle(), dst.aspect(), kAll, VK_ACCESS_2_MEMORY_WRITE_BIT,
                 VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                 VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    VkBufferImageCopy region{};
    region.imageSubresource = {dst.aspect() & ~VkImageAspectFlags(VK_IMAGE_ASPECT_STENCIL_BIT), 0,
                               0, dst.layers()};
    region.imageExtent = {dst.extent().width, dst.extent().height, 1};
    vkCmdCopyBufferToImage(cmd, staging.handle(), dst.handle(),
                           VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    imageBarrier(cmd, dst.handle(), dst.aspect(), VK_PIPELINE_STAGE_2_COPY_BIT,
                 VK_ACCESS_2_TRANSFER_WRITE_BIT, kAll, kAllAccess,
                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, finalLayout);
  });
}

std::vector<std::byte> readbackImage(Context& ctx, VkImage image, VkFormat format,
                                     VkExtent2D extent, VkImageLayout layout, uint32_t layer) {
  const VkDeviceSize texel = bytesPerTexel(format);
  if (texel == 0) throw std::invalid_argument("readbackImage: unsupported format");
  const VkDeviceSize size = texel * extent.width * extent.height;
  Buffer staging(ctx, size, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::Readback,
                 "engine.staging.image_readback");
  const VkImageAspectFlags aspect =
      aspectOf(format) & ~VkImageAspectFlags(VK_IMAGE_ASPECT_STENCIL_BIT);
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    const VkImageLayout copyLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    imageBarrier(cmd, image, aspectOf(format), kAll, VK_ACCESS_2_MEMORY_WRITE_BIT,
                 VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT, layout, copyLayout);
    VkBufferImageCopy region{};
    region.imageSubresource = {aspect, 0, layer, 1};
    region.imageExtent = {extent.width, extent.height, 1};
    vkCmdCopyImageToBuffer(cmd, image, copyLayout, staging.handle(), 1, &region);
    imageBarrier(cmd, image, aspectOf(format), VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE, kAll,
                 kAllAccess, copyLayout, layout);
    memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                  VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
  });
  std::vector<std::byte> out(size);
  std::memcpy(out.data(), staging.mapped(), size);
  return out;
}

std::vector<std::byte> readbackImage(Context& ctx, const Image& src, VkImageLayout layout,
                                     uint32_t layer) {
  return readbackImage(ctx, src.handle(), src.format(), src.extent(), layout, layer);
}

}  // namespace engine
