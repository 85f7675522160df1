// Device memory: a sub-allocator over a few large VkDeviceMemory blocks per memory type, RAII
// buffers and images on top of it, and blocking upload / readback helpers (staging + copy with
// synchronization2 barriers).
#pragma once

#include <vulkan/vulkan.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string_view>
#include <vector>

namespace engine {

class Context;

/// Where a resource lives and how the CPU sees it.
enum class MemoryUsage {
  DeviceLocal,  ///< GPU-only (meshes, images, render targets)
  Upload,       ///< host-visible, coherent, persistently mapped (uniforms, staging)
  Readback,     ///< host-visible, coherent, preferably cached, persistently mapped
};

/// A sub-range of one VkDeviceMemory block.
struct Allocation {
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize offset = 0;
  VkDeviceSize size = 0;   ///< bytes reserved (may exceed the request after alignment)
  void* mapped = nullptr;  ///< host pointer to `offset` when host-visible, else null
  uint32_t memoryType = 0;
  uint32_t block = 0;      ///< index of the block inside its memory type (internal)
  bool dedicated = false;  ///< a VkDeviceMemory of its own (larger than half a block)
  explicit operator bool() const { return memory != VK_NULL_HANDLE; }
};

/// Sub-allocates a few large VkDeviceMemory blocks (64 MiB by default) per memory type,
/// first-fit with a coalescing free list. Optimal-tiling images are padded to
/// bufferImageGranularity on both ends so they never share a page with a linear resource.
/// Thread-safe. Requests larger than half a block (the block: blockSize, or an eighth of the
/// heap when that is smaller, at least 1 MiB) get a dedicated VkDeviceMemory.
class Allocator {
 public:
  /// Reads the memory properties of the context's device; `blockSize` is the default block size.
  Allocator(VkPhysicalDevice physicalDevice, VkDevice device,
            VkDeviceSize blockSize = VkDeviceSize(64) << 20);
  /// Frees every block (all allocations must have been freed).
  ~Allocator();
  Allocator(const Allocator&) = delete;
  Allocator& operator=(const Allocator&) = delete;

  /// Allocates memory for `req` with `usage`; `linear` is false for optimal-tiling images.
  Allocation allocate(const VkMemoryRequirements& req, MemoryUsage usage, bool linear);
  /// Returns an allocation to its block (a null allocation is ignored).
  void free(const Allocation& allocation) noexcept;

  /// Number of VkDeviceMemory objects alive (blocks + dedicated), for tests and statistics.
  uint32_t deviceMemoryCount() const;
  /// Bytes handed out and not yet freed.
  VkDeviceSize bytesInUse() const;

 private:
  struct Range {
    VkDeviceSize offset, size;
  };
  struct Block {
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize size = 0;
    void* mapped = nullptr;
    std::vector<Range> freeRanges;  // sorted by offset, never adjacent
  };
  uint32_t findMemoryType(uint32_t typeBits, MemoryUsage usage) const;
  VkDeviceMemory allocateMemory(uint32_t type, VkDeviceSize size, void** mapped);

  VkDevice device_;
  VkPhysicalDeviceMemoryProperties props_{};
  VkDeviceSize blockSize_;
  VkDeviceSize granularity_;
  mutable std::mutex mutex_;
  std::vector<std::vector<Block>> blocks_;  // per memory type
  uint32_t dedicatedCount_ = 0;
  VkDeviceSize bytesInUse_ = 0;
};

/// A VkBuffer with its memory. Move-only; destroys both on destruction.
class Buffer {
 public:
  Buffer() = default;
  /// Creates a buffer of `size` bytes for `usage`, in memory chosen by `memory`, named `name`.
  Buffer(Context& ctx, VkDeviceSize size, VkBufferUsageFlags usage, MemoryUsage memory,
         std::string_view name);
  ~Buffer();
  Buffer(Buffer&& other) noexcept;
  Buffer& operator=(Buffer&& other) noexcept;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  VkBuffer handle() const { return buffer_; }
  VkDeviceSize size() const { return size_; }
  /// Persistent host pointer (Upload / Readback memory), else null.
  void* mapped() const { return allocation_.mapped; }
  explicit operator bool() const { return buffer_ != VK_NULL_HANDLE; }
  /// Destroys the buffer now.
  void reset() noexcept;

