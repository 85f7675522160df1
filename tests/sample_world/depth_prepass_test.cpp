// The fly-through's depth pre-pass (view.depthPrepass) and back-face culling of closed meshes
// (view.cullBackFaces): the lit pass after a depth-only draw of the same instances (depth test
// EQUAL, no writes) shows the image of the lit pass alone with both faces drawn (the renderer
// before either), with validation on. The only pixels allowed to differ are depth ties: where two
// surfaces rasterise to the same depth value, depth test LESS keeps the first drawn and EQUAL the
// last drawn (a back face culled no longer ties). And deferred shading (view.deferred) against
// that forward lit pass.
#include <gtest/gtest.h>

#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#include <stb_image.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "run_app.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct Image {
  int width = 0, height = 0;
  std::vector<unsigned char> rgba;
};

Image loadPng(const fs::path& file) {
  Image im;
  int n = 0;
  std::unique_ptr<unsigned char, void (*)(void*)> px(
      stbi_load(file.string().c_str(), &im.width, &im.height, &n, 4), stbi_image_free);
  if (px) im.rgba.assign(px.get(), px.get() + std::size_t(im.width) * im.height * 4);
  return im;
}

// The forward lit pass with the depth pre-pass and back-face culling (the default before
// view.deferred), the lit pass alone with both faces drawn (the renderer before either), and
// deferred shading.
const char* kForward =
    " --set view.deferred=false --set view.depthPrepass=true"
    " --set view.cullBackFaces=true";
const char* kLitAlone =
    " --set view.deferred=false --set view.depthPrepass=false"
    " --set view.cullBackFaces=false";
const char* kDeferred = " --set view.deferred=true --set view.cullBackFaces=true";

struct ImagePair {
  std::string name;
  Image a, b;
};

// The lit images and shadow-factor views of two runs' screenshots (the overlay image adds host
// text with timings), loaded in pairs; a pair whose names or 320x180 sizes disagree is reported
// as a failure and left out.
std::vector<ImagePair> litAndShadowImages(const json& ra, const fs::path& da, const json& rb,
                                          const fs::path& db) {
  std::vector<ImagePair> pairs;
  const std::size_t n = std::min(ra["screenshots"].size(), rb["screenshots"].size());
  for (std::size_t s = 0; s < n; ++s) {
    for (const char* k : {"file", "shadow_file"}) {
      const std::string name = ra["screenshots"][s][k].get<std::string>();
      if (name != rb["screenshots"][s][k].get<std::string>()) {
        ADD_FAILURE() << "screenshot " << s << ": " << name << " against "
                      << rb["screenshots"][s][k].get<std::string>();
        continue;
      }
      ImagePair p{name, loadPng(da / name), loadPng(db / name)};
      if (p.a.width != 320 || p.a.height != 180 || p.b.width != 320 || p.b.height != 180) {
        ADD_FAILURE() << name << " is not 320x180 in both runs";
        continue;
      }
      pairs.push_back(std::move(p));
    }
  }
  return pairs;
}

json runFlight(const std::string& path, const std::string& settings, const fs::path& out) {
  fs::remove_all(out);
  // Small on purpose (lavapipe): 320x180 views, 1024^2 cascades, screenshots at 0, 4, 8, 11.
  const ProcessResult r = runApp("--headless --frames 12 --shot-every 4 --validation --path " +
                                 path + " --out " + out.string() +
                                 " --set view.width=320 --set view.height=180"
                                 " --set shadow.resolution=1024" +
                                 settings);
  EXPECT_EQ(r.exitCode, 0) << r.output;
  std::ifstream in(out / "report.json");
  if (!in) {
    ADD_FAILURE() << "no report.json in " << out;
    return json();
  }
  json rep;
  in >> rep;
  return rep;
}

// Each report of a comparison had validation on and heard nothing.
void expectValidationClean(std::initializer_list<const json*> reports) {
  for (const json* rep : reports) {
    EXPECT_TRUE((*rep)["validation"]["enabled"].get<bool>());
    EXPECT_EQ((*rep)["validation"]["messages"].get<std::uint64_t>(), 0u);
  }
}

class Prepass : public ::testing::TestWithParam<std::string> {};

