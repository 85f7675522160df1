// csm_flythrough: the headless loop along a named path (screenshots and report.json).
#include "flythrough_app.hpp"

#include <imgui.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "imgui_layer.hpp"
#include "sample_world/output_dir.hpp"

namespace flythrough {

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

}  // namespace flythrough
