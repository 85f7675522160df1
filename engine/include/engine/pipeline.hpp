// Shader modules from embedded SPIR-V, RAII device handles, descriptor set layouts and a small
// graphics pipeline builder for dynamic rendering.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace engine {

class Context;

/// Owns one device-level handle destroyed with vkDestroy<T>(device, handle, nullptr).
/// Move-only; `DeviceHandle<VkPipeline> p(device, handle, vkDestroyPipeline);`.
template <class T>
class DeviceHandle {
 public:
  using Destroy = void (*)(VkDevice, T, const VkAllocationCallbacks*);
  DeviceHandle() = default;
  /// Takes ownership of `handle`.
  DeviceHandle(VkDevice device, T handle, Destroy destroy)
      : device_(device), handle_(handle), destroy_(destroy) {}
  ~DeviceHandle() { reset(); }
  DeviceHandle(DeviceHandle&& o) noexcept
      : device_(o.device_), handle_(std::exchange(o.handle_, T{})), destroy_(o.destroy_) {}
  DeviceHandle& operator=(DeviceHandle&& o) noexcept {
    if (this != &o) {
      reset();
      device_ = o.device_;
      handle_ = std::exchange(o.handle_, T{});
      destroy_ = o.destroy_;
    }
    return *this;
  }
  DeviceHandle(const DeviceHandle&) = delete;
  DeviceHandle& operator=(const DeviceHandle&) = delete;

  /// The raw handle (still owned).
  T get() const { return handle_; }
  operator T() const { return handle_; }  // NOLINT: implicit use in Vulkan calls is the point
  explicit operator bool() const { return handle_ != T{}; }
  /// Destroys the handle now.
  void reset() noexcept {
    if (handle_ != T{} && destroy_) destroy_(device_, handle_, nullptr);
    handle_ = T{};
  }

 private:
  VkDevice device_ = VK_NULL_HANDLE;
  T handle_{};
  Destroy destroy_ = nullptr;
};

/// Creates a shader module from SPIR-V words (e.g. the embedded engine_tri_vert_spv array).
DeviceHandle<VkShaderModule> createShaderModule(VkDevice device, std::span<const uint32_t> spirv,
                                                std::string_view name);

/// Creates a descriptor set layout from `bindings`.
DeviceHandle<VkDescriptorSetLayout> createDescriptorSetLayout(
    VkDevice device, std::span<const VkDescriptorSetLayoutBinding> bindings, std::string_view name);

/// A pipeline and the layout it was built with.
struct GraphicsPipeline {
  DeviceHandle<VkPipelineLayout> layout;
  DeviceHandle<VkPipeline> pipeline;
};

