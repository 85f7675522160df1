// csm_flythrough: what report.json says of a frame.
#include "flythrough_app.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "sample_world/output_dir.hpp"

namespace flythrough {

json finiteOrNull(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

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

json cascadesJson(const world::FrameStats& st) {
  json arr = json::array();
  for (std::uint32_t c = 0; c < st.cascadeCount; ++c) {
    const csm::Cascade& cs = st.cascades.cascades[c];
    const world::FrameStats::LodRange& lod = st.lod[c];
    // "lod" (the coarsest, as before), "lod_min" and "lod_max": 0 where no cluster was drawn
    // ("lod_clusters" 0).
    arr.push_back({{"split_near_m", cs.splitNearM},
                   {"split_far_m", cs.splitFarM},
                   {"sphere_radius_m", cs.sphereRadiusM},
                   {"texel_m", cs.texelSizeM()},
                   {"empty", cs.empty},
                   {"lod", lod.coarsest},
                   {"lod_min", lod.finest},
                   {"lod_max", lod.coarsest},
                   {"lod_clusters", lod.clusters},
                   {"casters", st.casters[c]},
                   {"triangles", st.triangles[c]},
                   {"texels_rendered", st.texelsRendered[c]},
                   {"moment_texels", st.momentTexels[c]},
                   {"lag_frames", st.lagFrames[c]}});
    // settings.tileMarks: tiles marked (of kTileGridSide^2) by the depth buffer of a few frames
    // ago, when that frame's marks are ready and had this cascade (absent otherwise).
    if (c < st.tilesMarkedFrom) arr.back()["tiles_marked"] = st.tilesMarked[c];
    // settings.shadowTiles: whether the cascade drew only marked tiles, of how many tiles it
    // drew something, and how many its layer holds (absent for a cascade drawn whole).
    if ((st.tilesPartialMask >> c) & 1u) {
      arr.back()["tiles_partial"] = true;
      arr.back()["tiles_drawn"] = st.tilesDrawn[c];
      arr.back()["tiles_held"] = st.tilesHeld[c];
      // settings.tileBudgetTexels: marked tiles left for a later frame (their pixels fell back).
      arr.back()["tiles_deferred"] = st.tilesDeferred[c];
    }
  }
  return arr;
}

json frameJson(int i, double t, const engine::Camera& cam, const world::FrameStats& st,
               double cpuMs) {
  return {{"index", i},
          {"t", t},
          {"camera_ws", {cam.positionWs.x, cam.positionWs.y, cam.positionWs.z}},
          {"fov_deg", glm::degrees(cam.fovYRad)},
          {"cpu_ms",
           {{"setup", st.cpuSetupMs},
            {"culling", st.cpuCullMs},
            {"record", st.cpuRecordMs},
            {"frame", cpuMs}}},
          {"shadow_far_m", st.cascades.shadowFarM},
          {"lit_instances", st.litInstances},
          {"lit_triangles", st.litTriangles},
          {"cascades", cascadesJson(st)},
          {"validation_messages", engine::validationMessageCount()}};
}

void addGpuMs(std::vector<json>& framesJson,
              const std::vector<std::map<std::string, double>>& gpuByFrame) {
  for (std::size_t i = 0; i < framesJson.size(); ++i) {
    json g = json::object();
    for (const auto& [k, v] : gpuByFrame[i]) g[k] = finiteOrNull(v);
    // Every pass has a number (0 for a pass that did not run, e.g. an empty cascade).
    for (const char* k : {"shadow", "lit"}) {
      if (!g.contains(k)) g[k] = 0.0;
    }
    framesJson[i]["gpu_ms"] = g;
  }
}

json summaryJson(const std::vector<json>& framesJson, const world::AppSettings& settings,
                 const world::FrameStats& lastStats) {
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
      {"cpu_culling_ms", mean([](const json& f) { return f["cpu_ms"]["culling"].get<double>(); })},
      {"cpu_record_ms", mean([](const json& f) { return f["cpu_ms"]["record"].get<double>(); })},
      {"gpu_shadow_ms", mean([](const json& f) { return f["gpu_ms"]["shadow"].get<double>(); })},
      {"gpu_lit_ms", mean([](const json& f) { return f["gpu_ms"]["lit"].get<double>(); })},
      {"wall_frame_ms", mean([](const json& f) { return f["wall_ms"].get<double>(); })},
  };
  // Quantiles over the frames after the first (the cache's first frame renders everything),
  // screenshot frames left out: the median, and the 99th percentile (nearest rank) for the worst
  // frames a player notices.
  auto quantile = [&](auto get, double q) {
    std::vector<double> v;
    for (std::size_t i = 1; i < framesJson.size(); ++i) {
      if (!framesJson[i].contains("screenshot")) v.push_back(get(framesJson[i]));
    }
    if (v.empty()) return 0.0;
    const auto k = static_cast<std::size_t>(
        std::min<double>(double(v.size() - 1), std::ceil(q * double(v.size())) - 1.0));
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(k), v.end());
    return v[k];
  };
  auto median = [&](auto get) { return quantile(get, 0.5); };
  auto p99 = [&](auto get) { return quantile(get, 0.99); };
  summary["shadow_cache"] = settings.shadowCache;
  summary["shadow_tiles"] = settings.shadowTiles;
  summary["thin_casters"] = settings.thinCasters;
  summary["shadow_cull_closed"] = settings.shadow.diagnostics.cullClosedCasters;
  summary["thin_widen_texels"] = settings.thinWidenTexels;
  summary["shadow_cache_bytes"] = lastStats.cacheBytes;
  summary["moment_bytes"] = lastStats.momentBytes;
  summary["shadow_cache_budget_texels"] = settings.cacheBudgetTexels;
  summary["shadow_tile_budget_texels"] = settings.tileBudgetTexels;
  summary["gpu_shadow_ms_median"] =
      median([](const json& f) { return f["gpu_ms"]["shadow"].get<double>(); });
  // The whole frame: shadow pass, depth pre-pass or G-buffer pass (0 without them) and lit pass
  // (the deferred lighting pass with view.deferred), per frame.
  auto gpuMs = [](const json& f, const char* k) {
    return f["gpu_ms"].contains(k) ? f["gpu_ms"][k].get<double>() : 0.0;
  };
  summary["gpu_prepass_ms_median"] = median([&](const json& f) { return gpuMs(f, "prepass"); });
  summary["gpu_gbuffer_ms_median"] = median([&](const json& f) { return gpuMs(f, "gbuffer"); });
  summary["gpu_lit_ms_median"] = median([&](const json& f) { return gpuMs(f, "lit"); });
  auto frameMs = [&](const json& f) {
    return gpuMs(f, "shadow") + gpuMs(f, "prepass") + gpuMs(f, "gbuffer") + gpuMs(f, "lit");
  };
  summary["gpu_frame_ms_median"] = median(frameMs);
  summary["wall_frame_ms_median"] =
      median([](const json& f) { return f["wall_ms"].get<double>(); });
  summary["gpu_shadow_ms_p99"] = p99([&](const json& f) { return gpuMs(f, "shadow"); });
  summary["gpu_frame_ms_p99"] = p99(frameMs);
  summary["wall_frame_ms_p99"] = p99([](const json& f) { return f["wall_ms"].get<double>(); });
  for (std::uint32_t c = 0; c < settings.shadow.cascadeCount; ++c) {
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
  return summary;
}

json worldJson(const world::World& w, const world::WorldRenderer& renderer,
               const std::string& meshPath) {
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
  return {{"seed", w.desc.seed},
          {"size_m", w.desc.sizeM},
          {"origin_ws", {w.desc.originWs.x, w.desc.originWs.y, w.desc.originWs.z}},
          {"hash", hash},
          {"objects", w.objects.size()},
          {"objects_by_kind", kinds},
          {"objects_not_casting", noCast},
          {"objects_not_receiving", noReceive},
          {"caster_clusters", w.clusters.size()},
          {"caster_triangles_by_lod", lodTris},
          {"user_mesh", meshPath}};
}

void writeReport(const json& report, const std::string& out) {
  const std::string reportPath = (std::filesystem::path(out) / "report.json").string();
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
              std::filesystem::absolute(out).string().c_str());
  std::printf("validation messages: %llu\n",
              report["validation"]["messages"].get<unsigned long long>());
}

}  // namespace flythrough
