// The fly-through's debug overlay shows what is sampled (issue 24), end to end on the default
// world with validation on: the shadow-map thumbnails are readable (casters dark on a light
// ground, never a flat block), the statistics panel reports each cascade's LOD range, prints no
// GPU time before one was measured and covers at most a sixth of a 640x360 view, and the texel
// checker fades out where a texel is smaller than 2 pixels instead of aliasing.
#include <gtest/gtest.h>

#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#include <stb_image.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "csm/gpu_layout.hpp"
#include "run_app.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct Image {
  int width = 0, height = 0;
  std::vector<unsigned char> rgba;
  const unsigned char* at(int x, int y) const {
    return rgba.data() + (std::size_t(y) * std::size_t(width) + std::size_t(x)) * 4;
  }
  double luma(int x, int y) const {
    const unsigned char* p = at(x, y);
    return (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]) / 255.0;
  }
};

Image loadPng(const fs::path& file) {
  Image im;
  int n = 0;
  std::unique_ptr<unsigned char, void (*)(void*)> px(
      stbi_load(file.string().c_str(), &im.width, &im.height, &n, 4), stbi_image_free);
  if (px) im.rgba.assign(px.get(), px.get() + std::size_t(im.width) * im.height * 4);
  return im;
}

json runFlight(const fs::path& out, const std::string& args) {
  fs::remove_all(out);
  const ProcessResult r = runApp("--headless --validation --out " + out.string() + " " + args);
  EXPECT_EQ(r.exitCode, 0) << r.output;
  std::ifstream in(out / "report.json");
  if (!in) {
    ADD_FAILURE() << "no report.json in " << out << "\n" << r.output;
    return json();
  }
  json rep = json::parse(in);
  EXPECT_EQ(rep["validation"]["messages"].get<std::uint64_t>(), 0u) << out;
  return rep;
}

/// Mean grey level (0..255) of a rectangle of pixels (clipped to the image).
double meanGrey(const Image& im, int x0, int y0, int x1, int y1) {
  x0 = std::clamp(x0, 0, im.width), x1 = std::clamp(x1, 0, im.width);
  y0 = std::clamp(y0, 0, im.height), y1 = std::clamp(y1, 0, im.height);
  double sum = 0.0;
  int n = 0;
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x, ++n) {
      const unsigned char* p = im.at(x, y);
      sum += (p[0] + p[1] + p[2]) / 3.0;
    }
  }
  return n ? sum / n : 0.0;
}

// ---- One flight at 640x360 along each of forest and fast: screenshots at frames 0 and 2 ------

constexpr int kWidth = 640, kHeight = 360;

// Each cascade's LOD range: lod_min <= lod_max, "lod" still the coarsest, and the range is a
// range (the default world's near cascades draw near clusters finer than far ones).
void expectLodRanges(const json& rep) {
  bool someRange = false;
  for (const json& f : rep["per_frame"]) {
    for (const json& c : f["cascades"]) {
      ASSERT_TRUE(c.contains("lod_min") && c.contains("lod_max") && c.contains("lod_clusters"))
          << c.dump();
      const auto lo = c["lod_min"].get<std::uint32_t>(), hi = c["lod_max"].get<std::uint32_t>();
      EXPECT_LE(lo, hi) << c.dump();
      EXPECT_EQ(c["lod"].get<std::uint32_t>(), hi) << c.dump();
      EXPECT_LE(c["lod_clusters"].get<std::uint32_t>(), c["casters"].get<std::uint32_t>());
      if (!c["empty"].get<bool>()) {
        EXPECT_GT(c["lod_clusters"].get<std::uint32_t>(), 0u) << c.dump();
      }
      someRange |= lo < hi;
    }
  }
  EXPECT_TRUE(someRange) << "no cascade drew more than one LOD";
}

// The panel prints "-" (report: null) for every GPU time before the first one was measured, and
// the times once they were.
void expectNoGpuTimeBeforeOneIsMeasured(const json& rep) {
  const json& first = rep["screenshots"][0];
  ASSERT_EQ(first["frame"].get<int>(), 0);
  ASSERT_TRUE(first.contains("overlay_panel")) << first.dump();
  const json& gpu0 = first["overlay_panel"]["gpu_ms"];
  const std::uint32_t cascades = rep["settings"]["shadow.cascades"].get<std::uint32_t>();
  std::vector<std::string> scopes = {"shadow", "lit", "overlay"};
  for (std::uint32_t c = 0; c < cascades; ++c) scopes.push_back("shadow c" + std::to_string(c));
  for (const std::string& s : scopes) {
    ASSERT_TRUE(gpu0.contains(s)) << gpu0.dump();
    EXPECT_TRUE(gpu0[s].is_null()) << s << ": " << gpu0[s];
  }
  const json& later = rep["screenshots"][1]["overlay_panel"]["gpu_ms"];
  for (const char* s : {"shadow", "lit", "shadow c0"}) {
    ASSERT_TRUE(later.contains(s) && later[s].is_number()) << later.dump();
    EXPECT_GT(later[s].get<double>(), 0.0) << s;
  }
}

