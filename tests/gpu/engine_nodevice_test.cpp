// With no Vulkan driver, the smoke app must exit with code 3 and say so on stderr (no crash).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <string>

#ifndef CSM_ENGINE_SMOKE_EXE
#error "CSM_ENGINE_SMOKE_EXE must name the csm_engine_smoke binary"
#endif

namespace {

TEST(EngineNoDevice, SmokeExitsWith3AndAMessage) {
  // 2>&1 1>/dev/null: capture stderr only.
  const std::string command =
      "VK_DRIVER_FILES=/nonexistent.json VK_ICD_FILENAMES=/nonexistent.json '" +
      std::string(CSM_ENGINE_SMOKE_EXE) + "' --out /dev/null 2>&1 1>/dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string err;
  char buf[512];
  while (size_t n = fread(buf, 1, sizeof(buf), pipe)) err.append(buf, n);
  const int status = pclose(pipe);
  ASSERT_TRUE(WIFEXITED(status)) << "the smoke app crashed; stderr:\n" << err;
  EXPECT_EQ(WEXITSTATUS(status), 3) << err;
  EXPECT_NE(err.find("no Vulkan device"), std::string::npos) << err;
}

}  // namespace
