// GPU timestamps: per-slot query pools give finite, non-negative milliseconds per scope.
#include <cmath>

#include "engine_gpu_test.hpp"

namespace {

using engine_test::GpuTest;

TEST_F(GpuTest, TimestampScopesGiveFiniteNonNegativeMs) {
  engine::HeadlessTarget target(ctx(), {{64, 64}, VK_FORMAT_D32_SFLOAT});
  engine::GpuTimer timer(ctx(), 4);
  if (!timer.supported()) GTEST_SKIP() << "the queue has no timestamps";
  uint32_t lastSlot = 0;
  for (int i = 0; i < 4; ++i) {
    std::optional<engine::Frame> frame = target.beginFrame();
    ASSERT_TRUE(frame);
    timer.beginFrame(frame->cmd, frame->slot);
    timer.begin(frame->cmd, "clear");
    engine::beginRendering(*frame, VkClearColorValue{{0, 0, 0, 1}});
    vkCmdEndRendering(frame->cmd);
    timer.end(frame->cmd, "clear");
    timer.begin(frame->cmd, "empty");
    timer.end(frame->cmd, "empty");
    lastSlot = frame->slot;
    target.endFrame();
    if (i >= 2) {  // slot reuse read the results of frame i - 2
      ASSERT_EQ(timer.results().size(), 2u);
    }
  }
  target.waitIdle();
  timer.collect(lastSlot);
  ASSERT_EQ(timer.results().size(), 2u);
  for (const auto& [name, ms] : timer.results()) {
    EXPECT_TRUE(std::isfinite(ms)) << name;
    // End after begin (a swapped pair of queries gives a negative span); no upper bound: how
    // long the GPU takes decides no test.
    EXPECT_GE(ms, 0.0) << name;
  }
  EXPECT_THROW(timer.end(VK_NULL_HANDLE, "never begun"), std::logic_error);
}

}  // namespace