// The panel covers at most a sixth of the 640x360 view, and the pixels agree with the rectangle
// it reports: darkened inside (its background over the plain frame), untouched beside and below.
void expectPanelAtMostASixth(const json& rep, const fs::path& out) {
  for (const json& s : rep["screenshots"]) {
    ASSERT_TRUE(s.contains("overlay_panel")) << s.dump();
    const json& p = s["overlay_panel"];
    const double x = p["x"].get<double>(), y = p["y"].get<double>();
    const double w = p["width"].get<double>(), h = p["height"].get<double>();
    EXPECT_GE(p["font_px"].get<double>(), 10.0);
    EXPECT_LE(w * h, kWidth * kHeight / 6.0) << w << " x " << h;
    EXPECT_LE(x + w, kWidth);
    EXPECT_LE(y + h, kHeight);
    const Image overlay = loadPng(out / s["overlay_file"].get<std::string>());
    const Image plain = loadPng(out / s["file"].get<std::string>());
    ASSERT_EQ(overlay.width, kWidth);
    ASSERT_EQ(plain.width, kWidth);
    const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
    const int x1 = int(std::ceil(x + w)), y1 = int(std::ceil(y + h));
    auto ratio = [&](int ax, int ay, int bx, int by) {
      return meanGrey(overlay, ax, ay, bx, by) / std::max(1.0, meanGrey(plain, ax, ay, bx, by));
    };
    EXPECT_LT(ratio(x0, y0, x1, y1), 0.7) << "the panel is not where the report says";
    EXPECT_GT(ratio(x1 + 2, y0, x1 + 30, y1), 0.85) << "the panel is wider than reported";
    EXPECT_GT(ratio(x0, y1 + 2, x1, y1 + 30), 0.85) << "the panel is taller than reported";
  }
}

// Every cascade's thumbnail (laid out as WorldRenderer::buildOverlay does: bottom-left, side
// min(0.2 H, (0.55 W - pad (n + 1)) / n), pad max(4, 0.01 H), framed 2 px in the cascade's tint)
// shows casters dark on a light ground: its grey levels span a range, much of it is light and a
// part of it dark. (The raw layer remapped by the sphere's depth range was one flat block.)
void expectReadableThumbnails(const json& rep, const fs::path& out) {
  const int n = int(rep["settings"]["shadow.cascades"].get<std::uint32_t>());
  const double pad = std::max(4.0, 0.01 * kHeight);
  const double size = std::min(0.2 * kHeight, (0.55 * kWidth - pad * (n + 1)) / n);
  for (const json& s : rep["screenshots"]) {
    const std::string name = s["overlay_file"].get<std::string>();
    const Image im = loadPng(out / name);
    ASSERT_EQ(im.width, kWidth) << name;
    for (int c = 0; c < n; ++c) {
      const std::string where = name + " cascade " + std::to_string(c);
      const int ax = int(pad + c * (size + pad)), ay = int(kHeight - pad - size);
      // The frame in the cascade's tint just left of the thumbnail: the layout is as assumed.
      const glm::vec3 tint = csm::cascadeTint(c);
      const unsigned char* f = im.at(ax - 1, ay + int(size) / 2);
      for (int k = 0; k < 3; ++k) ASSERT_NEAR(f[k], tint[k] * 255.0f, 2.0f) << where;
      std::vector<double> v;
      for (int y = ay + 1; y < ay + int(size) - 1; ++y) {
        for (int x = ax + 1; x < ax + int(size) - 1; ++x) v.push_back(im.luma(x, y));
      }
      std::sort(v.begin(), v.end());
      const double p5 = v[v.size() / 20], p95 = v[v.size() * 19 / 20];
      auto share = [&](auto pred) {
        return double(std::count_if(v.begin(), v.end(), pred)) / double(v.size());
      };
      const double dark = share([](double l) { return l < 0.3; });
      const double light = share([](double l) { return l > 0.5; });
      EXPECT_GT(p95 - p5, 0.4) << where << ": a flat block";
      EXPECT_GT(light, 0.3) << where << ": no light ground";
      EXPECT_GT(dark, 0.02) << where << ": no dark casters";
      EXPECT_LT(dark, 0.7) << where << ": casters everywhere";
    }
  }
}

