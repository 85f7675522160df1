// csm_flythrough end to end: a headless 120-frame flight over each named path with validation
// on: zero messages, every report field present and finite, shadows in every screenshot.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
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

/// Width and height from a PNG's IHDR chunk (0, 0 when the file is not a PNG).
std::pair<std::uint32_t, std::uint32_t> pngSize(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  unsigned char h[24] = {};
  if (!in.read(reinterpret_cast<char*>(h), sizeof h)) return {0, 0};
  static const unsigned char kSig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (!std::equal(kSig, kSig + 8, h) || std::string(reinterpret_cast<char*>(h + 12), 4) != "IHDR") {
    return {0, 0};
  }
  auto be = [&](int o) {
    return (std::uint32_t(h[o]) << 24) | (std::uint32_t(h[o + 1]) << 16) |
           (std::uint32_t(h[o + 2]) << 8) | std::uint32_t(h[o + 3]);
  };
  return {be(16), be(20)};
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
  EXPECT_EQ(rep["settings"]["view.width"].get<int>(), 320);
  EXPECT_EQ(rep["settings"]["view.height"].get<int>(), 180);
  EXPECT_EQ(rep["path"].get<std::string>(), path);
  EXPECT_EQ(rep["frames"].get<int>(), 120);
  const std::uint32_t cascades = rep["settings"]["shadow.cascades"].get<std::uint32_t>();
  ASSERT_EQ(rep["per_frame"].size(), 120u);
  double trianglesC0 = 0.0;
  int measured = 0;
  for (std::size_t i = 0; i < rep["per_frame"].size(); ++i) {
    const json& f = rep["per_frame"][i];
    const std::string where = "frame " + std::to_string(i);
    // Frames in order along the whole path: index i at t = i / 119.
    EXPECT_EQ(f["index"].get<std::size_t>(), i) << where;
    EXPECT_NEAR(f["t"].get<double>(), double(i) / 119.0, 1e-12) << where;
    for (const char* k : {"setup", "culling", "record", "frame"}) {
      ASSERT_TRUE(f["cpu_ms"].contains(k)) << where << " cpu_ms." << k;
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
    // The cascades tile [near, shadow far] without gaps: each starts where the previous ends,
    // the last ends at the frame's shadow distance, the first at the camera's near plane.
    const json& cs = f["cascades"];
    EXPECT_DOUBLE_EQ(cs[0]["split_near_m"].get<double>(), 0.5) << where;
    for (std::uint32_t c = 0; c + 1 < cascades; ++c) {
      EXPECT_DOUBLE_EQ(cs[c]["split_far_m"].get<double>(), cs[c + 1]["split_near_m"].get<double>())
          << where << " cascade " << c;
      EXPECT_LT(cs[c]["split_near_m"].get<double>(), cs[c]["split_far_m"].get<double>()) << where;
    }
    EXPECT_DOUBLE_EQ(cs[cascades - 1]["split_far_m"].get<double>(), f["shadow_far_m"].get<double>())
        << where;
    if (!f.contains("screenshot")) {
      trianglesC0 += cs[0]["triangles"].get<double>();
      ++measured;
    }
    EXPECT_EQ(f["validation_messages"].get<std::uint64_t>(), 0u) << where;
    expectFiniteNumbers(f, where);
  }
  expectFiniteNumbers(rep["summary"], "summary");
  // The summary is the mean over the frames not followed by screenshot renders (3 of 120).
  EXPECT_EQ(measured, 117);
  EXPECT_EQ(rep["summary"]["measured_frames"].get<int>(), measured);
  EXPECT_NEAR(rep["summary"]["triangles_c0"].get<double>(), trianglesC0 / measured,
              1e-9 * trianglesC0);
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
  std::set<std::string> expected = {"report.json"};
  for (const json& s : rep["screenshots"]) {
    for (const char* k : {"file", "overlay_file", "shadow_file"}) {
      const std::string name = s[k].get<std::string>();
      expected.insert(name);
      const auto [w, h] = pngSize(out / name);
      EXPECT_EQ(w, 320u) << name;
      EXPECT_EQ(h, 180u) << name;
    }
    const double fraction = s["shadowed_fraction"].get<double>();
    EXPECT_GE(fraction, 0.005) << path << " frame " << s["frame"];
    EXPECT_LE(fraction, 0.70) << path << " frame " << s["frame"];
    EXPECT_GT(s["geometry_coverage"].get<double>(), 0.05) << path << " frame " << s["frame"];
  }
  // Exactly the files the report names: no temporary file, no lock left behind.
  std::set<std::string> found;
  for (const auto& e : fs::directory_iterator(out)) found.insert(e.path().filename().string());
  EXPECT_EQ(found, expected);
}

INSTANTIATE_TEST_SUITE_P(Paths, Flight,
                         ::testing::Values("forest", "fast", "rotate", "zoom", "far"),
                         [](const auto& info) { return info.param; });

/// The bytes of a file.
std::string fileBytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

class CacheOnOff : public ::testing::TestWithParam<std::string> {};

// Turning the cache on changes the cost, never the image: the same flight with shadow.cache
// on and off writes byte-identical shadow-factor screenshots (what a user compares first).
TEST_P(CacheOnOff, ShadowScreenshotsByteIdentical) {
  const std::string path = GetParam();
  std::array<fs::path, 2> dirs;
  for (int k = 0; k < 2; ++k) {
    dirs[k] = fs::path(CSM_TEST_ARTEFACT_DIR) / ("cache_" + path + (k == 0 ? "_on" : "_off"));
    fs::remove_all(dirs[k]);
    // The day path's sun steps (0.25°) every frame or two in a 10 s day; the cut path cuts
    // every 6 frames.
    const std::string clock = path == "day"   ? " --set day.lengthS=10"
                              : path == "cut" ? " --set cut.everyS=0.1"
                                              : "";
    const ProcessResult r = runApp(
        "--headless --frames 12 --shot-every 5 --validation --path " + path + " --out " +
        dirs[k].string() + " --set view.width=320 --set view.height=180" +
        " --set shadow.resolution=1024 --set shadow.cache=" + (k == 0 ? "true" : "false") + clock);
    ASSERT_EQ(r.exitCode, 0) << r.output;
  }
  int compared = 0;
  for (const auto& entry : fs::directory_iterator(dirs[0])) {
    const std::string name = entry.path().filename().string();
    if (!name.ends_with("_shadow.png")) continue;
    const std::string on = fileBytes(entry.path()), off = fileBytes(dirs[1] / name);
    ASSERT_FALSE(on.empty()) << name;
    EXPECT_TRUE(on == off) << path << ": " << name << " differs with the cache on and off";
    ++compared;
  }
  EXPECT_EQ(compared, 4) << "screenshots of frames 0, 5, 10 and 11";
}

// Three paths through the app (a flight, a moving sun, cuts): every path's every frame is
// compared layer by layer, in process, by CacheWorld.* (cache_world_tests), which this
// end-to-end check would only repeat at a process start each.
INSTANTIATE_TEST_SUITE_P(Paths, CacheOnOff, ::testing::Values("forest", "day", "cut"),
                         [](const auto& info) { return info.param; });

// The day path moves the sun at its day length (the light steps, the report says how often);
// the cut path jumps between places at its interval (each cut marked). Both report the median
// and the p99 of the shadow pass and of the whole frame.
// Flies csm_flythrough headless with validation and `args` into the test artefact folder `name`
// (emptied first) and returns its report.json, after checking that validation stayed silent;
// nothing after reporting why.
std::optional<json> flyReport(const std::string& name, const std::string& args) {
  const fs::path out = fs::path(CSM_TEST_ARTEFACT_DIR) / name;
  fs::remove_all(out);
  const ProcessResult r = runApp("--headless --validation " + args + " --out " + out.string());
  if (r.exitCode != 0) {
    ADD_FAILURE() << r.output;
    return std::nullopt;
  }
  std::ifstream in(out / "report.json");
  if (!in) {
    ADD_FAILURE() << "no report.json in " << out;
    return std::nullopt;
  }
  json rep;
  in >> rep;
  EXPECT_EQ(rep["validation"]["messages"].get<std::uint64_t>(), 0u);
  return rep;
}

TEST(FlightClock, DayAndCutPathsReportSunStepsCutsAndTheirWorstFrames) {
  for (const std::string path : {"day", "cut"}) {
    const std::optional<json> report =
        flyReport("clock_" + path, "--frames 24 --path " + path +
                                       " --set view.width=160 --set view.height=90"
                                       " --set shadow.resolution=512"
                                       " --set day.lengthS=10 --set cut.everyS=0.1");
    ASSERT_TRUE(report);
    const json& rep = *report;
    EXPECT_EQ(rep["settings"]["day.lengthS"].get<double>(), 10.0);
    EXPECT_EQ(rep["settings"]["cut.everyS"].get<double>(), 0.1);
    const json& frames = rep["per_frame"];
    ASSERT_EQ(frames.size(), 24u);
    int cuts = 0, steps = 0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      const json& f = frames[i];
      EXPECT_NEAR(f["seconds"].get<double>(), double(i) / 60.0, 1e-12);
      const bool cut = f.value("camera_cut", false);
      cuts += cut ? 1 : 0;
      steps += f.value("light_stepped", false) ? 1 : 0;
      if (path == "day") {
        // 180° of azimuth in 10 s: 0.3° a frame, from 135° at the start.
        ASSERT_TRUE(f.contains("sun_deg"));
        EXPECT_NEAR(f["sun_deg"]["azimuth"].get<double>(), 135.0 + 0.3 * double(i), 1e-9);
        EXPECT_FALSE(cut);
      } else {
        EXPECT_FALSE(f.contains("sun_deg"));
        // A new place every 6 frames (0.1 s at 60 frames a second).
        EXPECT_EQ(f["shot"].get<int>(), static_cast<int>(i) / 6) << i;
        EXPECT_EQ(cut, i > 0 && i % 6 == 0) << i;
      }
    }
    EXPECT_EQ(rep["summary"]["camera_cuts"].get<int>(), cuts);
    EXPECT_EQ(rep["summary"]["light_steps"].get<int>(), steps);
    if (path == "day") {
      // More than 0.25° a frame (azimuth and elevation): the held sun steps on every frame
      // after the first.
      EXPECT_EQ(steps, 23) << "the sun did not move the shadows";
      EXPECT_EQ(cuts, 0);
    } else {
      EXPECT_EQ(cuts, 3);
      EXPECT_EQ(steps, 0) << "the cut path keeps the settings' sun";
    }
    for (const char* k :
         {"gpu_shadow_ms_median", "gpu_shadow_ms_p99", "gpu_frame_ms_median", "gpu_frame_ms_p99"}) {
      ASSERT_TRUE(rep["summary"].contains(k)) << k;
      EXPECT_GE(rep["summary"][k].get<double>(), 0.0) << k;
    }
    EXPECT_GE(rep["summary"]["gpu_shadow_ms_p99"].get<double>(),
              rep["summary"]["gpu_shadow_ms_median"].get<double>());
  }
}