 private:
  Context* ctx_ = nullptr;
  VkBuffer buffer_ = VK_NULL_HANDLE;
  VkDeviceSize size_ = 0;
  Allocation allocation_{};
};

/// How to create an Image (2D or 2D array, optimal tiling, device-local).
struct ImageDesc {
  VkFormat format = VK_FORMAT_R8G8B8A8_UNORM;
  VkExtent2D extent{1, 1};
  uint32_t layers = 1;
  uint32_t mipLevels = 1;
  VkImageUsageFlags usage = VK_IMAGE_USAGE_SAMPLED_BIT;
  /// View type of the default view; 2D_ARRAY gives an array view even for one layer.
  VkImageViewType viewType = VK_IMAGE_VIEW_TYPE_2D;
};

/// A device-local VkImage with its memory and a default view over all layers and mips.
/// Move-only. The image is created in VK_IMAGE_LAYOUT_UNDEFINED; layouts are the user's job.
class Image {
 public:
  Image() = default;
  /// Creates the image and its default view, both named after `name`.
  Image(Context& ctx, const ImageDesc& desc, std::string_view name);
  ~Image();
  Image(Image&& other) noexcept;
  Image& operator=(Image&& other) noexcept;
  Image(const Image&) = delete;
  Image& operator=(const Image&) = delete;

  VkImage handle() const { return image_; }
  VkImageView view() const { return view_; }
  VkFormat format() const { return desc_.format; }
  VkExtent2D extent() const { return desc_.extent; }
  uint32_t layers() const { return desc_.layers; }
  const ImageDesc& desc() const { return desc_; }
  /// The aspect of the format (DEPTH for depth formats, COLOR otherwise).
  VkImageAspectFlags aspect() const;
  explicit operator bool() const { return image_ != VK_NULL_HANDLE; }
  /// Creates an additional view of `layerCount` layers starting at `baseLayer` (the caller
  /// destroys it with vkDestroyImageView), named `name`.
  VkImageView createView(VkImageViewType type, uint32_t baseLayer, uint32_t layerCount,
                         std::string_view name) const;
  /// Destroys view, image and memory now.
  void reset() noexcept;

 private:
  Context* ctx_ = nullptr;
  VkImage image_ = VK_NULL_HANDLE;
  VkImageView view_ = VK_NULL_HANDLE;
  ImageDesc desc_{};
  Allocation allocation_{};
};

/// Whether `format` is a depth (or depth/stencil) format.
bool isDepthFormat(VkFormat format) noexcept;
/// The aspect flags of `format`.
VkImageAspectFlags aspectOf(VkFormat format) noexcept;
/// Bytes per texel of the uncompressed colour/depth formats the engine uses (0 if unknown).
uint32_t bytesPerTexel(VkFormat format) noexcept;

/// Records one synchronization2 image barrier over all mips and layers of `image`.
void imageBarrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect,
                  VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                  VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess, VkImageLayout oldLayout,
                  VkImageLayout newLayout);
/// Records one synchronization2 global memory barrier.
void memoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                   VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess);

/// Copies `data` into `dst` at `dstOffset` through a staging buffer and waits for completion;
/// afterwards the bytes are visible to every later stage (vertex input, shaders, transfers).
void uploadBuffer(Context& ctx, const Buffer& dst, VkDeviceSize dstOffset,
                  std::span<const std::byte> data);
/// Reads `size` bytes of `src` from `srcOffset` back to the CPU (blocking).
std::vector<std::byte> readbackBuffer(Context& ctx, const Buffer& src, VkDeviceSize srcOffset,
                                      VkDeviceSize size);
/// Uploads tightly packed texels of mip 0 / all layers into `dst` (layer after layer) and leaves
/// it in `finalLayout`, visible to all later commands. The image's previous content is discarded.
void uploadImage(Context& ctx, const Image& dst, std::span<const std::byte> texels,
                 VkImageLayout finalLayout);
/// Reads mip 0 of `layer` of `src`, currently in `layout` (left unchanged), back to the CPU as
/// tightly packed texels (blocking).
std::vector<std::byte> readbackImage(Context& ctx, const Image& src, VkImageLayout layout,
                                     uint32_t layer = 0);
/// Reads mip 0 / layer 0 of a raw image (aspect COLOR or DEPTH from `format`) in `layout`.
std::vector<std::byte> readbackImage(Context& ctx, VkImage image, VkFormat format,
                                     VkExtent2D extent, VkImageLayout layout, uint32_t layer = 0);

/// Views any trivially copyable span as bytes (for uploadBuffer / uploadImage).
template <class T>
std::span<const std::byte> asBytes(std::span<const T> values) {
  return std::as_bytes(values);
}
template <class T>
std::span<const std::byte> asBytes(const std::vector<T>& values) {
  return std::as_bytes(std::span<const T>(values));
}

}  // namespace engine