class FlythroughOverlay : public ::testing::TestWithParam<std::string> {};

TEST_P(FlythroughOverlay, ShowsWhatIsSampled) {
  const fs::path out = fs::path(CSM_TEST_ARTEFACT_DIR) / ("overlay_" + GetParam());
  const json rep = runFlight(out, "--frames 3 --shot-every 2 --path " + GetParam() +
                                      " --set view.width=640 --set view.height=360");
  ASSERT_TRUE(rep.contains("screenshots"));
  ASSERT_EQ(rep["screenshots"].size(), 2u);
  {
    SCOPED_TRACE("LOD ranges");
    expectLodRanges(rep);
  }
  {
    SCOPED_TRACE("GPU times");
    expectNoGpuTimeBeforeOneIsMeasured(rep);
  }
  {
    SCOPED_TRACE("panel size");
    expectPanelAtMostASixth(rep, out);
  }
  {
    SCOPED_TRACE("thumbnails");
    expectReadableThumbnails(rep, out);
  }
}

INSTANTIATE_TEST_SUITE_P(Paths, FlythroughOverlay, ::testing::Values("forest", "fast"),
                         [](const auto& info) { return info.param; });

// With a prefiltered filter the thumbnails show the moment layers the lighting reads: readable
// as the depth ones are (casters dark on a light ground), and not the depth layers themselves
// (the blur softens every caster's edge, so the same flight's thumbnails differ from the
// tent's wherever the blur spans a texel or more; were they drawn from the depth layer they
// would be identical). Where the blur is under half a texel there is none (csm_moments.comp),
// and the two thumbnails agree.
TEST(FlythroughOverlayMoments, ThumbnailsShowTheMomentLayers) {
  const std::string flight =
      "--frames 3 --shot-every 2 --path forest --set view.width=640 "
      "--set view.height=360 --set shadow.momentBlur=0.5";
  const fs::path depthOut = fs::path(CSM_TEST_ARTEFACT_DIR) / "overlay_moments_tent";
  const fs::path momentOut = fs::path(CSM_TEST_ARTEFACT_DIR) / "overlay_moments_msm";
  const json depthRep = runFlight(depthOut, flight + " --set shadow.kernel=tent3x3");
  const json momentRep = runFlight(momentOut, flight + " --set shadow.kernel=msm");
  ASSERT_EQ(momentRep["screenshots"].size(), 2u);
  {
    SCOPED_TRACE("msm thumbnails");
    expectReadableThumbnails(momentRep, momentOut);
  }
  const int n = int(momentRep["settings"]["shadow.cascades"].get<std::uint32_t>());
  const double pad = std::max(4.0, 0.01 * kHeight);
  const double size = std::min(0.2 * kHeight, (0.55 * kWidth - pad * (n + 1)) / n);
  constexpr double kBlurM = 0.5;
  std::uint32_t blurred = 0;
  for (std::size_t k = 0; k < 2; ++k) {
    const json& shot = momentRep["screenshots"][k];
    const std::string name = shot["overlay_file"].get<std::string>();
    const json& cascades = momentRep["per_frame"][shot["frame"].get<std::size_t>()]["cascades"];
    const Image a =
        loadPng(depthOut / depthRep["screenshots"][k]["overlay_file"].get<std::string>());
    const Image b = loadPng(momentOut / name);
    ASSERT_EQ(a.width, b.width);
    for (int c = 0; c < n; ++c) {
      const int ax = int(pad + c * (size + pad)), ay = int(kHeight - pad - size);
      std::uint64_t differ = 0, all = 0;
      for (int y = ay + 1; y < ay + int(size) - 1; ++y) {
        for (int x = ax + 1; x < ax + int(size) - 1; ++x) {
          ++all;
          if (std::abs(a.luma(x, y) - b.luma(x, y)) > 12.0 / 255.0) ++differ;
        }
      }
      const double share = double(differ) / double(all);
      const double blurTexels = kBlurM / cascades[std::size_t(c)]["texel_m"].get<double>();
      std::printf(
          "[overlay moments] %s cascade %d: blur %.2f texels, %.2f%% of thumbnail "
          "pixels differ\n",
          name.c_str(), c, blurTexels, 100.0 * share);
      if (blurTexels >= 1.0) {
        ++blurred;
        EXPECT_GT(share, 0.005) << name << " cascade " << c
                                << ": the msm thumbnail looks like the depth layer";
      } else if (blurTexels < 0.5) {
        EXPECT_LT(share, 0.005) << name << " cascade " << c << ": unblurred moments differ";
      }
    }
  }
  EXPECT_GE(blurred, 4u) << "too few cascades where the blur spans a texel: the case tests little";
}

