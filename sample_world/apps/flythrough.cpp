// csm_flythrough: the open-world sample. Windowed (GLFW + Dear ImGui panel, mouse and keyboard
// flight) when a display is present, or headless along a named spline path, writing PNG
// screenshots (with and without the cascade-visualisation overlay) and DIR/report.json.
// Exit codes: 0 success, 1 runtime error or validation messages, 2 invalid arguments, settings
// or mesh file, 3 no Vulkan device.
#include <GLFW/glfw3.h>
#include <imgui.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include "csm/names.hpp"
#include "engine/engine.hpp"
#include "enum_combo.hpp"
#include "imgui_layer.hpp"
#include "sample_world/key_state.hpp"
#include "sample_world/output_dir.hpp"
#include "sample_world/paths.hpp"
#include "sample_world/settings.hpp"
#include "sample_world/world.hpp"
#include "sample_world/world_renderer.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;
constexpr int kExitUsage = 2;

/// A refused command line, config or mesh: printed, exit 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Options {
  bool headless = false;
  bool window = false;  // --window: insist on a window (error when there is no display)
  int frames = -1;      // headless: default 120; windowed: run until closed
  std::string out = "out";
  std::string path = "forest";
  int shotEvery = 0;  // 0: first and last frame only
  bool smokeTest = false;
  bool validation = false;
  world::AppSettings settings;
  std::string meshPath;
};

std::string usage() {
  std::string paths;
  for (const auto& p : world::pathNames()) paths += (paths.empty() ? "" : ", ") + p;
  return "usage: csm_flythrough [--headless --frames N --out DIR] [--path NAME] [--shot-every K]\n"
         "                      [--config FILE.json] [--set key=value ...] [--mesh FILE]\n"
         "                      [--validation] [--window] [--smoke-test]\n"
         "  --path: one of " +
         paths +
         "\n"
         "  --mesh: an OBJ, PLY or OFF file placed near the town\n"
         "settings (--set key=value, or keys of the --config JSON object):\n" +
         world::settingsHelp();
}

int parseInt(const std::string& flag, const std::string& v, int lo, int hi) {
  // The whole text as a decimal integer: no blanks, no exponent, no trailing text.
  long n = 0;
  const auto r = std::from_chars(v.data(), v.data() + v.size(), n);
  if (r.ec == std::errc() && r.ptr == v.data() + v.size() && n >= lo && n <= hi) {
    return static_cast<int>(n);
  }
  throw UsageError(flag + " = '" + v + "' is invalid: allowed an integer in [" +
                   std::to_string(lo) + ", " + std::to_string(hi) + "]");
}

Options parse(int argc, char** argv) {
  Options o;
  std::vector<std::string> sets;
  std::string config;
  bool haveConfig = false;
  std::vector<std::string> seen;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    // Every flag but --set once: a second --frames or --out is a mistake, not an override.
    if (a.rfind("--", 0) == 0 && a != "--set") {
      if (std::find(seen.begin(), seen.end(), a) != seen.end()) {
        throw UsageError(a + " is given twice: allowed once (--set may repeat)");
      }
      seen.push_back(a);
    }
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError(a + " needs a value");
      std::string v = argv[++i];
      if (v.empty()) throw UsageError(a + " = '' is invalid: the value is empty");
      return v;
    };
    if (a == "--headless") {
      o.headless = true;
    } else if (a == "--window") {
      o.window = true;
    } else if (a == "--frames") {
      o.frames = parseInt(a, value(), 1, 1000000);
    } else if (a == "--out") {
      o.out = value();
    } else if (a == "--path") {
      o.path = value();
      const auto& names = world::pathNames();
      if (std::find(names.begin(), names.end(), o.path) == names.end()) {
        std::string all;
        for (const auto& p : names) all += (all.empty() ? "" : ", ") + p;
        throw UsageError("--path = '" + o.path + "' is invalid: allowed one of " + all);
      }
    } else if (a == "--shot-every") {
      o.shotEvery = parseInt(a, value(), 1, 1000000);
    } else if (a == "--config") {
      config = value();
      haveConfig = true;
    } else if (a == "--set") {
      sets.push_back(value());
    } else if (a == "--mesh") {
      o.meshPath = value();
    } else if (a == "--validation") {
      o.validation = true;
    } else if (a == "--smoke-test") {
      o.smokeTest = true;
    } else if (a == "--help" || a == "-h") {
      std::printf("%s", usage().c_str());
      std::exit(0);
    } else {
      throw UsageError("unknown argument '" + a +
                       "': allowed --headless, --window, --frames, --out, --path, --shot-every, "
                       "--config, --set, --mesh, --validation, --smoke-test, --help");
    }
  }
  // The config file first, then --set in order: the command line wins.
  if (haveConfig) {
    if (auto e = world::loadConfig(o.settings, config)) throw UsageError(*e);
  }
  for (const std::string& s : sets) {
    const auto eq = s.find('=');
    if (eq == std::string::npos) throw UsageError("--set '" + s + "': expected key=value");
    if (auto e = world::setSetting(o.settings, s.substr(0, eq), s.substr(eq + 1))) {
      throw UsageError("--set: " + *e);
    }
  }
  if (auto e = world::validateSettings(o.settings)) throw UsageError(*e);
  // The mesh file is read and checked now, so that a bad file exits 2 before the device and
  // the world are touched (generateWorld reads it again: a second read of a checked file).
  if (!o.meshPath.empty()) {
    world::WorldError err;
    if (!world::loadMeshFile(o.meshPath, o.settings.world.userMeshSizeM, &err)) {
      throw UsageError(err.message);
    }
  }
  return o;
}

