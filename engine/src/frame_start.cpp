#include "frame_start.hpp"

namespace engine::detail {

Frame startFrame(VkCommandBuffer cmd, uint32_t slot, uint64_t number, const FrameImages& images,
                 VkPipelineStageFlags2 colorSrcStage, VkAccessFlags2 colorSrcAccess) {
  imageBarrier(cmd, images.colorImage, VK_IMAGE_ASPECT_COLOR_BIT, colorSrcStage, colorSrcAccess,
               VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
               VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
               VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
  const VkPipelineStageFlags2 depthStages =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  imageBarrier(cmd, images.depth->handle(), images.depth->aspect(), depthStages,
               VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, depthStages,
               VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
                   VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
               VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
  Frame f;
  f.cmd = cmd;
  f.slot = slot;
  f.number = number;
  f.colorImage = images.colorImage;
  f.colorView = images.colorView;
  f.colorFormat = images.colorFormat;
  f.depthImage = images.depth->handle();
  f.depthView = images.depth->view();
  f.depthFormat = images.depthFormat;
  f.extent = images.extent;
  return f;
}

}  // namespace engine::detail