// ---- The texel checker ------------------------------------------------------------------------

/// Fraction of pixels of two overlay screenshots (checker on and off) that differ by more than
/// 12 grey levels in any channel, outside the statistics panel of either run (its timings differ,
/// and so may its size: a slower build prints longer numbers); where a report does not say where
/// it is, the top left 85 % x 50 % of the view is left out.
double checkerPixels(const json& on, const json& off, const fs::path& dirOn,
                     const fs::path& dirOff) {
  const std::string name = on["screenshots"][0]["overlay_file"].get<std::string>();
  const Image a = loadPng(dirOn / name), b = loadPng(dirOff / name);
  EXPECT_TRUE(a.width > 0 && a.width == b.width && a.height == b.height) << name;
  if (!(a.width > 0 && a.width == b.width && a.height == b.height)) return 0.0;
  double px1 = 0.0, py1 = 0.0;
  for (const json* rep : {&on, &off}) {
    const json& shot = (*rep)["screenshots"][0];
    if (!shot.contains("overlay_panel")) {
      px1 = std::max(px1, 0.85 * a.width);
      py1 = std::max(py1, 0.5 * a.height);
      continue;
    }
    const json& p = shot["overlay_panel"];
    px1 = std::max(px1, p["x"].get<double>() + p["width"].get<double>() + 1.0);
    py1 = std::max(py1, p["y"].get<double>() + p["height"].get<double>() + 1.0);
  }
  std::size_t differ = 0, total = 0;
  for (int y = 0; y < a.height; ++y) {
    for (int x = 0; x < a.width; ++x) {
      if (x < px1 && y < py1) continue;
      ++total;
      const unsigned char *pa = a.at(x, y), *pb = b.at(x, y);
      for (int k = 0; k < 3; ++k) {
        if (std::abs(int(pa[k]) - int(pb[k])) > 12) {
          ++differ;
          break;
        }
      }
    }
  }
  return total ? double(differ) / double(total) : 0.0;
}

/// The checker's share of a width x height overlay screenshot of the forest's first frame:
/// the run with the checker against the same run without it.
double checkerShare(const std::string& name, int width, int height, const std::string& settings) {
  const fs::path dir = fs::path(CSM_TEST_ARTEFACT_DIR) / ("overlay_checker_" + name);
  const std::string args = "--frames 1 --path forest --set view.width=" + std::to_string(width) +
                           " --set view.height=" + std::to_string(height) + " " + settings;
  const json on = runFlight(dir / "on", args);
  const json off = runFlight(dir / "off", args + " --set overlay.checker=false");
  if (!on.contains("screenshots") || !off.contains("screenshots")) return -1.0;
  return checkerPixels(on, off, dir / "on", dir / "off");
}

// Default resolution (2048): a texel of the forest's first view spans less than 2 pixels
// everywhere, so the checker has faded out entirely (before: a moire over a quarter of the view),
// in the deferred lighting pass (the default: steps to the neighbouring G-buffer pixels) ...
TEST(FlythroughOverlayChecker, FadesWhereTexelsAreSmallerThanTwoPixelsDeferred) {
  const double share = checkerShare("deferred", 320, 180, "--set view.deferred=true");
  EXPECT_GE(share, 0.0);
  EXPECT_LT(share, 0.002);
}

// ... and in the forward lit pass (screen-space derivatives).
TEST(FlythroughOverlayChecker, FadesWhereTexelsAreSmallerThanTwoPixelsForward) {
  const double share = checkerShare("forward", 320, 180, "--set view.deferred=false");
  EXPECT_GE(share, 0.0);
  EXPECT_LT(share, 0.002);
}

// At 256 texels a side the near cascades' texels span several pixels of a 640x360 view: there the
// checker shows (about a tenth of the view).
TEST(FlythroughOverlayChecker, ShownWhereTexelsSpanPixels) {
  EXPECT_GT(checkerShare("coarse", 640, 360, "--set shadow.resolution=256"), 0.03);
}

}  // namespace