json finiteOrNull(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

/// Fraction of geometry pixels (grey in the shadow-factor debug view; the sky is blue) whose
/// shadow factor is below one half.
std::pair<double, double> shadowedFraction(const engine::CpuImage& img) {
  std::uint64_t geometry = 0, shadowed = 0;
  for (std::uint32_t y = 0; y < img.height; ++y) {
    for (std::uint32_t x = 0; x < img.width; ++x) {
      const auto p = img.at(x, y);
      if (std::abs(int(p[0]) - int(p[1])) > 2 || std::abs(int(p[1]) - int(p[2])) > 2) continue;
      ++geometry;
      if (p[0] < 128) ++shadowed;
    }
  }
  const double total = double(img.width) * img.height;
  return {geometry ? double(shadowed) / double(geometry) : 0.0, double(geometry) / total};
}

/// Keeps the current ImGui window inside the display (after any resize, down to 1x1): moved so
/// that its top-left corner is on screen and as much of it as fits is visible.
void keepOnScreen() {
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  const ImVec2 pos = ImGui::GetWindowPos(), size = ImGui::GetWindowSize();
  const ImVec2 clamped(std::clamp(pos.x, 0.0f, std::max(0.0f, display.x - size.x)),
                       std::clamp(pos.y, 0.0f, std::max(0.0f, display.y - size.y)));
  if (clamped.x != pos.x || clamped.y != pos.y) ImGui::SetWindowPos(clamped);
}

/// The per-cascade statistics window of the overlay (also in the windowed panel).
void cascadeStatsWindow(const world::FrameStats& st, const engine::GpuTimer& timer,
                        const std::map<std::string, double>& gpu, double cpuFrameMs,
                        std::uint64_t validationMessages, bool pinned) {
  if (pinned) {
    ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_Always);
    ImGui::SetNextWindowBgAlpha(0.6f);
  }
  ImGui::Begin("Cascades", nullptr,
               pinned ? ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize
                      : ImGuiWindowFlags_AlwaysAutoResize);
  auto gpuMs = [&](const std::string& k) {
    auto it = gpu.find(k);
    return it == gpu.end() ? 0.0 : it->second;
  };
  ImGui::Text("frame: cpu %.2f ms (setup %.2f, cull %.2f, record %.2f)", cpuFrameMs, st.cpuSetupMs,
              st.cpuCullMs, st.cpuRecordMs);
  ImGui::Text("gpu: shadow %.2f ms, lit %.2f ms, overlay %.2f ms%s", gpuMs("shadow"), gpuMs("lit"),
              gpuMs("overlay"), timer.supported() ? "" : " (no timestamps)");
  if (!pinned) keepOnScreen();
  ImGui::Text("validation messages: %llu   lit: %u instances, %.2f Mtri",
              static_cast<unsigned long long>(validationMessages), st.litInstances,
              st.litTriangles * 1e-6);
  if (ImGui::BeginTable("c", 8, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingFixedFit)) {
    for (const char* h :
         {"#", "split (m)", "radius m", "texel m", "casters", "tris", "lod", "gpu ms"}) {
      ImGui::TableSetupColumn(h);
    }
    ImGui::TableHeadersRow();
    for (std::uint32_t c = 0; c < st.cascadeCount; ++c) {
      const csm::Cascade& cs = st.cascades.cascades[c];
      const glm::vec3 t = csm::cascadeTint(static_cast<int>(c));
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextColored(ImVec4(t.r, t.g, t.b, 1.0f), "%u%s", c, cs.empty ? " (empty)" : "");
      ImGui::TableNextColumn();
      ImGui::Text("%.1f-%.1f", cs.splitNearM, cs.splitFarM);
      ImGui::TableNextColumn();
      ImGui::Text("%.1f", cs.sphereRadiusM);
      ImGui::TableNextColumn();
      ImGui::Text("%.3f", cs.texelSizeM());
      ImGui::TableNextColumn();
      ImGui::Text("%u", st.casters[c]);
      ImGui::TableNextColumn();
      ImGui::Text("%llu", static_cast<unsigned long long>(st.triangles[c]));
      ImGui::TableNextColumn();
      ImGui::Text("%u", st.lod[c]);
      ImGui::TableNextColumn();
      ImGui::Text("%.2f", gpuMs("shadow c" + std::to_string(c)));
    }
    ImGui::EndTable();
  }
  ImGui::End();
}

