// The module's shared Vulkan helpers that are more than a few lines (see vk_util.hpp).
#include "vk_util.hpp"

#include <iterator>

namespace csm::vk {

VkResult createDepthPipeline(VkDevice device, VkPipelineCache cache, const DepthPipelineDesc& desc,
                             VkPipeline* out) {
  const VertexLayout& layout = desc.vertexLayout;
  VkVertexInputBindingDescription binding{0, layout.stride, VK_VERTEX_INPUT_RATE_VERTEX};
  VkVertexInputAttributeDescription attr{0, 0, layout.positionFormat, layout.positionOffset};
  auto vin = vkInit<VkPipelineVertexInputStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO);
  vin.vertexBindingDescriptionCount = desc.restore ? 0 : 1;
  vin.pVertexBindingDescriptions = desc.restore ? nullptr : &binding;
  vin.vertexAttributeDescriptionCount = desc.restore ? 0 : 1;
  vin.pVertexAttributeDescriptions = desc.restore ? nullptr : &attr;
  auto ia = vkInit<VkPipelineInputAssemblyStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO);
  ia.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  auto vp = vkInit<VkPipelineViewportStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO);
  vp.viewportCount = 1;
  vp.scissorCount = 1;
  auto rs = vkInit<VkPipelineRasterizationStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO);
  rs.pNext = desc.rasterizationNext;
  rs.depthClampEnable = desc.depthClamp ? VK_TRUE : VK_FALSE;
  rs.polygonMode = VK_POLYGON_MODE_FILL;
  rs.depthBiasEnable = desc.restore ? VK_FALSE : VK_TRUE;
  rs.lineWidth = 1.0f;
  auto ms = vkInit<VkPipelineMultisampleStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO);
  ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  auto ds = vkInit<VkPipelineDepthStencilStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO);
  ds.depthTestEnable = VK_TRUE;
  ds.depthWriteEnable = VK_TRUE;
  ds.depthCompareOp = desc.restore ? VK_COMPARE_OP_ALWAYS : VK_COMPARE_OP_LESS_OR_EQUAL;
  auto cb = vkInit<VkPipelineColorBlendStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO);
  const VkDynamicState dyn[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR,
                                VK_DYNAMIC_STATE_DEPTH_BIAS, VK_DYNAMIC_STATE_CULL_MODE,
                                VK_DYNAMIC_STATE_FRONT_FACE};
  auto dy = vkInit<VkPipelineDynamicStateCreateInfo>(
      VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO);
  dy.dynamicStateCount = static_cast<std::uint32_t>(std::size(dyn));
  dy.pDynamicStates = dyn;
  auto rendering =
      vkInit<VkPipelineRenderingCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO);
  rendering.depthAttachmentFormat = desc.depthFormat;
  auto ci = vkInit<VkGraphicsPipelineCreateInfo>(VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO,
                                                 &rendering);
  ci.stageCount = desc.stageCount;
  ci.pStages = desc.stages;
  ci.pVertexInputState = &vin;
  ci.pInputAssemblyState = &ia;
  ci.pViewportState = &vp;
  ci.pRasterizationState = &rs;
  ci.pMultisampleState = &ms;
  ci.pDepthStencilState = &ds;
  ci.pColorBlendState = &cb;
  ci.pDynamicState = &dy;
  ci.layout = desc.layout;
  const VkResult r = vkCreateGraphicsPipelines(device, cache, 1, &ci, nullptr, out);
  if (r != VK_SUCCESS) *out = VK_NULL_HANDLE;
  return r;
}

}  // namespace csm::vk
