// csm_flythrough: the ImGui panels (per-cascade statistics, live settings).
#include "flythrough_app.hpp"

#include <imgui.h>

#include "csm/names.hpp"
#include "enum_combo.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>

namespace flythrough {

/// Keeps the current ImGui window inside the display (after any resize, down to 1x1): moved so
/// that its top-left corner is on screen and as much of it as fits is visible.
void keepOnScreen() {
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  const ImVec2 pos = ImGui::GetWindowPos(), size = ImGui::GetWindowSize();
  const ImVec2 clamped(std::clamp(pos.x, 0.0f, std::max(0.0f, display.x - size.x)),
                       std::clamp(pos.y, 0.0f, std::max(0.0f, display.y - size.y)));
  if (clamped.x != pos.x || clamped.y != pos.y) ImGui::SetWindowPos(clamped);
}

namespace {

/// "12.34", or "-" where no time was measured (yet): a GPU time absent from the timer's results.
std::string msText(const std::optional<double>& ms) {
  if (!ms) return "-";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.2f", *ms);
  return buf;
}

/// A count in three or four characters: 812, 33.5k, 1.16M.
std::string countText(std::uint64_t n) {
  char buf[32];
  if (n < 1000) {
    std::snprintf(buf, sizeof(buf), "%llu", static_cast<unsigned long long>(n));
  } else if (n < 1000000) {
    std::snprintf(buf, sizeof(buf), "%.1fk", double(n) * 1e-3);
  } else {
    std::snprintf(buf, sizeof(buf), "%.2fM", double(n) * 1e-6);
  }
  return buf;
}

/// Metres with one decimal below 100 m, whole metres above.
std::string metresText(double m) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), m < 100.0 ? "%.1f" : "%.0f", m);
  return buf;
}

/// "-" (no cluster drawn), "1" (one LOD) or "0-2" (finest-coarsest).
std::string lodText(const world::FrameStats::LodRange& lod) {
  if (lod.clusters == 0) return "-";
  if (lod.finest == lod.coarsest) return std::to_string(lod.finest);
  return std::to_string(lod.finest) + "-" + std::to_string(lod.coarsest);
}

}  // namespace

std::optional<double> gpuScopeMs(const std::map<std::string, double>& gpu,
                                 const std::string& scope) {
  const auto it = gpu.find(scope);
  if (it == gpu.end() || !std::isfinite(it->second)) return std::nullopt;
  return it->second;
}