json cascadesJson(const world::FrameStats& st) {
  json arr = json::array();
  for (std::uint32_t c = 0; c < st.cascadeCount; ++c) {
    const csm::Cascade& cs = st.cascades.cascades[c];
    arr.push_back({{"split_near_m", cs.splitNearM},
                   {"split_far_m", cs.splitFarM},
                   {"sphere_radius_m", cs.sphereRadiusM},
                   {"texel_m", cs.texelSizeM()},
                   {"empty", cs.empty},
                   {"lod", st.lod[c]},
                   {"casters", st.casters[c]},
                   {"triangles", st.triangles[c]},
                   {"texels_rendered", st.texelsRendered[c]},
                   {"lag_frames", st.lagFrames[c]}});
  }
  return arr;
}

world::World makeWorld(const Options& o, const std::string& pathName) {
  world::WorldDesc desc = o.settings.world;
  desc.originWs = world::pathWorldOrigin(pathName, desc.sizeM);
  desc.userMeshPath = o.meshPath;
  world::WorldError err;
  const auto t0 = Clock::now();
  std::optional<world::World> w = world::generateWorld(desc, &err);
  if (!w) throw UsageError(err.message);
  std::printf(
      "world: seed %llu, %zu objects (%u trees, %u rocks, %u buildings), %zu caster "
      "clusters, generated in %.2f s\n",
      static_cast<unsigned long long>(desc.seed), w->objects.size(),
      w->kindCounts[static_cast<int>(world::Kind::kTree)],
      w->kindCounts[static_cast<int>(world::Kind::kRock)],
      w->kindCounts[static_cast<int>(world::Kind::kBuilding)], w->clusters.size(),
      std::chrono::duration<double>(Clock::now() - t0).count());
  return std::move(*w);
}

void poseCamera(engine::Camera& cam, const world::CameraPose& pose, double aspect,
                const world::AppSettings& s) {
  cam.positionWs = pose.positionWs;
  cam.setYawPitchRoll(pose.yawRad, pose.pitchRad);
  cam.fovYRad = glm::radians(pose.fovDeg);
  cam.aspect = aspect;
  cam.nearM = 0.5;
  cam.farM = s.farM;
}

// ---- Headless
// ------------------------------------------------------------------------------------

