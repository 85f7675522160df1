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

void Builder::requireFeatures(const Context& ctx, const std::string& name) const {
  const DeviceFeatures& features = ctx.features();
  auto need = [&](bool wanted, bool enabled, const char* feature) {
    if (wanted && !enabled)
      throw std::invalid_argument("pipeline " + name + " needs the " + feature +
                                  " feature, which the device does not enable");
  };
  need(depthClamp_, features.depthClamp, "depthClamp");
  need(depthBias_ && !dynamicDepthBias_ && biasClamp_ != 0.0f, features.depthBiasClamp,
       "depthBiasClamp");
  need(polygonMode_ != VK_POLYGON_MODE_FILL, features.fillModeNonSolid, "fillModeNonSolid");
  need(viewMask_ != 0, features.multiview, "multiview");
  bool hasVertex = false;
  for (const Stage& s : stages_) hasVertex |= s.stage == VK_SHADER_STAGE_VERTEX_BIT;
  if (!hasVertex) throw std::invalid_argument("pipeline " + name + " has no vertex shader");
}

DeviceHandle<VkPipelineLayout> Builder::createLayout(VkDevice device,
                                                     const std::string& name) const {
  auto layoutInfo =
      detail::vkStruct<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  layoutInfo.setLayoutCount = static_cast<uint32_t>(setLayouts_.size());
  layoutInfo.pSetLayouts = setLayouts_.data();
  layoutInfo.pushConstantRangeCount = static_cast<uint32_t>(pushRanges_.size());
  layoutInfo.pPushConstantRanges = pushRanges_.data();
  VkPipelineLayout rawLayout = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreatePipelineLayout(device, &layoutInfo, nullptr, &rawLayout));
  DeviceHandle<VkPipelineLayout> layout(device, rawLayout, vkDestroyPipelineLayout);
  setDebugName(device, rawLayout, name + ".layout");
  return layout;
}

// Specialisation data per stage (each stage sees the constants given for it).
struct Builder::StageSpec {
  std::vector<VkSpecializationMapEntry> entries;
  std::vector<uint32_t> data;
  VkSpecializationInfo info{};
};

// `specs` (one per stage) holds what the returned infos point to.
std::vector<VkPipelineShaderStageCreateInfo> Builder::stageInfos(
    std::vector<StageSpec>& specs) const {
  specs.resize(stages_.size());
  std::vector<VkPipelineShaderStageCreateInfo> infos;
  for (size_t i = 0; i < stages_.size(); ++i) {
    StageSpec& ss = specs[i];
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
    infos.push_back(si);
  }
  return infos;
}

// Filled in place (blend and dynamic point into the vectors beside them): not copied or moved.
struct Builder::FixedState {
  VkPipelineVertexInputStateCreateInfo vertexInput{};
  VkPipelineInputAssemblyStateCreateInfo inputAssembly{};
  VkPipelineViewportStateCreateInfo viewport{};
  VkPipelineRasterizationStateCreateInfo raster{};
  VkPipelineMultisampleStateCreateInfo multisample{};
  VkPipelineDepthStencilStateCreateInfo depth{};
  std::vector<VkPipelineColorBlendAttachmentState> blends;
  VkPipelineColorBlendStateCreateInfo blend{};
  std::vector<VkDynamicState> dynamicStates;
  VkPipelineDynamicStateCreateInfo dynamic{};
  VkPipelineRenderingCreateInfo rendering{};
};