TEST_P(Prepass, PrepassAndCullingSameImageAsLitPassAloneValidationClean) {
  const std::string path = GetParam();
  const fs::path base = fs::path(CSM_TEST_ARTEFACT_DIR) / "depth_prepass" / path;
  const json on = runFlight(path, kForward, base / "on");
  const json off = runFlight(path, kLitAlone, base / "off");
  ASSERT_TRUE(on.is_object() && off.is_object());
  expectValidationClean({&on, &off});
  EXPECT_TRUE(on["settings"]["view.depthPrepass"].get<bool>());
  EXPECT_TRUE(on["settings"]["view.cullBackFaces"].get<bool>());
  EXPECT_FALSE(off["settings"]["view.depthPrepass"].get<bool>());
  EXPECT_FALSE(off["settings"]["view.cullBackFaces"].get<bool>());
  // The pre-pass has its own GPU scope (a rendering of its own); without it there is none.
  for (const json& f : on["per_frame"]) {
    ASSERT_TRUE(f["gpu_ms"].contains("prepass"));
    EXPECT_GT(f["gpu_ms"]["prepass"].get<double>(), 0.0);
  }
  for (const json& f : off["per_frame"]) EXPECT_FALSE(f["gpu_ms"].contains("prepass"));

  ASSERT_EQ(on["screenshots"].size(), 4u);
  ASSERT_EQ(off["screenshots"].size(), 4u);
  std::uint64_t differing = 0, total = 0;
  const std::vector<ImagePair> pairs = litAndShadowImages(on, base / "on", off, base / "off");
  EXPECT_EQ(pairs.size(), 8u);
  for (const ImagePair& im : pairs) {
    std::uint64_t here = 0;
    for (std::size_t p = 0; p < im.a.rgba.size(); p += 4) {
      here += (im.a.rgba[p] != im.b.rgba[p] || im.a.rgba[p + 1] != im.b.rgba[p + 1] ||
               im.a.rgba[p + 2] != im.b.rgba[p + 2])
                  ? 1
                  : 0;
    }
    // Per image: depth ties are a few pixels of distant, overlapping foliage. A pre-pass whose
    // depths differ from the lit pass's (no `precise`, another vertex shader) fails EQUAL on
    // whole surfaces and shows the sky there; culling the front faces of a mesh, or the back
    // faces of an open one, shows what lies behind it.
    EXPECT_LE(here, im.a.rgba.size() / 4 / 500)
        << path << " " << im.name << ": " << here << " pixels differ";
    differing += here;
    total += im.a.rgba.size() / 4;
  }
  std::printf("%s: %llu of %llu pixels differ with the pre-pass and culling (depth ties)\n",
              path.c_str(), static_cast<unsigned long long>(differing),
              static_cast<unsigned long long>(total));
  // Over all images of the flight: under 0.1 %.
  EXPECT_LE(differing * 1000, total);
}

INSTANTIATE_TEST_SUITE_P(Paths, Prepass, ::testing::Values("forest", "fast"),
                         [](const auto& info) { return info.param; });

// Deferred shading (view.deferred) shows the forward lit pass's image: the G-buffer holds the
// albedo in 8 bits (the forward pass reads it as a float vertex colour), the normals octahedral
// in half floats and the view depth in a float (the point is put back on its pixel's ray), so
// colours may differ by a few levels of rounding, and a shadow lookup on the very edge of a
// shadow-map texel may land on the other side. Validation (synchronization included) clean, and
// the report has the G-buffer pass's scope instead of the pre-pass's.
class Deferred : public ::testing::TestWithParam<std::string> {};

TEST_P(Deferred, SameImageAsTheForwardLitPassValidationClean) {
  const std::string path = GetParam();
  const fs::path base = fs::path(CSM_TEST_ARTEFACT_DIR) / "deferred" / path;
  const json deferred = runFlight(path, kDeferred, base / "deferred");
  const json forward = runFlight(path, kForward, base / "forward");
  ASSERT_TRUE(deferred.is_object() && forward.is_object());
  expectValidationClean({&deferred, &forward});
  EXPECT_TRUE(deferred["settings"]["view.deferred"].get<bool>());
  EXPECT_FALSE(forward["settings"]["view.deferred"].get<bool>());
  for (const json& f : deferred["per_frame"]) {
    ASSERT_TRUE(f["gpu_ms"].contains("gbuffer"));
    EXPECT_GT(f["gpu_ms"]["gbuffer"].get<double>(), 0.0);
    EXPECT_GT(f["gpu_ms"]["lit"].get<double>(), 0.0);
    EXPECT_FALSE(f["gpu_ms"].contains("prepass"));
  }
  ASSERT_EQ(deferred["screenshots"].size(), 4u);
  ASSERT_EQ(forward["screenshots"].size(), 4u);
  std::uint64_t rounding = 0, far = 0, total = 0;
  int largest = 0;
  const std::vector<ImagePair> pairs =
      litAndShadowImages(deferred, base / "deferred", forward, base / "forward");
  EXPECT_EQ(pairs.size(), 8u);
  for (const ImagePair& im : pairs) {
    std::uint64_t farHere = 0;
    for (std::size_t p = 0; p < im.a.rgba.size(); p += 4) {
      int d = 0;
      for (int c = 0; c < 3; ++c) {
        d = std::max(d, std::abs(int(im.a.rgba[p + c]) - int(im.b.rgba[p + c])));
      }
      largest = std::max(largest, d);
      rounding += d > 0 && d <= 3 ? 1 : 0;
      farHere += d > 3 ? 1 : 0;
    }
    // A sky pixel shaded, a surface left sky, a wrong normal or position: whole surfaces or
    // strips. Shadow-texel edge flips and depth ties: a few scattered pixels.
    EXPECT_LE(farHere, im.a.rgba.size() / 4 / 1000)
        << path << " " << im.name << ": " << farHere << " pixels differ by more than 3 levels";
    far += farHere;
    total += im.a.rgba.size() / 4;
  }
  std::printf("%s: of %llu pixels %llu differ by 1-3 levels, %llu by more (largest %d)\n",
              path.c_str(), static_cast<unsigned long long>(total),
              static_cast<unsigned long long>(rounding), static_cast<unsigned long long>(far),
              largest);
  EXPECT_LE(far * 2000, total);
}

INSTANTIATE_TEST_SUITE_P(Paths, Deferred, ::testing::Values("forest", "far"),
                         [](const auto& info) { return info.param; });

}  // namespace