int runHeadless(const Options& o, const std::string& why) {
  if (!why.empty()) std::printf("%s\n", why.c_str());
  const int frames = o.frames > 0 ? o.frames : 120;
  // Order: the output folder is checked (nothing created), then the device is found, and only
  // then the folder is created and locked and the world built: no driver, no side effects.
  if (auto e = world::checkOutputDir(o.out)) throw UsageError(*e);
  engine::ContextDesc desc;
  desc.appName = "csm_flythrough";
  desc.validation = o.validation;
  engine::Context ctx(desc);
  world::OutputDirLock lock;
  if (auto e = lock.acquire(o.out)) throw UsageError(*e);
  const world::World w = makeWorld(o, o.path);
  const std::optional<world::FlightPath> path =
      world::FlightPath::make(o.path, w, o.settings.fovDeg);
  auto writePng = [](const std::string& file, const engine::CpuImage& img) {
    if (auto e = world::writePngAtomically(file, img)) throw std::runtime_error(*e);
  };
  std::printf("device: %s, validation %s, %ux%u, %d frames along '%s'\n",
              ctx.properties().deviceName, ctx.validationEnabled() ? "on" : "off", o.settings.width,
              o.settings.height, frames, o.path.c_str());
  json report;
  std::vector<json> framesJson, shots;
  {
    engine::HeadlessTarget target(ctx,
                                  {{o.settings.width, o.settings.height}, VK_FORMAT_D32_SFLOAT});
    world::WorldRenderer renderer(ctx, w, target.colorFormat(), target.depthFormat());
    if (auto e = renderer.apply(o.settings)) throw UsageError(*e);
    engine::GpuTimer timer(ctx, 32);
    ImGuiLayer imgui(ctx, target.colorFormat(), nullptr);
    const double aspect = double(o.settings.width) / double(o.settings.height);

    std::array<int, engine::kFramesInFlight> owner{};
    owner.fill(-1);
    std::vector<std::map<std::string, double>> gpuByFrame(static_cast<std::size_t>(frames));
    auto takeGpu = [&](std::uint32_t slot) {
      if (owner[slot] >= 0) gpuByFrame[static_cast<std::size_t>(owner[slot])] = timer.results();
      owner[slot] = -1;
    };
    std::map<std::string, double> lastGpu;
    world::FrameStats lastStats;
    double lastCpuFrameMs = 0.0;

    // Renders the prepared frame once more (a screenshot variant), not counted in the report.
    auto renderVariant = [&](bool overlay, csm::DebugMode debug, world::FrameStats stats) {
      world::AppSettings s = o.settings;
      s.debug = debug;
      if (auto e = renderer.apply(s)) throw std::runtime_error(*e);
      std::optional<engine::Frame> f = target.beginFrame();
      if (!f) throw std::runtime_error("headless target gave no frame");
      timer.beginFrame(f->cmd, f->slot);
      takeGpu(f->slot);
      renderer.record(*f, timer, overlay, stats);
      if (overlay) {
        // An auto-sized ImGui window is measured in its first frame and drawn from the second.
        for (int warm = 0; warm < 2; ++warm) {
          if (warm == 1) imgui.endFrame();
          imgui.newFrame(f->extent, 1.0 / 30.0);
          cascadeStatsWindow(lastStats, timer, lastGpu, lastCpuFrameMs,
                             engine::validationMessageCount(), true);
        }
        imgui.endFrame();
        imgui.record(*f);
      }
      target.endFrame();
      engine::CpuImage img = target.readback();
      if (auto e = renderer.apply(o.settings)) throw std::runtime_error(*e);
      return img;
    };

    auto prev = Clock::now();
    for (int i = 0; i < frames; ++i) {
      const double t = frames > 1 ? double(i) / double(frames - 1) : 0.0;
      engine::Camera cam;
      poseCamera(cam, path->at(t), aspect, o.settings);
      world::FrameStats st;
      const auto cpu0 = Clock::now();
      if (auto e = renderer.prepare(cam, st))
        throw std::runtime_error("frame " + std::to_string(i) + ": " + *e);
      std::optional<engine::Frame> f = target.beginFrame();
      if (!f) throw std::runtime_error("headless target gave no frame");
      timer.beginFrame(f->cmd, f->slot);
      takeGpu(f->slot);
      owner[f->slot] = i;
      renderer.record(*f, timer, false, st);
      const double cpuMs = std::chrono::duration<double, std::milli>(Clock::now() - cpu0).count();
      target.endFrame();
      const auto now = Clock::now();
      const double wallMs = std::chrono::duration<double, std::milli>(now - prev).count();
      prev = now;
      lastStats = st;
      lastCpuFrameMs = cpuMs;
      if (!timer.results().empty()) lastGpu = timer.results();

      json fj = {{"index", i},
                 {"t", t},
                 {"camera_ws", {cam.positionWs.x, cam.positionWs.y, cam.positionWs.z}},
                 {"fov_deg", glm::degrees(cam.fovYRad)},
                 {"cpu_ms",
                  {{"setup", st.cpuSetupMs},
                   {"culling", st.cpuCullMs},
                   {"record", st.cpuRecordMs},
                   {"frame", cpuMs}}},
                 {"wall_ms", wallMs},
                 {"shadow_far_m", st.cascades.shadowFarM},
                 {"lit_instances", st.litInstances},
                 {"lit_triangles", st.litTriangles},
                 {"cascades", cascadesJson(st)},
                 {"validation_messages", engine::validationMessageCount()}};
      framesJson.push_back(std::move(fj));

      const bool shot = (o.shotEvery > 0 ? i % o.shotEvery == 0 : i == 0) || i == frames - 1;
      if (shot) {
        char name[64];
        std::snprintf(name, sizeof(name), "frame_%04d", i);
        const std::string base = (std::filesystem::path(o.out) / name).string();
        engine::CpuImage plain = target.readback();
        writePng(base + ".png", plain);
        const engine::CpuImage shadowView = renderVariant(false, csm::DebugMode::kShadowFactor, st);
        const auto [fraction, coverage] = shadowedFraction(shadowView);
        writePng(base + "_shadow.png", shadowView);
        const engine::CpuImage overlayImg = renderVariant(true, o.settings.debug, st);
        writePng(base + "_overlay.png", overlayImg);
        shots.push_back({{"frame", i},
                         {"file", std::string(name) + ".png"},
                         {"overlay_file", std::string(name) + "_overlay.png"},
                         {"shadow_file", std::string(name) + "_shadow.png"},
                         {"shadowed_fraction", fraction},
                         {"geometry_coverage", coverage}});
        prev = Clock::now();
        framesJson.back()["screenshot"] = true;
      }
    }
    target.waitIdle();
    for (std::uint32_t s = 0; s < engine::kFramesInFlight; ++s) {
      if (owner[s] >= 0) {
        timer.collect(s);
        takeGpu(s);
      }
    }
    for (int i = 0; i < frames; ++i) {
      json g = json::object();
      for (const auto& [k, v] : gpuByFrame[static_cast<std::size_t>(i)]) g[k] = finiteOrNull(v);
      // Every pass has a number (0 for a pass that did not run, e.g. an empty cascade).
      for (const char* k : {"shadow", "lit"}) {
        if (!g.contains(k)) g[k] = 0.0;
      }
      framesJson[static_cast<std::size_t>(i)]["gpu_ms"] = g;
    }

    // Summary: means over the frames that were not followed by screenshot renders.
    // With no such frame (--frames 1 or 2, --shot-every 1) every mean is null, not 0.
    int measured = 0;
    for (const json& f : framesJson) measured += f.contains("screenshot") ? 0 : 1;
    auto mean = [&](auto get) -> json {
      double sum = 0.0;
      int n = 0;
      for (const json& f : framesJson) {
        if (f.contains("screenshot")) continue;
        sum += get(f);
        ++n;
      }
      return n ? json(sum / n) : json(nullptr);
    };
    json summary = {
        {"cpu_setup_ms", mean([](const json& f) { return f["cpu_ms"]["setup"].get<double>(); })},
        {"cpu_culling_ms",
         mean([](const json& f) { return f["cpu_ms"]["culling"].get<double>(); })},
        {"cpu_record_ms", mean([](const json& f) { return f["cpu_ms"]["record"].get<double>(); })},
        {"gpu_shadow_ms", mean([](const json& f) { return f["gpu_ms"]["shadow"].get<double>(); })},
        {"gpu_lit_ms", mean([](const json& f) { return f["gpu_ms"]["lit"].get<double>(); })},
        {"wall_frame_ms", mean([](const json& f) { return f["wall_ms"].get<double>(); })},
    };
    // Medians over the frames after the first (the cache's first frame renders everything).
    auto median = [&](auto get) {
      std::vector<double> v;
      for (std::size_t i = 1; i < framesJson.size(); ++i) {
        if (!framesJson[i].contains("screenshot")) v.push_back(get(framesJson[i]));
      }
      if (v.empty()) return 0.0;
      std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
      return v[v.size() / 2];
    };
    summary["shadow_cache"] = o.settings.shadowCache;
    summary["shadow_cache_bytes"] = lastStats.cacheBytes;
    summary["shadow_cache_budget_texels"] = o.settings.cacheBudgetTexels;
    summary["gpu_shadow_ms_median"] =
        median([](const json& f) { return f["gpu_ms"]["shadow"].get<double>(); });
    for (std::uint32_t c = 0; c < o.settings.shadow.cascadeCount; ++c) {
      const std::string k = "shadow c" + std::to_string(c);
      summary["gpu_" + k + "_ms_median"] = median([&](const json& f) {
        return f["gpu_ms"].contains(k) ? f["gpu_ms"][k].get<double>() : 0.0;
      });
      summary["texels_rendered_c" + std::to_string(c) + "_median"] = median([&](const json& f) {
        return f["cascades"].size() > c ? f["cascades"][c]["texels_rendered"].get<double>() : 0.0;
      });
      summary["triangles_c" + std::to_string(c) + "_median"] = median([&](const json& f) {
        return f["cascades"].size() > c ? f["cascades"][c]["triangles"].get<double>() : 0.0;
      });
      summary["texels_rendered_c" + std::to_string(c)] = mean([&](const json& f) {
        return f["cascades"].size() > c ? f["cascades"][c]["texels_rendered"].get<double>() : 0.0;
      });
      summary["gpu_" + k + "_ms"] = mean([&](const json& f) {
        return f["gpu_ms"].contains(k) ? f["gpu_ms"][k].get<double>() : 0.0;
      });
      summary["triangles_c" + std::to_string(c)] = mean([&](const json& f) {
        return f["cascades"].size() > c ? f["cascades"][c]["triangles"].get<double>() : 0.0;
      });
    }
    summary["measured_frames"] = measured;
    report["summary"] = summary;
    json lodTris = json::array();
    for (std::uint32_t l = 0; l < world::kLodCount; ++l)
      lodTris.push_back(renderer.clusterTriangles(l));
    json kinds = json::object();
    for (std::uint32_t k = 0; k < world::kKindCount; ++k) {
      kinds[world::kindName(static_cast<world::Kind>(k))] = w.kindCounts[k];
    }
    std::uint32_t noCast = 0, noReceive = 0;
    for (const world::Object& ob : w.objects)
      noCast += ob.casts ? 0 : 1, noReceive += ob.receives ? 0 : 1;
    char hash[32];
    std::snprintf(hash, sizeof(hash), "%016llx",
                  static_cast<unsigned long long>(world::worldHash(w)));
    report["world"] = {{"seed", w.desc.seed},
                       {"size_m", w.desc.sizeM},
                       {"origin_ws", {w.desc.originWs.x, w.desc.originWs.y, w.desc.originWs.z}},
                       {"hash", hash},
                       {"objects", w.objects.size()},
                       {"objects_by_kind", kinds},
                       {"objects_not_casting", noCast},
                       {"objects_not_receiving", noReceive},
                       {"caster_clusters", w.clusters.size()},
                       {"caster_triangles_by_lod", lodTris},
                       {"user_mesh", o.meshPath}};
  }
  ctx.shutdown();
  const engine::ValidationCounts counts = engine::validationCounts();
  report["app"] = "csm_flythrough";
  report["device"] = ctx.properties().deviceName;
  report["path"] = o.path;
  report["frames"] = frames;
  report["view"] = {{"width", o.settings.width}, {"height", o.settings.height}};
  report["settings"] = world::settingsJson(o.settings);
  report["validation"] = {{"enabled", ctx.validationEnabled()},
                          {"messages", counts.warnings + counts.errors},
                          {"warnings", counts.warnings},
                          {"errors", counts.errors}};
  report["screenshots"] = shots;
  report["per_frame"] = framesJson;
  const std::string reportPath = (std::filesystem::path(o.out) / "report.json").string();
  if (auto e = world::writeFileAtomically(reportPath, report.dump(1) + "\n")) {
    throw std::runtime_error(*e);
  }
  const json& sm = report["summary"];
  if (sm["measured_frames"].get<int>() == 0) {
    std::printf(
        "mean per frame: no measured frames (every frame was followed by screenshot renders; use "
        "--frames 3 or more and --shot-every 2 or more)\n");
  } else {
    std::printf(
        "mean per frame (%d measured frames): cpu setup %.3f ms, culling %.3f ms, record %.3f ms; "
        "gpu shadow %.2f ms, lit %.2f ms; wall %.1f ms\n",
        sm["measured_frames"].get<int>(), sm["cpu_setup_ms"].get<double>(),
        sm["cpu_culling_ms"].get<double>(), sm["cpu_record_ms"].get<double>(),
        sm["gpu_shadow_ms"].get<double>(), sm["gpu_lit_ms"].get<double>(),
        sm["wall_frame_ms"].get<double>());
  }
  std::printf("screenshots and report: %s (report.json, frame_*.png, frame_*_overlay.png)\n",
              std::filesystem::absolute(o.out).string().c_str());
  std::printf("validation messages: %llu\n",
              static_cast<unsigned long long>(counts.warnings + counts.errors));
  return counts.warnings + counts.errors == 0 ? 0 : 1;
}

