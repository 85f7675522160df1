// Headless rendering: a known clear colour and two flat triangles with depth, read back and
// checked texel by texel; several frames through the 2-frame ring; PNG output.
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <glm/glm.hpp>

#include "engine_gpu_test.hpp"

// Generated SPIR-V arrays (they need <cstdint> first).
#include <csm_shaders/engine_tri.frag.spv.h>
#include <csm_shaders/engine_tri.vert.spv.h>

namespace {

using engine_test::GpuTest;

// Push constants of engine_tri.vert/frag.
struct TriPush {
  glm::vec4 color;
  glm::vec2 offset;
  float scale;
  float depth;
};
static_assert(sizeof(TriPush) == 32);

struct TriPipeline {
  engine::DeviceHandle<VkShaderModule> vs, fs;
  engine::GraphicsPipeline pipeline;
};

TriPipeline makeTriPipeline(engine::Context& ctx, const engine::RenderTarget& target) {
  TriPipeline p;
  p.vs = engine::createShaderModule(ctx.device(), engine_tri_vert_spv, "test.tri.vert");
  p.fs = engine::createShaderModule(ctx.device(), engine_tri_frag_spv, "test.tri.frag");
  p.pipeline =
      engine::GraphicsPipelineBuilder()
          .vertexShader(p.vs)
          .fragmentShader(p.fs)
          .colorFormat(target.colorFormat())
          .depthFormat(target.depthFormat())
          .depthTest(true, true, VK_COMPARE_OP_LESS)
          .pushConstants(VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, sizeof(TriPush))
          .build(ctx, "test.tri.pipeline");
  return p;
}

void drawTri(VkCommandBuffer cmd, const TriPipeline& p, const TriPush& push) {
  vkCmdPushConstants(cmd, p.pipeline.layout,
                     VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push),
                     &push);
  vkCmdDraw(cmd, 3, 1, 0, 0);
}

using Rgba = std::array<uint8_t, 4>;
constexpr Rgba kClear{51, 102, 153, 255};  // 0.2, 0.4, 0.6 are exact in UNORM8
constexpr Rgba kRed{255, 0, 0, 255};
constexpr Rgba kGreen{0, 255, 0, 255};

// One frame: clear, a near green triangle, then a far red one that the depth test hides where
// they overlap. Base triangle (NDC, y down): apex (0, -0.5), base y = 0.5 from x = -0.5 to 0.5.
void renderScene(engine::HeadlessTarget& target, const TriPipeline& p) {
  std::optional<engine::Frame> frame = target.beginFrame();
  ASSERT_TRUE(frame.has_value());
  {
    engine::ScopedLabel label(frame->cmd, "test pass");
    engine::beginRendering(*frame, VkClearColorValue{{0.2f, 0.4f, 0.6f, 1.0f}});
    vkCmdBindPipeline(frame->cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, p.pipeline.pipeline);
    drawTri(frame->cmd, p, {{0, 1, 0, 1}, {0.25f, 0.25f}, 0.5f, 0.25f});
    drawTri(frame->cmd, p, {{1, 0, 0, 1}, {0.0f, 0.0f}, 1.0f, 0.5f});
    vkCmdEndRendering(frame->cmd);
  }
  target.endFrame();
}

TEST_F(GpuTest, HeadlessClearAndTrianglesExactTexels) {
  engine::HeadlessTarget target(ctx(), {{64, 64}, VK_FORMAT_D32_SFLOAT});
  EXPECT_EQ(target.colorFormat(), VK_FORMAT_R8G8B8A8_UNORM);
  const TriPipeline p = makeTriPipeline(ctx(), target);
  renderScene(target, p);
  const engine::CpuImage image = target.readback();
  ASSERT_EQ(image.width, 64u);
  ASSERT_EQ(image.height, 64u);
  // Texel (x, y) covers NDC ((x + 0.5) / 32 - 1, (y + 0.5) / 32 - 1).
  EXPECT_EQ(image.at(0, 0), kClear);
  EXPECT_EQ(image.at(63, 63), kClear);
  EXPECT_EQ(image.at(32, 6), kClear);   // above the apex
  EXPECT_EQ(image.at(32, 60), kClear);  // below the base
  EXPECT_EQ(image.at(32, 20), kRed);    // just under the apex: y points down
  EXPECT_EQ(image.at(22, 44), kRed);    // red only
  EXPECT_EQ(image.at(40, 44), kGreen);  // both: the nearer green wins the depth test
  EXPECT_EQ(image.at(36, 30), kRed);    // red, left of the green apex (0.25, 0)

  // Depth: cleared to 1, then the depth of the nearest triangle.
  const std::vector<std::byte> depthBytes =
      engine::readbackImage(ctx(), target.depthImage(), VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
  auto depthAt = [&](uint32_t x, uint32_t y) {
    float d;
    std::memcpy(&d, depthBytes.data() + (size_t(y) * 64 + x) * 4, 4);
    return d;
  };
  EXPECT_EQ(depthAt(0, 0), 1.0f);
  EXPECT_EQ(depthAt(22, 44), 0.5f);
  EXPECT_EQ(depthAt(40, 44), 0.25f);

  // Coverage is symmetric about x = 0 for the red triangle's rows above the green one.
  for (uint32_t y = 8; y < 30; ++y)
    for (uint32_t x = 0; x < 32; ++x)
      EXPECT_EQ(image.at(x, y) == kRed, image.at(63 - x, y) == kRed) << x << "," << y;
}

TEST_F(GpuTest, HeadlessSeveralFramesAndPng) {
  engine::HeadlessTarget target(ctx(), {{48, 32}, VK_FORMAT_D32_SFLOAT});
  const TriPipeline p = makeTriPipeline(ctx(), target);
  for (int i = 0; i < 5; ++i) renderScene(target, p);  // both frame slots, reused
  const engine::CpuImage image = target.readback();
  EXPECT_EQ(image.at(0, 0), kClear);
  EXPECT_EQ(image.at(24, 12), kRed);
  const std::filesystem::path png =
      std::filesystem::path(::testing::TempDir()) / "engine_headless_test.png";
  target.savePng(png.string());
  EXPECT_GT(std::filesystem::file_size(png), 50u);
}

TEST_F(GpuTest, ReadbackBeforeAnyFrameThrows) {
  engine::HeadlessTarget target(ctx(), {{16, 16}, VK_FORMAT_D32_SFLOAT});
  EXPECT_THROW(target.readback(), std::logic_error);
}

TEST_F(GpuTest, PipelineBuilderRefusesMissingVertexShader) {
  EXPECT_THROW(engine::GraphicsPipelineBuilder().build(ctx(), "test.invalid"),
               std::invalid_argument);
}

}  // namespace