void Builder::fillFixedState(FixedState& st) const {
  st.vertexInput = detail::vkStruct<VkPipelineVertexInputStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO);
  st.vertexInput.vertexBindingDescriptionCount = static_cast<uint32_t>(bindings_.size());
  st.vertexInput.pVertexBindingDescriptions = bindings_.data();
  st.vertexInput.vertexAttributeDescriptionCount = static_cast<uint32_t>(attributes_.size());
  st.vertexInput.pVertexAttributeDescriptions = attributes_.data();

  st.inputAssembly = detail::vkStruct<VkPipelineInputAssemblyStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO);
  st.inputAssembly.topology = topology_;

  st.viewport = detail::vkStruct<VkPipelineViewportStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO);
  st.viewport.viewportCount = 1;
  st.viewport.scissorCount = 1;

  st.raster = detail::vkStruct<VkPipelineRasterizationStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO);
  st.raster.depthClampEnable = depthClamp_;
  st.raster.polygonMode = polygonMode_;
  st.raster.cullMode = cull_;
  st.raster.frontFace = front_;
  st.raster.depthBiasEnable = depthBias_;
  st.raster.depthBiasConstantFactor = biasConstant_;
  st.raster.depthBiasSlopeFactor = biasSlope_;
  st.raster.depthBiasClamp = biasClamp_;
  st.raster.lineWidth = 1.0f;

  st.multisample = detail::vkStruct<VkPipelineMultisampleStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO);
  st.multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;

  const bool hasDepth = depthFormat_ != VK_FORMAT_UNDEFINED;
  st.depth = detail::vkStruct<VkPipelineDepthStencilStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO);
  st.depth.depthTestEnable = hasDepth && depthTest_;
  st.depth.depthWriteEnable = hasDepth && depthWrite_;
  st.depth.depthCompareOp = depthCompare_;
  st.depth.minDepthBounds = 0.0f;
  st.depth.maxDepthBounds = 1.0f;

  st.blends.resize(colorFormats_.size());
  for (auto& b : st.blends) {
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
  st.blend = detail::vkStruct<VkPipelineColorBlendStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO);
  st.blend.attachmentCount = static_cast<uint32_t>(st.blends.size());
  st.blend.pAttachments = st.blends.data();

  st.dynamicStates = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  if (dynamicDepthBias_) st.dynamicStates.push_back(VK_DYNAMIC_STATE_DEPTH_BIAS);
  st.dynamic = detail::vkStruct<VkPipelineDynamicStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO);
  st.dynamic.dynamicStateCount = static_cast<uint32_t>(st.dynamicStates.size());
  st.dynamic.pDynamicStates = st.dynamicStates.data();

  st.rendering = detail::vkStruct<VkPipelineRenderingCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO);
  st.rendering.viewMask = viewMask_;
  st.rendering.colorAttachmentCount = static_cast<uint32_t>(colorFormats_.size());
  st.rendering.pColorAttachmentFormats = colorFormats_.data();
  st.rendering.depthAttachmentFormat = depthFormat_;
}

GraphicsPipeline Builder::build(const Context& ctx, std::string_view name) const {
  const std::string base(name);
  requireFeatures(ctx, base);
  VkDevice device = ctx.device();
  GraphicsPipeline result;
  result.layout = createLayout(device, base);

  std::vector<StageSpec> stageSpecs;
  const std::vector<VkPipelineShaderStageCreateInfo> stages = stageInfos(stageSpecs);
  FixedState st;
  fillFixedState(st);

  auto info = detail::vkStruct<VkGraphicsPipelineCreateInfo>(
      VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO, &st.rendering);
  info.stageCount = static_cast<uint32_t>(stages.size());
  info.pStages = stages.data();
  info.pVertexInputState = &st.vertexInput;
  info.pInputAssemblyState = &st.inputAssembly;
  info.pViewportState = &st.viewport;
  info.pRasterizationState = &st.raster;
  info.pMultisampleState = &st.multisample;
  info.pDepthStencilState = depthFormat_ != VK_FORMAT_UNDEFINED ? &st.depth : nullptr;
  info.pColorBlendState = colorFormats_.empty() ? nullptr : &st.blend;
  info.pDynamicState = &st.dynamic;
  info.layout = result.layout.get();
  VkPipeline pipeline = VK_NULL_HANDLE;
  ENGINE_VK_CHECK(vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline));
  result.pipeline = DeviceHandle<VkPipeline>(device, pipeline, vkDestroyPipeline);
  setDebugName(device, pipeline, base);
  return result;
}

}  // namespace engine