// ---- Windowed
// ------------------------------------------------------------------------------------

struct Input {
  double scroll = 0.0;
  world::KeyState keys;
};
Input* gInput = nullptr;
void onScroll(GLFWwindow*, double, double dy) {
  if (gInput) gInput->scroll += dy;
}
// Installed before ImGui, which chains to it: every press and release is seen, however short.
void onKey(GLFWwindow*, int key, int, int action, int) {
  if (gInput) gInput->keys.event(key, action != GLFW_RELEASE);
}
void onFocus(GLFWwindow*, int focused) {
  if (gInput && !focused) gInput->keys.releaseAll();
}

bool settingsPanel(world::AppSettings& s, const std::string& error) {
  bool changed = false;
  ImGui::SetNextWindowPos(ImVec2(8, 200), ImGuiCond_FirstUseEver);
  ImGui::Begin("Settings", nullptr, ImGuiWindowFlags_AlwaysAutoResize);
  float az = static_cast<float>(s.lightAzimuthDeg), el = static_cast<float>(s.lightElevationDeg);
  changed |= ImGui::SliderFloat("light azimuth", &az, 0.0f, 360.0f);
  changed |= ImGui::SliderFloat("light elevation", &el, 1.0f, 90.0f);
  s.lightAzimuthDeg = az;
  s.lightElevationDeg = el;
  int cascades = static_cast<int>(s.shadow.cascadeCount);
  changed |= ImGui::SliderInt("cascades", &cascades, 1, static_cast<int>(csm::kMaxCascades));
  s.shadow.cascadeCount = static_cast<std::uint32_t>(cascades);
  static const int kRes[] = {256, 512, 1024, 2048, 4096, 8192};
  int resIndex = 0;
  for (int k = 0; k < 6; ++k) {
    if (kRes[k] == static_cast<int>(s.shadow.resolution)) resIndex = k;
  }
  changed |= ImGui::Combo("resolution", &resIndex,
                          "256\0"
                          "512\0"
                          "1024\0"
                          "2048\0"
                          "4096\0"
                          "8192\0");
  s.shadow.resolution = static_cast<std::uint32_t>(kRes[resIndex]);
  changed |= world::enumCombo("split scheme", s.scheme, world::kAllSplitSchemes, world::schemeKey);
  float lambda = static_cast<float>(s.shadow.splitLambda);
  changed |= ImGui::SliderFloat("split lambda", &lambda, 0.0f, 1.0f);
  s.shadow.splitLambda = lambda;
  float dist = static_cast<float>(s.shadow.shadowDistanceM);
  changed |= ImGui::SliderFloat("shadow distance", &dist, 20.0f, 6000.0f, "%.0f m");
  s.shadow.shadowDistanceM = dist;
  float blend = static_cast<float>(s.shadow.blendBand);
  changed |= ImGui::SliderFloat("blend band", &blend, 0.0f, 0.5f);
  s.shadow.blendBand = blend;
  changed |= world::enumCombo("PCF kernel", s.kernel, csm::kAllKernels, csm::kernelName);
  float lightAngle = static_cast<float>(s.shadow.lightAngularDiameterDeg);
  changed |= ImGui::SliderFloat("light angle (PCSS)", &lightAngle, 0.0f, 20.0f, "%.2f deg");
  s.shadow.lightAngularDiameterDeg = lightAngle;
  float maxPenumbra = static_cast<float>(s.shadow.maxPenumbraM);
  changed |= ImGui::SliderFloat("max penumbra (PCSS)", &maxPenumbra, 0.0f, 10.0f, "%.2f m");
  s.shadow.maxPenumbraM = maxPenumbra;
  changed |= ImGui::SliderFloat("bias constant", &s.shadow.depthBiasConstant, 0.0f, 20.0f);
  changed |= ImGui::SliderFloat("bias slope", &s.shadow.depthBiasSlope, 0.0f, 10.0f);
  changed |=
      ImGui::SliderFloat("normal offset", &s.shadow.normalOffsetTexels, 0.0f, 4.0f, "%.2f texels");
  changed |= ImGui::SliderFloat("ambient", &s.ambient, 0.0f, 1.0f);
  changed |= ImGui::Checkbox("stabilise", &s.shadow.stabilize);
  changed |= ImGui::Checkbox("size ladder", &s.shadow.sizeLadder);
  bool tight = s.shadow.boxFit == csm::BoxFit::kTight;
  if (ImGui::Checkbox("tight box", &tight)) {
    s.shadow.boxFit = tight ? csm::BoxFit::kTight : csm::BoxFit::kSphere;
    changed = true;
  }
  changed |= ImGui::Checkbox("receiver splits", &s.receiverSplits);
  changed |= ImGui::Checkbox("caster LODs", &s.casterLods);
  // One row: the label, then one narrow slider per cascade, each after the previous with the
  // default spacing (SameLine(-1) placed them at x = -1, over the checkbox).
  ImGui::BeginDisabled(!s.casterLods);
  ImGui::TextUnformatted("LOD per cascade");
  for (std::uint32_t c = 0; c < s.shadow.cascadeCount; ++c) {
    int lod = static_cast<int>(s.cascadeLod[c]);
    ImGui::SameLine();
    ImGui::PushID(static_cast<int>(c));
    ImGui::SetNextItemWidth(ImGui::GetFontSize() * 2.5f);
    changed |= ImGui::SliderInt("##lod", &lod, 0, 2);
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("cascade %u draws LOD %d", c, lod);
    ImGui::PopID();
    s.cascadeLod[c] = static_cast<std::uint32_t>(lod);
  }
  ImGui::EndDisabled();
  changed |= ImGui::SliderFloat("LOD max error", &s.lodMaxErrorTexels, 0.0f, 4.0f, "%.2f texels");
  changed |= world::enumCombo("debug output", s.debug, csm::kAllDebugModes, csm::debugModeName);
  changed |= ImGui::Checkbox("overlay (F1)", &s.overlay);
  ImGui::SameLine();
  changed |= ImGui::Checkbox("tint", &s.overlayTint);
  ImGui::SameLine();
  changed |= ImGui::Checkbox("texels", &s.overlayChecker);
  ImGui::SameLine();
  changed |= ImGui::Checkbox("maps", &s.overlayThumbnails);
  ImGui::SameLine();
  changed |= ImGui::Checkbox("top-down", &s.overlayMap);
  if (!error.empty()) ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "%s", error.c_str());
  ImGui::TextDisabled(
      "LMB rotate, RMB pan, wheel zoom, WASD/QE fly, Shift fast, R reset, ESC quit");
  keepOnScreen();
  ImGui::End();
  return changed;
}

