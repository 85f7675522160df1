// Shared fixture of the engine GPU tests: a validation-enabled Context per test, skipped only
// where no Vulkan device exists, and zero validation messages required, counted up to and
// including device and instance destruction (leak reports).
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <memory>

#include "engine/engine.hpp"

namespace engine_test {

/// Whether the environment forces validation off (CSM_VALIDATION=0).
inline bool validationForcedOff() {
  const char* v = std::getenv("CSM_VALIDATION");
  return v && std::strcmp(v, "0") == 0;
}

class GpuTest : public ::testing::Test {
 protected:
  void SetUp() override {
    engine::resetValidationCounts();
    engine::ContextDesc desc;
    desc.appName = "engine_tests";
    desc.validation = true;
    try {
      ctx_ = std::make_unique<engine::Context>(desc);
    } catch (const engine::NoDeviceError& e) {
      GTEST_SKIP() << "no Vulkan device: " << e.what();
    }
    if (!validationForcedOff()) {
      ASSERT_TRUE(ctx_->validationEnabled()) << "VK_LAYER_KHRONOS_validation is required";
    }
  }

  void TearDown() override {
    if (ctx_) {
      ctx_->shutdown();
      ctx_.reset();
    }
    const engine::ValidationCounts counts = engine::validationCounts();
    EXPECT_EQ(counts.errors, 0u) << "validation errors (printed on stderr)";
    EXPECT_EQ(counts.warnings, 0u) << "validation warnings (printed on stderr)";
  }

  engine::Context& ctx() { return *ctx_; }

  std::unique_ptr<engine::Context> ctx_;
};

}  // namespace engine_test