/// The per-cascade statistics window of the overlay (also in the windowed panel): compact, in the
/// font ImGuiLayer sized for the view, with tight spacing scaled alike.
StatsPanel cascadeStatsWindow(const world::FrameStats& st, const engine::GpuTimer& timer,
                              const std::map<std::string, double>& gpu, double cpuFrameMs,
                              std::uint64_t validationMessages, bool pinned) {
  StatsPanel shown;
  const float k = ImGui::GetFontSize() / 13.0f;
  if (pinned) {
    ImGui::SetNextWindowPos(ImVec2(4.0f * k, 4.0f * k), ImGuiCond_Always);
    ImGui::SetNextWindowBgAlpha(0.75f);
  }
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(4.0f * k, 3.0f * k));
  ImGui::PushStyleVar(ImGuiStyleVar_ItemSpacing, ImVec2(6.0f * k, 1.0f * k));
  ImGui::PushStyleVar(ImGuiStyleVar_CellPadding, ImVec2(3.0f * k, 0.0f));
  ImGui::Begin("Cascades", nullptr,
               pinned ? ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize
                      : ImGuiWindowFlags_AlwaysAutoResize);
  auto gpuMs = [&](const std::string& scope) {
    const std::optional<double> ms = gpuScopeMs(gpu, scope);
    shown.gpuMs[scope] = ms;
    return msText(ms);
  };
  ImGui::Text("cpu %.1f ms (setup %.1f, cull %.1f, record %.1f)", cpuFrameMs, st.cpuSetupMs,
              st.cpuCullMs, st.cpuRecordMs);
  ImGui::Text("gpu ms: shadow %s, lit %s, overlay %s%s", gpuMs("shadow").c_str(),
              gpuMs("lit").c_str(), gpuMs("overlay").c_str(),
              timer.supported() ? "" : " (no timestamps)");
  if (!pinned) keepOnScreen();
  ImGui::Text("lit %u inst, %.2f Mtri; validation msgs %llu", st.litInstances,
              st.litTriangles * 1e-6, static_cast<unsigned long long>(validationMessages));
  if (ImGui::BeginTable("c", 8, ImGuiTableFlags_BordersInnerV | ImGuiTableFlags_SizingFixedFit)) {
    for (const char* h : {"#", "split m", "r m", "texel m", "cast", "tris", "lod", "gpu ms"}) {
      ImGui::TableSetupColumn(h);
    }
    ImGui::TableHeadersRow();
    for (std::uint32_t c = 0; c < st.cascadeCount; ++c) {
      const csm::Cascade& cs = st.cascades.cascades[c];
      const glm::vec3 t = csm::cascadeTint(static_cast<int>(c));
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextColored(ImVec4(t.r, t.g, t.b, 1.0f), "%u%s", c, cs.empty ? " empty" : "");
      ImGui::TableNextColumn();
      ImGui::Text("%s-%s", metresText(cs.splitNearM).c_str(), metresText(cs.splitFarM).c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(metresText(cs.sphereRadiusM).c_str());
      ImGui::TableNextColumn();
      ImGui::Text("%.3f", cs.texelSizeM());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(countText(st.casters[c]).c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(countText(st.triangles[c]).c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(lodText(st.lod[c]).c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(gpuMs("shadow c" + std::to_string(c)).c_str());
    }
    ImGui::EndTable();
  }
  const ImVec2 pos = ImGui::GetWindowPos(), size = ImGui::GetWindowSize();
  shown.x = pos.x;
  shown.y = pos.y;
  shown.width = size.x;
  shown.height = size.y;
  shown.fontPixels = ImGui::GetFontSize();
  ImGui::End();
  ImGui::PopStyleVar(3);
  return shown;
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
  // A quality tier sets cascades, resolution and kernel below (the other settings stay). The
  // menu names the tier those three hold now, or "custom" when no tier matches them.
  const std::optional<csm::Preset> current = world::matchingPreset(s);
  if (ImGui::BeginCombo("preset", current ? csm::presetName(*current) : "custom")) {
    for (const csm::Preset p : csm::kAllPresets) {
      const bool selected = current == p;
      if (ImGui::Selectable(csm::presetName(p), selected) && !selected) {
        changed = true;
        (void)world::setSetting(s, "preset", csm::presetName(p));
      }
      if (selected) ImGui::SetItemDefaultFocus();
    }
    ImGui::EndCombo();
  }
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
  changed |= world::enumCombo("Filter", s.shadow.kernel, csm::kAllFilters, csm::kernelName);
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
  changed |= ImGui::Checkbox("stabilise", &s.shadow.diagnostics.stabilize);
  changed |= ImGui::Checkbox("size ladder", &s.shadow.diagnostics.sizeLadder);
  bool tight = s.shadow.boxFit == csm::BoxFit::kTight;
  if (ImGui::Checkbox("tight box", &tight)) {
    s.shadow.boxFit = tight ? csm::BoxFit::kTight : csm::BoxFit::kSphere;
    changed = true;
  }
  changed |= ImGui::Checkbox("receiver splits", &s.receiverSplits);
  changed |= ImGui::Checkbox("thin casters widened", &s.thinCasters);
  changed |= ImGui::Checkbox("cull closed casters", &s.shadow.diagnostics.cullClosedCasters);
  changed |= ImGui::Checkbox("caster LODs", &s.casterLods);
  changed |= ImGui::Checkbox("depth pre-pass", &s.depthPrepass);
  changed |= ImGui::Checkbox("deferred shading", &s.deferred);
  changed |= ImGui::Checkbox("cull back faces", &s.cullBackFaces);
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

}  // namespace flythrough
