// Context creation, features, debug names and labels, validation message counting (including
// leak reports at device destruction) and the sub-allocator.
#include <set>

#include "engine_gpu_test.hpp"

namespace {

using engine_test::GpuTest;

TEST_F(GpuTest, ContextHasVulkan13DeviceAndQueue) {
  EXPECT_GE(ctx().properties().apiVersion, VK_API_VERSION_1_3);
  EXPECT_NE(ctx().device(), VK_NULL_HANDLE);
  EXPECT_NE(ctx().queue(), VK_NULL_HANDLE);
  EXPECT_TRUE(ctx().debugUtilsEnabled());
  // Lavapipe and every desktop GPU have these; the shadow renderer relies on depth clamp.
  EXPECT_TRUE(ctx().features().depthClamp);
  EXPECT_TRUE(ctx().features().timestamps);
  // Every object created by the engine gets a name; names and labels raise no messages.
  engine::Buffer buffer(ctx(), 1024, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                        engine::MemoryUsage::Upload, "test.named_buffer");
  engine::setDebugName(ctx().device(), buffer.handle(), "test.renamed_buffer");
  ctx().submitAndWait([](VkCommandBuffer cmd) { engine::ScopedLabel label(cmd, "test label"); });
  EXPECT_EQ(engine::validationMessageCount(), 0u);
}

TEST_F(GpuTest, ShutdownIsIdempotent) {
  ctx().shutdown();
  ctx().shutdown();
  EXPECT_EQ(ctx().device(), VK_NULL_HANDLE);
  EXPECT_EQ(engine::validationMessageCount(), 0u);
}

// A leaked object is reported by the validation layer inside vkDestroyDevice; the counter must
// see that report after shutdown(), or "zero messages" would not cover leaks.
TEST(EngineValidation, LeakAtDeviceDestructionIsCounted) {
  if (engine_test::validationForcedOff()) GTEST_SKIP() << "CSM_VALIDATION=0";
  engine::resetValidationCounts();
  engine::ContextDesc desc;
  desc.validation = true;
  std::unique_ptr<engine::Context> ctx;
  try {
    ctx = std::make_unique<engine::Context>(desc);
  } catch (const engine::NoDeviceError& e) {
    GTEST_SKIP() << e.what();
  }
  VkSamplerCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
  info.maxLod = 1.0f;
  VkSampler leaked = VK_NULL_HANDLE;
  ASSERT_EQ(vkCreateSampler(ctx->device(), &info, nullptr, &leaked), VK_SUCCESS);
  EXPECT_EQ(engine::validationMessageCount(), 0u);
  std::fprintf(stderr, "(the leak report below is expected)\n");
  ctx->shutdown();
  EXPECT_GE(engine::validationCounts().errors, 1u);
  engine::resetValidationCounts();
}

TEST(EngineValidation, EnvironmentOverridesTheFlag) {
  const char* old = std::getenv("CSM_VALIDATION");
  const std::string saved = old ? old : "";
  setenv("CSM_VALIDATION", "0", 1);
  EXPECT_FALSE(engine::resolveValidationSetting(true));
  setenv("CSM_VALIDATION", "1", 1);
  EXPECT_TRUE(engine::resolveValidationSetting(false));
  unsetenv("CSM_VALIDATION");
  EXPECT_TRUE(engine::resolveValidationSetting(true));
  EXPECT_FALSE(engine::resolveValidationSetting(false));
  if (old) setenv("CSM_VALIDATION", saved.c_str(), 1);
}

TEST_F(GpuTest, AllocatorAlignsPadsAndReuses) {
  engine::Allocator& alloc = ctx().allocator();
  const uint32_t blocksBefore = alloc.deviceMemoryCount();
  const VkDeviceSize granularity = ctx().properties().limits.bufferImageGranularity;
  VkMemoryRequirements req{};
  req.memoryTypeBits = ~0u;
  req.alignment = 256;
  req.size = 1000;
  const engine::Allocation a = alloc.allocate(req, engine::MemoryUsage::DeviceLocal, true);
  const engine::Allocation b = alloc.allocate(req, engine::MemoryUsage::DeviceLocal, false);
  const engine::Allocation c = alloc.allocate(req, engine::MemoryUsage::DeviceLocal, true);
  const uint32_t blocksAfter = alloc.deviceMemoryCount();
  for (const engine::Allocation* x : {&a, &b, &c}) EXPECT_EQ(x->offset % 256, 0u);
  // The optimal-tiling allocation starts and ends on granularity pages of its own.
  EXPECT_EQ(b.offset % granularity, 0u);
  EXPECT_EQ(b.size % granularity, 0u);
  // No linear allocation shares a granularity page with the image allocation.
  for (const engine::Allocation* x : {&a, &c}) {
    if (x->memory != b.memory) continue;
    const VkDeviceSize xFirst = x->offset / granularity;
    const VkDeviceSize xLast = (x->offset + x->size - 1) / granularity;
    const VkDeviceSize bFirst = b.offset / granularity;
    const VkDeviceSize bLast = (b.offset + b.size - 1) / granularity;
    EXPECT_TRUE(xLast < bFirst || bLast < xFirst);
  }
  // Disjoint ranges.
  EXPECT_TRUE(a.offset + a.size <= b.offset || b.offset + b.size <= a.offset ||
              a.memory != b.memory);
  EXPECT_TRUE(b.offset + b.size <= c.offset || c.offset + c.size <= b.offset ||
              b.memory != c.memory);
  const VkDeviceSize used = alloc.bytesInUse();
  alloc.free(b);
  alloc.free(a);
  alloc.free(c);
  EXPECT_EQ(alloc.bytesInUse(), used - a.size - b.size - c.size);
  // The freed ranges were merged: a large request reuses the block from its start.
  req.size = 16u << 20;
  const engine::Allocation big = alloc.allocate(req, engine::MemoryUsage::DeviceLocal, true);
  EXPECT_EQ(alloc.deviceMemoryCount(), blocksAfter);
  if (blocksBefore == 0) {
    EXPECT_EQ(big.offset, 0u);
    EXPECT_EQ(big.memory, a.memory);
  }
  alloc.free(big);
  // Host-visible allocations are persistently mapped.
  req.size = 64;
  const engine::Allocation m = alloc.allocate(req, engine::MemoryUsage::Upload, true);
  EXPECT_NE(m.mapped, nullptr);
  alloc.free(m);
}

}  // namespace

