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

// The runs that render: what they check (settings reaching report.json) does not depend on the
// world's size, and a tenth of the trees generates in a fraction of the time (under the
// sanitizers, 30-70 s a run with the default world).
const std::string kSmallWorld = " --set world.trees=2000";

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

// PCSS from the command line: the kernel and the light's size are settings, bad values are refused
// with the key and the range, good ones reach report.json.
TEST(Cli, PcssKernelAndLightAngle) {
  ProcessResult r = runApp("--headless --set shadow.lightAngleDeg=25");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.output.find("shadow.lightAngleDeg"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("[0, 20]"), std::string::npos) << r.output;
  r = runApp("--headless --set shadow.maxPenumbra=-1");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.output.find("shadow.maxPenumbra"), std::string::npos) << r.output;
  const fs::path out = fs::temp_directory_path() / "csm_flythrough_cli_pcss";
  r = runApp("--headless --frames 1 --out " + out.string() + kSmallWorld +
             " --set shadow.kernel=pcss --set shadow.lightAngleDeg=1.5 --set shadow.maxPenumbra=0.8"
             " --set shadow.resolution=512 --set view.width=320 --set view.height=180");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  std::ifstream in(out / "report.json");
  const json report = json::parse(in);
  EXPECT_EQ(report["settings"]["shadow.kernel"], "pcss");
  EXPECT_DOUBLE_EQ(report["settings"]["shadow.lightAngleDeg"].get<double>(), 1.5);
  EXPECT_DOUBLE_EQ(report["settings"]["shadow.maxPenumbra"].get<double>(), 0.8);
}

// The cache's texel budget: below one layer is refused with the key and the least allowed value;
// a valid one reaches report.json, with each cascade's lag.
TEST(Cli, CacheBudgetTexels) {
  ProcessResult r =
      runApp("--headless --set shadow.resolution=512 --set shadow.cacheBudgetTexels=1000");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.output.find("shadow.cacheBudgetTexels = 1000"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("262144"), std::string::npos) << r.output;
  r = runApp("--headless --set shadow.cacheBudgetTexels=-1");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.output.find("shadow.cacheBudgetTexels"), std::string::npos) << r.output;
  const fs::path out = fs::temp_directory_path() / "csm_flythrough_cli_budget";
  r = runApp("--headless --frames 3 --out " + out.string() + kSmallWorld +
             " --set shadow.resolution=512 --set shadow.cacheBudgetTexels=262144"
             " --set view.width=320 --set view.height=180");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  std::ifstream in(out / "report.json");
  const json report = json::parse(in);
  EXPECT_EQ(report["settings"]["shadow.cacheBudgetTexels"].get<std::uint64_t>(), 262144u);
  EXPECT_EQ(report["summary"]["shadow_cache_budget_texels"].get<std::uint64_t>(), 262144u);
  EXPECT_TRUE(report["per_frame"][0]["cascades"][0].contains("lag_frames"));
  // The tile budget: below one tile refused the same way; a valid one reaches report.json.
  r = runApp("--headless --set shadow.resolution=512 --set shadow.tileBudgetTexels=1000");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.output.find("shadow.tileBudgetTexels = 1000 is invalid"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("= 1024"), std::string::npos) << r.output;
  r = runApp("--headless --frames 4 --out " + out.string() + kSmallWorld +
             " --set shadow.resolution=512 --set shadow.tiles=true"
             " --set shadow.tileBudgetTexels=4096 --set view.width=320 --set view.height=180");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  std::ifstream tiled(out / "report.json");
  const json t = json::parse(tiled);
  EXPECT_EQ(t["summary"]["shadow_tile_budget_texels"].get<std::uint64_t>(), 4096u);
  bool deferredField = false;
  for (const json& frame : t["per_frame"]) {
    for (const json& c : frame["cascades"])
      deferredField = deferredField || c.contains("tiles_deferred");
  }
  EXPECT_TRUE(deferredField) << "a partial cascade reports its deferred tiles";
}

// MSM's moments at 64 or 128 bits: anything else is refused naming the key; 64 bits halve the
// moment image where the device stores RGBA16_UNORM (lavapipe does), recorded in report.json.
TEST(Cli, MsmMomentBits) {
  ProcessResult r = runApp("--headless --set shadow.msmMomentBits=96");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.output.find("shadow.msmMomentBits = 96"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("64 or 128"), std::string::npos) << r.output;
  r = runApp("--headless --set shadow.msmMomentBits=32");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.output.find("shadow.msmMomentBits"), std::string::npos) << r.output;
  std::uint64_t bytes[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    const std::string bits = k == 0 ? "64" : "128";
    const fs::path out = fs::temp_directory_path() / ("csm_flythrough_cli_msm" + bits);
    r = runApp("--headless --frames 2 --out " + out.string() + kSmallWorld +
               " --set shadow.kernel=msm --set shadow.resolution=512 --set shadow.msmMomentBits=" +
               bits + " --set view.width=160 --set view.height=90");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    std::ifstream in(out / "report.json");
    const json report = json::parse(in);
    EXPECT_EQ(report["settings"]["shadow.msmMomentBits"].get<std::uint32_t>(), k == 0 ? 64u : 128u);
    bytes[k] = report["summary"]["moment_bytes"].get<std::uint64_t>();
  }
  EXPECT_GT(bytes[1], 0u);
  EXPECT_EQ(2 * bytes[0], bytes[1]);
}

// --set preset=NAME on the command line: applied before the other --set values wherever it
// stands, recorded in report.json.
TEST(Cli, PresetThenOtherSettingsOnTop) {
  ProcessResult r = runApp("--headless --set preset=epic");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.output.find("low, medium, high, ultra"), std::string::npos) << r.output;
  const fs::path out = fs::temp_directory_path() / "csm_flythrough_cli_preset";
  r = runApp("--headless --frames 1 --out " + out.string() + kSmallWorld +
             " --set shadow.cascades=3 --set preset=low --set view.width=320"
             " --set view.height=180");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  std::ifstream in(out / "report.json");
  const json report = json::parse(in);
  EXPECT_EQ(report["settings"]["preset"], "low");
  EXPECT_EQ(report["settings"]["shadow.cascades"], 3);      // on top of the preset's 6
  EXPECT_EQ(report["settings"]["shadow.resolution"], 512);  // the preset's
  EXPECT_EQ(report["settings"]["shadow.kernel"], "tent3x3");
}

}  // namespace
