#include "engine/pipeline.hpp"

#include <stdexcept>
#include <string>

#include "engine/context.hpp"
#include "engine/debug.hpp"
#include "engine/errors.hpp"
#include "vk_struct.hpp"

namespace engine {

DeviceHandle<VkShaderModule> createShaderModule(VkDevice device, std::span<const uint32_t> spirv,
                                                std::string_view name) {
  if (spirv.empty() || spirv[0] != 0x07230203u)
    throw std::invalid_argument("createShaderModule(" + std::string(name) + "): not SPIR-V");
  auto info =
      detail::vkStruct<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
  info.codeSize = spirv.size_bytes();
  info.pCode = spirv.data();
  VkShaderModule module = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreateShaderModule(device, &info, nullptr, &module));
  setDebugName(device, module, name);
  return {device, module, vkDestroyShaderModule};
}

DeviceHandle<VkDescriptorSetLayout> createDescriptorSetLayout(
    VkDevice device, std::span<const VkDescriptorSetLayoutBinding> bindings,
    std::string_view name) {
  auto info = detail::vkStruct<VkDescriptorSetLayoutCreateInfo>(
      VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
  info.bindingCount = static_cast<uint32_t>(bindings.size());
  info.pBindings = bindings.data();
  VkDescriptorSetLayout layout = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreateDescriptorSetLayout(device, &info, nullptr, &layout));
  setDebugName(device, layout, name);
  return {device, layout, vkDestroyDescriptorSetLayout};
}

using Builder = GraphicsPipelineBuilder;

Builder& Builder::vertexShader(VkShaderModule module, const char* entry) {
  stages_.push_back({VK_SHADER_STAGE_VERTEX_BIT, module, entry});
  return *this;
}
Builder& Builder::fragmentShader(VkShaderModule module, const char* entry) {
  stages_.push_back({VK_SHADER_STAGE_FRAGMENT_BIT, module, entry});
  return *this;
}
Builder& Builder::specialization(VkShaderStageFlags stages, uint32_t constantId, uint32_t value) {
  specs_.push_back({stages, constantId, value});
  return *this;
}
Builder& Builder::vertexInput(std::span<const VkVertexInputBindingDescription> bindings,
                              std::span<const VkVertexInputAttributeDescription> attributes) {
  bindings_.assign(bindings.begin(), bindings.end());
  attributes_.assign(attributes.begin(), attributes.end());
  return *this;
}
Builder& Builder::topology(VkPrimitiveTopology topology) {
  topology_ = topology;
  return *this;
}
Builder& Builder::colorFormats(std::span<const VkFormat> formats) {
  colorFormats_.assign(formats.begin(), formats.end());
  return *this;
}
Builder& Builder::colorFormat(VkFormat format) {
  colorFormats_.assign(1, format);
  return *this;
}
Builder& Builder::depthFormat(VkFormat format) {
  depthFormat_ = format;
  return *this;
}
Builder& Builder::depthTest(bool test, bool write, VkCompareOp compare) {
  depthTest_ = test;
  depthWrite_ = write;
  depthCompare_ = compare;
  return *this;
}
Builder& Builder::depthBias(float constantFactor, float slopeFactor, float clamp) {
  depthBias_ = true;
  biasConstant_ = constantFactor;
  biasSlope_ = slopeFactor;
  biasClamp_ = clamp;
  return *this;
}
Builder& Builder::dynamicDepthBias() {
  depthBias_ = true;
  dynamicDepthBias_ = true;
  return *this;
}
Builder& Builder::depthClamp(bool enable) {
  depthClamp_ = enable;
  return *this;
}
Builder& Builder::cullMode(VkCullModeFlags mode, VkFrontFace front) {
  cull_ = mode;
  front_ = front;
  return *this;
}
Builder& Builder::polygonMode(VkPolygonMode mode) {
  polygonMode_ = mode;
  return *this;
}
Builder& Builder::alphaBlend(bool enable) {
  blend_ = enable;
  return *this;
}
Builder& Builder::viewMask(uint32_t mask) {
  viewMask_ = mask;
  return *this;
}
Builder& Builder::pushConstants(VkShaderStageFlags stages, uint32_t size, uint32_t offset) {
  pushRanges_.push_back({stages, offset, size});
  return *this;
}
Builder& Builder::descriptorSetLayout(VkDescriptorSetLayout layout) {
  setLayouts_.push_back(layout);
  return *this;
}