namespace {

// Synchronization validation is on: two copies into the same bytes without a barrier between
// them are a write-after-write hazard, which must be reported (and is then forgiven).
TEST(EngineValidation, SynchronizationValidationIsOn) {
  if (engine_test::validationForcedOff()) GTEST_SKIP() << "CSM_VALIDATION=0";
  engine::resetValidationCounts();
  engine::ContextDesc desc;
  desc.validation = true;
  std::unique_ptr<engine::Context> ctx;
  try {
    ctx = std::make_unique<engine::Context>(desc);
  } catch (const engine::NoDeviceError& e) {
    GTEST_SKIP() << e.what();
  }
  {
    const VkBufferUsageFlags usage =
        VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    engine::Buffer src(*ctx, 256, usage, engine::MemoryUsage::Upload, "test.hazard.src");
    engine::Buffer dst(*ctx, 256, usage, engine::MemoryUsage::DeviceLocal, "test.hazard.dst");
    std::fprintf(stderr, "(the hazard report below is expected)\n");
    ctx->submitAndWait([&](VkCommandBuffer cmd) {
      const VkBufferCopy region{0, 0, 256};
      vkCmdCopyBuffer(cmd, src.handle(), dst.handle(), 1, &region);
      vkCmdCopyBuffer(cmd, src.handle(), dst.handle(), 1, &region);
    });
  }
  ctx->shutdown();
  EXPECT_GE(engine::validationCounts().errors, 1u);
  engine::resetValidationCounts();
}

}  // namespace