// shadow.tileMarks: each frame's report carries, per cascade, the tiles that the visible pixels
// of the frame kFramesInFlight (2) earlier sample: absent on a cut's frame and the next (the
// marks of the old place are dropped), present on every other frame after the first two (whose
// slots the screenshot renders of frame 0 may have filled); at most a grid's worth, fewer in the
// first cascade (a view samples part of it), some in every cascade along the flight. The
// reduction's GPU scope is reported; validation clean.
TEST(FlightClock, TileMarksArePerCascadeAndDroppedAtACut) {
  const std::optional<json> report = flyReport("tile_marks_cut",
                                               "--frames 20 --shot-every 1000 --path cut"
                                               " --set view.width=160 --set view.height=90"
                                               " --set shadow.resolution=512 --set cut.everyS=0.1"
                                               " --set shadow.tileMarks=true");
  ASSERT_TRUE(report);
  const json& rep = *report;
  const json& frames = rep["per_frame"];
  ASSERT_EQ(frames.size(), 20u);
  constexpr std::uint32_t kGrid = 17 * 17;
  std::array<std::uint32_t, 8> most{};
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const json& cascades = frames[i]["cascades"];
    ASSERT_FALSE(cascades.empty());
    ASSERT_LE(cascades.size(), most.size());
    if (i < 2) continue;
    const bool expected = i % 6 >= 2;  // a cut every 6 frames, at frames 6, 12 and 18
    for (std::size_t c = 0; c < cascades.size(); ++c) {
      ASSERT_EQ(cascades[c].contains("tiles_marked"), expected)
          << "frame " << i << " cascade " << c;
      if (!expected) continue;
      const auto n = cascades[c]["tiles_marked"].get<std::uint32_t>();
      EXPECT_LE(n, c == 0 ? kGrid - 1 : kGrid) << "frame " << i << " cascade " << c;
      most[c] = std::max(most[c], n);
    }
  }
  // Every cascade samples some tiles somewhere along the flight (a cascade may see no receiver
  // from one place: the camera high above the ground).
  for (std::size_t c = 0; c < frames[0]["cascades"].size(); ++c) {
    EXPECT_GE(most[c], 1u) << "cascade " << c;
  }
  for (std::size_t i = 1; i < frames.size(); ++i) {
    EXPECT_TRUE(frames[i]["gpu_ms"].contains("tile marks")) << "frame " << i;
  }
}

}  // namespace
