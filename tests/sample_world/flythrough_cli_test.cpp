// csm_flythrough's command-line refusals: bad --mesh files (missing, empty, truncated, random
// bytes) and bad flags, settings and config files each exit 2 with a message naming the reason.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "run_app.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

TEST(Cli, BadMeshFilesExitTwoWithTheirReason) {
  const fs::path dir = fs::temp_directory_path() / "csm_flythrough_cli";
  fs::create_directories(dir);
  auto write = [&](const std::string& name, const std::string& bytes) {
    std::ofstream(dir / name, std::ios::binary) << bytes;
    return (dir / name).string();
  };
  std::string garbage(2048, '\0');
  for (std::size_t i = 0; i < garbage.size(); ++i)
    garbage[i] = static_cast<char>((i * 131u + 7u) % 256u);
  const std::string off = "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 2 3\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {(dir / "missing.obj").string(), "file not found"},
      {write("empty.ply", ""), "empty"},
      {write("truncated.off", off.substr(0, off.size() - 14)), "truncated"},
      {write("random.ply", garbage), "not a valid PLY"},
  };
  for (const auto& [file, reason] : cases) {
    const ProcessResult r =
        runApp("--headless --frames 1 --out " + (dir / "out").string() + " --mesh " + file);
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_NE(r.output.find(file), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(reason), std::string::npos) << r.output;
  }
}

TEST(Cli, InvalidFlagsAndSettingsListAllowedValues) {
  ProcessResult r = runApp("--headless --set shadow.kernel=box");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.output.find("poisson16"), std::string::npos) << r.output;
  r = runApp("--headless --path nowhere");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.output.find("forest, fast, rotate, zoom, far"), std::string::npos) << r.output;
  r = runApp("--headless --frames zero");
  EXPECT_EQ(r.exitCode, 2);
  r = runApp("--no-such-flag");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.output.find("--headless"), std::string::npos) << r.output;
  r = runApp("--headless --config /nonexistent/config.json");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.output.find("/nonexistent/config.json"), std::string::npos) << r.output;
}

}  // namespace