/// Builds graphics pipelines for dynamic rendering. Viewport and scissor are always dynamic.
/// Defaults: triangle list, no vertex input, fill, no culling, counter-clockwise front faces,
/// depth test LESS with write when a depth format is set, no blending, no depth bias.
class GraphicsPipelineBuilder {
 public:
  /// Vertex stage (required).
  GraphicsPipelineBuilder& vertexShader(VkShaderModule module, const char* entry = "main");
  /// Fragment stage (optional: depth-only pipelines have none).
  GraphicsPipelineBuilder& fragmentShader(VkShaderModule module, const char* entry = "main");
  /// A 32-bit specialisation constant for the given stage(s).
  GraphicsPipelineBuilder& specialization(VkShaderStageFlags stages, uint32_t constantId,
                                          uint32_t value);
  /// Vertex bindings and attributes.
  GraphicsPipelineBuilder& vertexInput(
      std::span<const VkVertexInputBindingDescription> bindings,
      std::span<const VkVertexInputAttributeDescription> attributes);
  GraphicsPipelineBuilder& topology(VkPrimitiveTopology topology);
  /// Formats of the colour attachments, in attachment order (none for depth-only).
  GraphicsPipelineBuilder& colorFormats(std::span<const VkFormat> formats);
  GraphicsPipelineBuilder& colorFormat(VkFormat format);
  /// Format of the depth attachment (VK_FORMAT_UNDEFINED: none).
  GraphicsPipelineBuilder& depthFormat(VkFormat format);
  /// Depth test and write; `compare` is the test.
  GraphicsPipelineBuilder& depthTest(bool test, bool write,
                                     VkCompareOp compare = VK_COMPARE_OP_LESS);
  /// Static depth bias (constant factor, slope factor, clamp; clamp != 0 needs depthBiasClamp).
  GraphicsPipelineBuilder& depthBias(float constantFactor, float slopeFactor, float clamp = 0.0f);
  /// Depth bias enabled with its values set per draw (vkCmdSetDepthBias).
  GraphicsPipelineBuilder& dynamicDepthBias();
  /// Depth clamp instead of near/far clipping (needs the depthClamp feature).
  GraphicsPipelineBuilder& depthClamp(bool enable);
  GraphicsPipelineBuilder& cullMode(VkCullModeFlags mode,
                                    VkFrontFace front = VK_FRONT_FACE_COUNTER_CLOCKWISE);
  /// Fill, line or point (non-fill needs fillModeNonSolid).
  GraphicsPipelineBuilder& polygonMode(VkPolygonMode mode);
  /// Standard alpha blending on every colour attachment.
  GraphicsPipelineBuilder& alphaBlend(bool enable);
  /// Multiview mask (needs the multiview feature; 0: off).
  GraphicsPipelineBuilder& viewMask(uint32_t mask);
  /// A push constant range.
  GraphicsPipelineBuilder& pushConstants(VkShaderStageFlags stages, uint32_t size,
                                         uint32_t offset = 0);
  /// Appends a descriptor set layout (set index = order of calls).
  GraphicsPipelineBuilder& descriptorSetLayout(VkDescriptorSetLayout layout);

  /// Creates the layout and the pipeline, named "<name>.layout" and "<name>". Throws
  /// std::invalid_argument when a requested feature is not enabled on `ctx`, or when there is
  /// no vertex shader.
  GraphicsPipeline build(const Context& ctx, std::string_view name) const;

 private:
  struct Stage {
    VkShaderStageFlagBits stage;
    VkShaderModule module;
    const char* entry;
  };
  struct Spec {
    VkShaderStageFlags stages;
    uint32_t id, value;
  };
  std::vector<Stage> stages_;
  std::vector<Spec> specs_;
  std::vector<VkVertexInputBindingDescription> bindings_;
  std::vector<VkVertexInputAttributeDescription> attributes_;
  VkPrimitiveTopology topology_ = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  std::vector<VkFormat> colorFormats_;
  VkFormat depthFormat_ = VK_FORMAT_UNDEFINED;
  bool depthTest_ = true, depthWrite_ = true;
  VkCompareOp depthCompare_ = VK_COMPARE_OP_LESS;
  bool depthBias_ = false, dynamicDepthBias_ = false;
  float biasConstant_ = 0, biasSlope_ = 0, biasClamp_ = 0;
  bool depthClamp_ = false;
  VkCullModeFlags cull_ = VK_CULL_MODE_NONE;
  VkFrontFace front_ = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  VkPolygonMode polygonMode_ = VK_POLYGON_MODE_FILL;
  bool blend_ = false;
  uint32_t viewMask_ = 0;
  std::vector<VkPushConstantRange> pushRanges_;
  std::vector<VkDescriptorSetLayout> setLayouts_;

  // build()'s steps (pipeline.cpp defines the two structs).
  struct StageSpec;   // one stage's specialisation constants
  struct FixedState;  // the fixed-function create infos, pointing into one another
  void requireFeatures(const Context& ctx, const std::string& name) const;
  DeviceHandle<VkPipelineLayout> createLayout(VkDevice device, const std::string& name) const;
  std::vector<VkPipelineShaderStageCreateInfo> stageInfos(std::vector<StageSpec>& specs) const;
  void fillFixedState(FixedState& state) const;
};

}  // namespace engine