int runWindowed(Options o) {
  engine::ContextDesc desc;
  desc.appName = "csm_flythrough";
  desc.validation = o.validation;
  engine::WindowTarget::prepareContext(desc);
  engine::Context ctx(desc);  // no device: found before the world is built
  const world::World w = makeWorld(o, o.path);
  const std::optional<world::FlightPath> path =
      world::FlightPath::make(o.path, w, o.settings.fovDeg);
  std::printf("device: %s, validation %s\n", ctx.properties().deviceName,
              ctx.validationEnabled() ? "on" : "off");
  {
    engine::WindowTarget target(
        ctx, engine::WindowDesc{"csm_flythrough", int(o.settings.width), int(o.settings.height),
                                true, VK_FORMAT_D32_SFLOAT});
    Input input;
    gInput = &input;
    glfwSetScrollCallback(target.window(), onScroll);  // before ImGui, which chains to them
    glfwSetKeyCallback(target.window(), onKey);
    glfwSetWindowFocusCallback(target.window(), onFocus);
    world::WorldRenderer renderer(ctx, w, target.colorFormat(), target.depthFormat());
    if (auto e = renderer.apply(o.settings)) throw UsageError(*e);
    engine::GpuTimer timer(ctx, 32);
    ImGuiLayer imgui(ctx, target.colorFormat(), target.window());
    world::AppSettings live = o.settings;
    std::string error;

    const world::CameraPose start = path->at(0.0);
    glm::dvec3 pos = start.positionWs;
    double yaw = start.yawRad, pitch = start.pitchRad;
    double lastX = 0, lastY = 0;
    glfwGetCursorPos(target.window(), &lastX, &lastY);
    std::uint32_t generation = target.swapchainGeneration();
    world::FrameStats st;
    std::map<std::string, double> gpu;
    double cpuFrameMs = 0.0;
    int rendered = 0, attempts = 0;
    auto prev = Clock::now();
    while (!target.shouldClose()) {
      if (o.frames > 0 && (rendered >= o.frames || attempts++ > o.frames * 50)) break;
      target.pollEvents();
      GLFWwindow* win = target.window();
      if (input.keys.active(GLFW_KEY_ESCAPE)) break;
      if (o.smokeTest && o.frames > 0) {
        if (rendered == o.frames / 3)
          glfwSetWindowSize(win, int(o.settings.width) + 160, int(o.settings.height) + 90);
        if (rendered == o.frames / 2 && attempts % 4 == 0) glfwIconifyWindow(win);
        if (rendered == o.frames / 2 && attempts % 4 == 2) glfwRestoreWindow(win);
        // Down to 1x1 and back: the panels must stay on screen (keepOnScreen).
        if (rendered == (2 * o.frames) / 3) glfwSetWindowSize(win, 1, 1);
        if (rendered == (5 * o.frames) / 6)
          glfwSetWindowSize(win, int(o.settings.width), int(o.settings.height));
      }
      const auto now = Clock::now();
      const double dt = std::min(0.25, std::chrono::duration<double>(now - prev).count());
      prev = now;

      // ---- Input (ignored while ImGui wants it) ------------------------------------------------
      const ImGuiIO& io = ImGui::GetIO();
      double x = 0, y = 0;
      glfwGetCursorPos(win, &x, &y);
      const double dx = x - lastX, dy = y - lastY;
      lastX = x;
      lastY = y;
      const double ground = w.heightAt(pos.x, pos.z);
      const double speed = std::max(20.0, 0.8 * (pos.y - ground)) *
                           (input.keys.active(GLFW_KEY_LEFT_SHIFT) ? 5.0 : 1.0);
      engine::Camera cam;
      cam.setYawPitchRoll(yaw, pitch);
      if (!io.WantCaptureMouse) {
        if (glfwGetMouseButton(win, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS) {
          yaw -= dx * 0.004;
          pitch = std::clamp(pitch - dy * 0.004, -1.55, 1.55);
        }
        if (glfwGetMouseButton(win, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS) {
          pos += (-dx * cam.rightWs() + dy * cam.upWs()) * (speed * 0.004);
        }
        pos += cam.forwardWs() * (input.scroll * speed * 0.25);
      }
      input.scroll = 0.0;
      if (!io.WantCaptureKeyboard) {
        // From key events: a tap shorter than a frame still moves the camera for one frame.
        auto key = [&](int k) { return input.keys.active(k) ? 1.0 : 0.0; };
        const glm::dvec3 move = cam.forwardWs() * (key(GLFW_KEY_W) - key(GLFW_KEY_S)) +
                                cam.rightWs() * (key(GLFW_KEY_D) - key(GLFW_KEY_A)) +
                                glm::dvec3(0, 1, 0) * (key(GLFW_KEY_E) - key(GLFW_KEY_Q));
        pos += move * speed * dt;
        if (input.keys.pressed(GLFW_KEY_R)) {
          pos = start.positionWs;
          yaw = start.yawRad;
          pitch = start.pitchRad;
        }
        if (input.keys.pressed(GLFW_KEY_F1)) live.overlay = !live.overlay;
      }
      input.keys.endFrame();

      // ---- UI ----------------------------------------------------------------------------------
      imgui.newFrame(target.extent(), dt);
      const world::AppSettings before = live;
      if (settingsPanel(live, error) || live.overlay != before.overlay) {
        if (auto e = renderer.apply(live)) {
          error = *e;
          live = before;
        } else {
          error.clear();
        }
      }
      if (live.overlay)
        cascadeStatsWindow(st, timer, gpu, cpuFrameMs, engine::validationMessageCount(), false);
      imgui.endFrame();

      std::optional<engine::Frame> f = target.beginFrame();
      if (target.swapchainGeneration() != generation) {
        target.waitIdle();
        imgui.releaseFramebuffers();
        generation = target.swapchainGeneration();
      }
      if (!f) {
        glfwWaitEventsTimeout(0.01);
        continue;
      }
      cam.positionWs = pos;
      cam.setYawPitchRoll(yaw, pitch);
      cam.fovYRad = glm::radians(live.fovDeg);
      cam.aspect = double(f->extent.width) / double(f->extent.height);
      cam.nearM = 0.5;
      cam.farM = live.farM;
      const auto cpu0 = Clock::now();
      timer.beginFrame(f->cmd, f->slot);
      if (!timer.results().empty()) gpu = timer.results();
      if (auto e = renderer.prepare(cam, st)) throw std::runtime_error(*e);
      renderer.record(*f, timer, live.overlay, st);
      imgui.record(*f);
      cpuFrameMs = std::chrono::duration<double, std::milli>(Clock::now() - cpu0).count();
      target.endFrame();
      ++rendered;
    }
    target.waitIdle();
    gInput = nullptr;
    std::printf("frames rendered: %d, swapchain generations: %u\n", rendered,
                target.swapchainGeneration());
    if (o.frames > 0 && rendered < o.frames)
      throw std::runtime_error("could not render all frames");
  }
  ctx.shutdown();
  const engine::ValidationCounts counts = engine::validationCounts();
  std::printf("validation messages: %llu\n",
              static_cast<unsigned long long>(counts.warnings + counts.errors));
  return counts.warnings + counts.errors == 0 ? 0 : 1;
}

int run(int argc, char** argv) {
  Options o;
  try {
    o = parse(argc, argv);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "csm_flythrough: %s\n\n%s", e.what(), usage().c_str());
    return kExitUsage;
  }
  try {
    if (o.headless) return runHeadless(o, "");
    const char* display = std::getenv("DISPLAY");
    const char* wayland = std::getenv("WAYLAND_DISPLAY");
    if ((!display || !*display) && (!wayland || !*wayland)) {
      if (o.window) throw std::runtime_error("--window: no display ($DISPLAY is not set)");
      if (o.out == "out" && o.frames < 0) o.frames = 120;
      return runHeadless(o, "no display ($DISPLAY is not set) and no --headless: running headless");
    }
    return runWindowed(o);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "csm_flythrough: %s\n", e.what());
    return kExitUsage;
  }
}

}  // namespace

int main(int argc, char** argv) {
  return engine::runMain([&] { return run(argc, argv); });
}
