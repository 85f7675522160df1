// csm_flythrough end to end: a headless 120-frame flight over each named path with validation
// on: zero messages, every report field present and finite, shadows in every screenshot.
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

void expectFiniteNumbers(const json& j, const std::string& where) {
  if (j.is_number()) {
    EXPECT_TRUE(std::isfinite(j.get<double>())) << where;
  } else if (j.is_null()) {
    ADD_FAILURE() << where << " is null";
  } else if (j.is_object()) {
    for (const auto& [k, v] : j.items()) expectFiniteNumbers(v, where + "." + k);
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i)
      expectFiniteNumbers(j[i], where + "[" + std::to_string(i) + "]");
  }
}

class Flight : public ::testing::TestWithParam<std::string> {};

TEST_P(Flight, HeadlessValidatedReportAndShadows) {
  const std::string path = GetParam();
  const fs::path out = fs::path(CSM_TEST_ARTEFACT_DIR) / path;
  fs::remove_all(out);
  // Small on purpose (lavapipe): 320x180 views, 1024^2 cascades; the world is the default one.
  const ProcessResult r = runApp(
      "--headless --frames 120 --shot-every 60 --validation --path " + path + " --out " +
      out.string() + " --set view.width=320 --set view.height=180 --set shadow.resolution=1024");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  std::ifstream in(out / "report.json");
  ASSERT_TRUE(in) << "no report.json in " << out;
  json rep;
  in >> rep;

  EXPECT_TRUE(rep["validation"]["enabled"].get<bool>());
  EXPECT_EQ(rep["validation"]["messages"].get<std::uint64_t>(), 0u);
  ASSERT_TRUE(rep.contains("settings"));
  EXPECT_EQ(rep["settings"]["shadow.resolution"].get<int>(), 1024);
  const std::uint32_t cascades = rep["settings"]["shadow.cascades"].get<std::uint32_t>();
  ASSERT_EQ(rep["per_frame"].size(), 120u);
  for (const json& f : rep["per_frame"]) {
    const std::string where = "frame " + std::to_string(f["index"].get<int>());
    for (const char* k : {"setup", "culling", "record", "frame"}) {
      ASSERT_TRUE(f["cpu_ms"].contains(k)) << where << " cpu_ms." << k;
      EXPECT_GE(f["cpu_ms"][k].get<double>(), 0.0) << where;
    }
    for (const char* k : {"shadow", "lit"}) {
      ASSERT_TRUE(f["gpu_ms"].contains(k)) << where << " gpu_ms." << k;
    }
    ASSERT_EQ(f["cascades"].size(), cascades) << where;
    for (const json& c : f["cascades"]) {
      for (const char* k : {"split_near_m", "split_far_m", "sphere_radius_m", "texel_m", "casters",
                            "triangles", "lod", "empty"}) {
        ASSERT_TRUE(c.contains(k)) << where << " cascade field " << k;
      }
    }
    EXPECT_EQ(f["validation_messages"].get<std::uint64_t>(), 0u) << where;
    expectFiniteNumbers(f, where);
  }
  expectFiniteNumbers(rep["summary"], "summary");
  // Casters are drawn: the nearest cascade and the whole shadow pass draw triangles.
  EXPECT_GT(rep["summary"]["triangles_c0"].get<double>(), 0.0);

  // Screenshots at frames 0, 60 and 119, each with and without the overlay. Shadowed fraction
  // of the geometry pixels (shadow-factor debug view): the sun stands 32 degrees high, so every
  // tree, rock and building casts a shadow 1.6 times its height long onto lit ground, and every
  // view of these paths holds some: the sparsest, the town seen from 60 m on the fast path,
  // measures 0.87 %, the others 3-40 %; a shadow pass that draws nothing gives 0 (>= 0.5 %).
  // More than 70 % shadowed would mean acne or a reversed comparison (lit slopes facing a
  // 32-degree sun are most of the terrain).
  ASSERT_EQ(rep["screenshots"].size(), 3u);
  for (const json& s : rep["screenshots"]) {
    EXPECT_TRUE(fs::exists(out / s["file"].get<std::string>()));
    EXPECT_TRUE(fs::exists(out / s["overlay_file"].get<std::string>()));
    const double fraction = s["shadowed_fraction"].get<double>();
    EXPECT_GE(fraction, 0.005) << path << " frame " << s["frame"];
    EXPECT_LE(fraction, 0.70) << path << " frame " << s["frame"];
    EXPECT_GT(s["geometry_coverage"].get<double>(), 0.05) << path << " frame " << s["frame"];
  }
}

INSTANTIATE_TEST_SUITE_P(Paths, Flight,
                         ::testing::Values("forest", "fast", "rotate", "zoom", "far"),
                         [](const auto& info) { return info.param; });

}  // namespace