GraphicsPipeline Builder::build(const Context& ctx, std::string_view name) const {
  const std::string base(name);
  const DeviceFeatures& features = ctx.features();
  auto need = [&](bool wanted, bool enabled, const char* feature) {
    if (wanted && !enabled)
      throw std::invalid_argument("pipeline " + base + " needs the " + feature +
                                  " feature, which the device does not enable");
  };
  need(depthClamp_, features.depthClamp, "depthClamp");
  need(depthBias_ && !dynamicDepthBias_ && biasClamp_ != 0.0f, features.depthBiasClamp,
       "depthBiasClamp");
  need(polygonMode_ != VK_POLYGON_MODE_FILL, features.fillModeNonSolid, "fillModeNonSolid");
  need(viewMask_ != 0, features.multiview, "multiview");
  bool hasVertex = false;
  for (const Stage& s : stages_) hasVertex |= s.stage == VK_SHADER_STAGE_VERTEX_BIT;
  if (!hasVertex) throw std::invalid_argument("pipeline " + base + " has no vertex shader");

  VkDevice device = ctx.device();
  auto layoutInfo =
      detail::vkStruct<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  layoutInfo.setLayoutCount = static_cast<uint32_t>(setLayouts_.size());
  layoutInfo.pSetLayouts = setLayouts_.data();
  layoutInfo.pushConstantRangeCount = static_cast<uint32_t>(pushRanges_.size());
  layoutInfo.pPushConstantRanges = pushRanges_.data();
  VkPipelineLayout rawLayout = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreatePipelineLayout(device, &layoutInfo, nullptr, &rawLayout));
  GraphicsPipeline result;
  result.layout = DeviceHandle<VkPipelineLayout>(device, rawLayout, vkDestroyPipelineLayout);
  setDebugName(device, rawLayout, base + ".layout");

  // Specialisation data per stage (each stage sees the constants given for it).
  struct StageSpec {
    std::vector<VkSpecializationMapEntry> entries;
    std::vector<uint32_t> data;
    VkSpecializationInfo info{};
  };
  std::vector<StageSpec> stageSpecs(stages_.size());
  std::vector<VkPipelineShaderStageCreateInfo> stageInfos;
  for (size_t i = 0; i < stages_.size(); ++i) {
    StageSpec& ss = stageSpecs[i];
    for (const Spec& sp : specs_)
      if (sp.stages & stages_[i].stage) {
        ss.entries.push_back(
            {sp.id, static_cast<uint32_t>(ss.data.size() * sizeof(uint32_t)), sizeof(uint32_t)});
        ss.data.push_back(sp.value);
      }
    ss.info.mapEntryCount = static_cast<uint32_t>(ss.entries.size());
    ss.info.pMapEntries = ss.entries.data();
    ss.info.dataSize = ss.data.size() * sizeof(uint32_t);
    ss.info.pData = ss.data.data();
    auto si = detail::vkStruct<VkPipelineShaderStageCreateInfo>(
        VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
    si.stage = stages_[i].stage;
    si.module = stages_[i].module;
    si.pName = stages_[i].entry;
    si.pSpecializationInfo = ss.entries.empty() ? nullptr : &ss.info;
    stageInfos.push_back(si);
  }

  auto vertexInput = detail::vkStruct<VkPipelineVertexInputStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO);
  vertexInput.vertexBindingDescriptionCount = static_cast<uint32_t>(bindings_.size());
  vertexInput.pVertexBindingDescriptions = bindings_.data();
  vertexInput.vertexAttributeDescriptionCount = static_cast<uint32_t>(attributes_.size());
  vertexInput.pVertexAttributeDescriptions = attributes_.data();

  auto inputAssembly = detail::vkStruct<VkPipelineInputAssemblyStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO);
  inputAssembly.topology = topology_;

  auto viewport = detail::vkStruct<VkPipelineViewportStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO);
  viewport.viewportCount = 1;
  viewport.scissorCount = 1;

  auto raster = detail::vkStruct<VkPipelineRasterizationStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO);
  raster.depthClampEnable = depthClamp_;
  raster.polygonMode = polygonMode_;
  raster.cullMode = cull_;
  raster.frontFace = front_;
  raster.depthBiasEnable = depthBias_;
  raster.depthBiasConstantFactor = biasConstant_;
  raster.depthBiasSlopeFactor = biasSlope_;
  raster.depthBiasClamp = biasClamp_;
  raster.lineWidth = 1.0f;

  auto multisample = detail::vkStruct<VkPipelineMultisampleStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO);
  multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;

  const bool hasDepth = depthFormat_ != VK_FORMAT_UNDEFINED;
  auto depth = detail::vkStruct<VkPipelineDepthStencilStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO);
  depth.depthTestEnable = hasDepth && depthTest_;
  depth.depthWriteEnable = hasDepth && depthWrite_;
  depth.depthCompareOp = depthCompare_;
  depth.minDepthBounds = 0.0f;
  depth.maxDepthBounds = 1.0f;

  std::vector<VkPipelineColorBlendAttachmentState> blends(colorFormats_.size());
  for (auto& b : blends) {
    b.blendEnable = blend_;
    b.srcColorBlendFactor = VK_BLEND_FACTOR_SRC_ALPHA;
    b.dstColorBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
    b.colorBlendOp = VK_BLEND_OP_ADD;
    b.srcAlphaBlendFactor = VK_BLEND_FACTOR_ONE;
    b.dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
    b.alphaBlendOp = VK_BLEND_OP_ADD;
    b.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                       VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  }
  auto blend = detail::vkStruct<VkPipelineColorBlendStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO);
  blend.attachmentCount = static_cast<uint32_t>(blends.size());
  blend.pAttachments = blends.data();

  std::vector<VkDynamicState> dynamicStates = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  if (dynamicDepthBias_) dynamicStates.push_back(VK_DYNAMIC_STATE_DEPTH_BIAS);
  auto dynamic = detail::vkStruct<VkPipelineDynamicStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO);
  dynamic.dynamicStateCount = static_cast<uint32_t>(dynamicStates.size());
  dynamic.pDynamicStates = dynamicStates.data();

  auto rendering = detail::vkStruct<VkPipelineRenderingCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO);
  rendering.viewMask = viewMask_;
  rendering.colorAttachmentCount = static_cast<uint32_t>(colorFormats_.size());
  rendering.pColorAttachmentFormats = colorFormats_.data();
  rendering.depthAttachmentFormat = depthFormat_;

  auto info = detail::vkStruct<VkGraphicsPipelineCreateInfo>(
      VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO, &rendering);
  info.stageCount = static_cast<uint32_t>(stageInfos.size());
  info.pStages = stageInfos.data();
  info.pVertexInputState = &vertexInput;
  info.pInputAssemblyState = &inputAssembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pDepthStencilState = hasDepth ? &depth : nullptr;
  info.pColorBlendState = colorFormats_.empty() ? nullptr : &blend;
  info.pDynamicState = &dynamic;
  info.layout = rawLayout;
  VkPipeline pipeline = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline));
  result.pipeline = DeviceHandle<VkPipeline>(device, pipeline, vkDestroyPipeline);
  setDebugName(device, pipeline, base);
  return result;
}

}  // namespace engine
