// The cascade math demo: prints, for one camera and light, each cascade's split range, sphere,
// texel size, light matrix and how many casters of a random scene it draws.
//   build/bin/csm_cascades [--flag value]...   (--help lists the flags)
// Bad flags print the allowed values and exit with status 2.
//   --json                  every cascade with full precision (for checking the rungs)
//   --zoom FROM,TO,FRAMES   a field-of-view sweep through one history, one JSON frame per step
#include <nlohmann/json.hpp>

#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "csm/core.hpp"

namespace {

constexpr int kUsageError = 2;

struct Options {
  csm::ShadowSettings settings;
  csm::Camera camera;
  double yawDeg = 30.0, pitchDeg = -10.0;
  double lightAzimuthDeg = 35.0, lightElevationDeg = 50.0;
  std::uint64_t casters = 20000;
  std::uint64_t seed = 1;
  double sceneHalfM = 2000.0;
  bool json = false;
  /// --zoom: field of view from, to (degrees) over frames frames (0 = no zoom).
  double zoomFromDeg = 0.0, zoomToDeg = 0.0;
  std::uint64_t zoomFrames = 0;
  /// --receivers: the visible receivers' view-depth range.
  bool haveReceivers = false;
  csm::ReceiverDepthRange receivers;
};

void printUsage(std::FILE* out) {
  std::fprintf(
      out,
      "usage: csm_cascades [options]\n"
      "  --pos X,Y,Z            camera position in metres, each in [-1e9, 1e9] (default 0,30,0)\n"
      "  --yaw DEG              camera yaw about +Y (default 30)\n"
      "  --pitch DEG            camera pitch, [-90, 90] (default -10)\n"
      "  --fov DEG              vertical field of view, (0, 180) (default 60)\n"
      "  --aspect A             width / height, (0, 1e4] (default 1.7778)\n"
      "  --near M --far M       camera planes, 1e-6 <= near < far <= 1e10 near (default 0.1, "
      "5000)\n"
      "  --light-az DEG         light azimuth (default 35)\n"
      "  --light-el DEG         light elevation above the horizon, [-90, 90] (default 50)\n"
      "  --cascades N           cascade count, 1..8 (default 4)\n"
      "  --resolution R         power of two in [256, 16384] (default 2048)\n"
      "  --lambda L             split lambda, [0, 1] (default 0.75)\n"
      "  --shadow-distance M    > near, <= 1e9 (default 400)\n"
      "  --blend B              blend band, [0, 0.5] (default 0.1)\n"
      "  --min-texels T         drop casters under T texels, [0, 1e6] (default 0 = off)\n"
      "  --unstable             tight fit without snapping (comparison mode)\n"
      "  --casters N            random casters in the scene, [0, 10000000] (default 20000)\n"
      "  --scene-half M         half width of the random scene, (0, 1e7] (default 2000)\n"
      "  --seed S               random seed, a non-negative integer (default 1)\n"
      "  --no-ladder            sizes follow their inputs continuously (comparison mode)\n"
      "  --ladder-steps N       ladder rungs per doubling, [1, 64] (default 8)\n"
      "  --hysteresis H         ladder hysteresis in rungs, [0, 8] (default 1)\n"
      "  --box-fit sphere|tight box around the slice's sphere or its light-space extent\n"
      "  --light-step DEG       light direction steps, [0, 10] degrees (default 0 = exact)\n"
      "  --receivers MIN,MAX    visible receivers' view depths, 0 <= MIN <= MAX (metres):\n"
      "                         receiver-driven splits, as a depth reduction would give them\n"
      "  --receiver-margin F    widening of that range per side, [0, 1] (default 0.15)\n"
      "  --json                 print every cascade as JSON with full precision\n"
      "  --zoom FROM,TO,FRAMES  sweep the field of view FROM -> TO degrees, each in (0, 180),\n"
      "                         over FRAMES in [2, 100000] frames through one history; JSON\n");
}

[[noreturn]] void usageError(const std::string& message) {
  std::fprintf(stderr, "csm_cascades: %s\n\n", message.c_str());
  printUsage(stderr);
  std::exit(kUsageError);
}

double parseNumber(std::string_view flag, std::string_view text, double lo, double hi,
                   const char* range) {
  double v = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || !(v >= lo && v <= hi)) {
    usageError(std::string(flag) + " = '" + std::string(text) + "' is invalid: allowed " + range);
  }
  return v;
}

std::uint64_t parseInteger(std::string_view flag, std::string_view text, std::uint64_t lo,
                           std::uint64_t hi, const char* range) {
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || v < lo || v > hi) {
    usageError(std::string(flag) + " = '" + std::string(text) + "' is invalid: allowed " + range);
  }
  return v;
}

// "a,b,c" -> its `count` parts; anything else is a usage error naming the flag.
std::vector<std::string_view> splitList(std::string_view flag, std::string_view text,
                                        std::size_t count, const char* form) {
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    parts.push_back(text.substr(start, comma == std::string_view::npos ? comma : comma - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (parts.size() != count) {
    usageError(std::string(flag) + " = '" + std::string(text) + "' is invalid: allowed " + form);
  }
  return parts;
}

Options parse(int argc, char** argv) {
  Options o;
  o.camera.positionWs = {0.0, 30.0, 0.0};
  constexpr double kHuge = 1e300;
  for (int i = 1; i < argc; ++i) {
    const std::string_view flag = argv[i];
    if (flag == "--help" || flag == "-h") {
      printUsage(stdout);
      std::exit(0);
    }
    if (flag == "--unstable") {
      o.settings.diagnostics.stabilize = false;
      continue;
    }
    if (flag == "--no-ladder") {
      o.settings.diagnostics.sizeLadder = false;
      continue;
    }
    if (flag == "--json") {
      o.json = true;
      continue;
    }
    if (i + 1 >= argc) usageError(std::string(flag) + " needs a value (or is unknown)");
    const std::string_view v = argv[++i];
    if (flag == "--pos") {
      std::string s(v);
      double xyz[3];
      std::size_t start = 0;
      for (int k = 0; k < 3; ++k) {
        const std::size_t comma = s.find(',', start);
        if ((k < 2) != (comma != std::string::npos)) usageError("--pos needs X,Y,Z");
        xyz[k] = parseNumber("--pos", std::string_view(s).substr(start, comma - start),
                             -csm::kMaxWorldCoordinateM, csm::kMaxWorldCoordinateM,
                             "coordinates X,Y,Z in [-1e9, 1e9] metres (csm::kMaxWorldCoordinateM)");
        start = comma + 1;
      }
      o.camera.positionWs = {xyz[0], xyz[1], xyz[2]};
    } else if (flag == "--yaw") {
      o.yawDeg = parseNumber(flag, v, -kHuge, kHuge, "a finite angle in degrees");
    } else if (flag == "--pitch") {
      o.pitchDeg = parseNumber(flag, v, -90, 90, "degrees in [-90, 90]");
    } else if (flag == "--fov") {
      o.camera.fovYRad =
          glm::radians(parseNumber(flag, v, 1e-9, 180 - 1e-9, "degrees in (0, 180)"));
    } else if (flag == "--aspect") {
      o.camera.aspect = parseNumber(flag, v, 1e-12, 1e4, "a ratio in (0, 1e4]");
    } else if (flag == "--near") {
      o.camera.nearM = parseNumber(flag, v, csm::kMinNearM, csm::kMaxWorldCoordinateM,
                                   "metres in [1e-6, 1e9] (csm::kMinNearM)");
    } else if (flag == "--far") {
      o.camera.farM = parseNumber(flag, v, 1e-300, kHuge, "metres > near");
    } else if (flag == "--light-az") {
      o.lightAzimuthDeg = parseNumber(flag, v, -kHuge, kHuge, "a finite angle in degrees");
    } else if (flag == "--light-el") {
      o.lightElevationDeg = parseNumber(flag, v, -90, 90, "degrees in [-90, 90]");
    } else if (flag == "--cascades") {
      o.settings.cascadeCount = static_cast<std::uint32_t>(
          parseInteger(flag, v, 1, csm::kMaxCascades, "an integer in [1, 8]"));
    } else if (flag == "--resolution") {
      o.settings.resolution = static_cast<std::uint32_t>(
          parseInteger(flag, v, 0, 1u << 20, "a power of two in [256, 16384]"));
    } else if (flag == "--lambda") {
      o.settings.splitLambda = parseNumber(flag, v, 0, 1, "a number in [0, 1]");
    } else if (flag == "--shadow-distance") {
      o.settings.shadowDistanceM =
          parseNumber(flag, v, 1e-300, csm::kMaxWorldCoordinateM, "metres > near, <= 1e9");
    } else if (flag == "--blend") {
      o.settings.blendBand = parseNumber(flag, v, 0, 0.5, "a fraction in [0, 0.5]");
    } else if (flag == "--min-texels") {
      o.settings.minCasterTexels =
          static_cast<float>(parseNumber(flag, v, 0, 1e6, "texels in [0, 1e6]"));
    } else if (flag == "--casters") {
      o.casters = parseInteger(flag, v, 0, 10000000, "an integer in [0, 10000000]");
    } else if (flag == "--scene-half") {
      o.sceneHalfM = parseNumber(flag, v, 1e-9, 1e7, "metres in (0, 1e7]");
    } else if (flag == "--ladder-steps") {
      o.settings.ladderStepsPerOctave =
          parseNumber(flag, v, 1, 64, "rungs per doubling in [1, 64]");
    } else if (flag == "--hysteresis") {
      o.settings.ladderHysteresisSteps = parseNumber(flag, v, 0, 8, "rungs in [0, 8]");
    } else if (flag == "--box-fit") {
      if (v == "sphere") {
        o.settings.boxFit = csm::BoxFit::kSphere;
      } else if (v == "tight") {
        o.settings.boxFit = csm::BoxFit::kTight;
      } else {
        usageError("--box-fit = '" + std::string(v) + "' is invalid: allowed sphere or tight");
      }
    } else if (flag == "--light-step") {
      o.settings.lightStepDeg = parseNumber(flag, v, 0, 10, "degrees in [0, 10]");
    } else if (flag == "--receiver-margin") {
      o.settings.receiverDepthMargin = parseNumber(flag, v, 0, 1, "a fraction in [0, 1]");
    } else if (flag == "--receivers") {
      const std::vector<std::string_view> parts = splitList(flag, v, 2, "MIN,MAX");
      o.receivers.minM = parseNumber(flag, parts[0], 0, kHuge, "MIN,MAX with 0 <= MIN <= MAX");
      o.receivers.maxM =
          parseNumber(flag, parts[1], o.receivers.minM, kHuge, "MIN,MAX with 0 <= MIN <= MAX");
      o.haveReceivers = true;
    } else if (flag == "--zoom") {
      const std::vector<std::string_view> parts = splitList(flag, v, 3, "FROM,TO,FRAMES");
      o.zoomFromDeg = parseNumber(flag, parts[0], 1e-9, 180 - 1e-9, "FROM,TO in (0, 180) degrees");
      o.zoomToDeg = parseNumber(flag, parts[1], 1e-9, 180 - 1e-9, "FROM,TO in (0, 180) degrees");
      o.zoomFrames = parseInteger(flag, parts[2], 2, 100000, "FRAMES an integer in [2, 100000]");
    } else if (flag == "--seed") {
      o.seed = parseInteger(flag, v, 0, UINT64_MAX, "a non-negative integer");
    } else {
      usageError("unknown flag " + std::string(flag));
    }
  }
  o.camera.orientationWs = glm::angleAxis(glm::radians(o.yawDeg), glm::dvec3(0, 1, 0)) *
                           glm::angleAxis(glm::radians(o.pitchDeg), glm::dvec3(1, 0, 0));
  return o;
}

nlohmann::json rungJson(int rung) {
  return rung == csm::kNoRung ? nlohmann::json(nullptr) : nlohmann::json(rung);
}

nlohmann::json vec3Json(const glm::dvec3& v) {
  return {v.x, v.y, v.z};
}

// One cascade with full precision (JSON numbers are printed round-trip exact).
nlohmann::json cascadeJson(const csm::Cascade& k, const Options& o, std::uint32_t index) {
  nlohmann::json j;
  j["index"] = index;
  j["empty"] = k.empty;
  j["split_near_m"] = k.splitNearM;
  j["split_far_m"] = k.splitFarM;
  j["sphere_center_ws"] = vec3Json(k.sphereCenterWs);
  j["sphere_radius_m"] = k.sphereRadiusM;
  j["box_center_ws"] = vec3Json(k.boxCenterWs);
  j["half_extent_ls"] = {k.halfExtentLs.x, k.halfExtentLs.y};
  j["needed_half_extent_m"] = k.neededHalfExtentM;
  j["ladder_area_ratio"] =
      k.neededHalfExtentM > 0.0
          ? (k.halfExtentLs.x * k.halfExtentLs.y) / (k.neededHalfExtentM * k.neededHalfExtentM)
          : 1.0;
  j["texel_size_m"] = k.texelSizeM();
  j["fit"] = !o.settings.diagnostics.stabilize ? "unstabilised" : (k.tightFit ? "tight" : "sphere");
  j["size_rung"] = rungJson(k.sizeRung);
  j["depth_rung"] = rungJson(k.depthRung);
  j["split_far_rung"] = rungJson(k.splitFarRung);
  j["size_rung_changed"] = k.sizeRungChanged;
  j["depth_near_ls"] = k.depthNearLs;
  j["depth_far_ls"] = k.depthFarLs;
  nlohmann::json m = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    m.push_back({k.viewProjCr[0][r], k.viewProjCr[1][r], k.viewProjCr[2][r], k.viewProjCr[3][r]});
  }
  j["view_proj_cr_rows"] = m;
  return j;
}

nlohmann::json frameJson(const csm::CascadeFrame& f, const Options& o, const csm::Camera& cam) {
  nlohmann::json j;
  j["camera"] = {{"position_ws", vec3Json(cam.positionWs)},
                 {"forward_ws", vec3Json(f.cameraForwardWs)},
                 {"fov_y_deg", glm::degrees(cam.fovYRad)},
                 {"aspect", cam.aspect},
                 {"near_m", cam.nearM},
                 {"far_m", cam.farM}};
  j["light_direction_ws"] = vec3Json(f.lightDirectionWs);
  j["light_stepped"] = f.lightStepped;
  j["resolution"] = f.resolution;
  j["stabilised"] = o.settings.diagnostics.stabilize;
  j["size_ladder"] = o.settings.diagnostics.stabilize && o.settings.diagnostics.sizeLadder;
  j["ladder_steps_per_octave"] = o.settings.ladderStepsPerOctave;
  j["ladder_hysteresis_steps"] = o.settings.ladderHysteresisSteps;
  j["receiver_driven"] = f.receiverDriven;
  if (o.haveReceivers) j["receivers_m"] = {o.receivers.minM, o.receivers.maxM};
  j["shadow_far_m"] = f.shadowFarM;
  j["splits_m"] = std::vector<double>(f.splitsM.begin(), f.splitsM.begin() + f.cascadeCount + 1);
  for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
    j["cascades"].push_back(cascadeJson(f.cascades[i], o, i));
  }
  return j;
}

nlohmann::json historyJson(const csm::CascadeHistory& h, std::uint32_t count) {
  return {{"frames", h.frames},
          {"size_rung_events",
           std::vector<std::uint32_t>(h.sizeRungEvents.begin(), h.sizeRungEvents.begin() + count)},
          {"split_rung_events",
           std::vector<std::uint32_t>(h.splitRungEvents.begin(),
                                      h.splitRungEvents.begin() + (count > 0 ? count - 1 : 0))},
          {"light_step_events", h.lightStepEvents}};
}

[[noreturn]] void refused(const csm::ValidationError& e) {
  std::fprintf(stderr, "csm_cascades: %s\n\n", e.message().c_str());
  printUsage(stderr);
  std::exit(kUsageError);
}

// --zoom: every frame of a field-of-view sweep through one history, as one JSON document.
int runZoom(const Options& o, const csm::DirectionalLight& light, const csm::AabbWs& scene) {
  csm::CascadeHistory history;
  nlohmann::json out;
  out["zoom_deg"] = {o.zoomFromDeg, o.zoomToDeg};
  for (std::uint64_t f = 0; f < o.zoomFrames; ++f) {
    csm::Camera cam = o.camera;
    const double t = double(f) / double(o.zoomFrames - 1);
    cam.fovYRad = glm::radians(o.zoomFromDeg + (o.zoomToDeg - o.zoomFromDeg) * t);
    auto r = csm::computeCascades(o.settings, cam, light, &scene, &history,
                                  o.haveReceivers ? &o.receivers : nullptr);
    if (!r.ok()) refused(r.error());
    nlohmann::json j = frameJson(r.value(), o, cam);
    j["frame"] = f;
    out["frames"].push_back(std::move(j));
  }
  out["history"] = historyJson(history, o.settings.cascadeCount);
  std::printf("%s\n", out.dump(1).c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  const double az = glm::radians(o.lightAzimuthDeg), el = glm::radians(o.lightElevationDeg);
  const csm::DirectionalLight light{
      {-std::cos(el) * std::cos(az), -std::sin(el), -std::cos(el) * std::sin(az)}};

  // A random scene around the camera: spheres and boxes on the ground 30 m below it, cut to the
  // domain (csm::kMaxWorldCoordinateM) where the camera is near its edge.
  const glm::dvec3 c = o.camera.positionWs;
  const glm::dvec3 edge(csm::kMaxWorldCoordinateM);
  const csm::AabbWs scene{
      glm::clamp(c + glm::dvec3(-o.sceneHalfM, -100.0, -o.sceneHalfM), -edge, edge),
      glm::clamp(c + glm::dvec3(o.sceneHalfM, 100.0, o.sceneHalfM), -edge, edge)};
  if (o.zoomFrames > 0) return runZoom(o, light, scene);
  csm::CascadeHistory history;
  const auto t0 = std::chrono::steady_clock::now();
  auto result = csm::computeCascades(o.settings, o.camera, light, &scene, &history,
                                     o.haveReceivers ? &o.receivers : nullptr);
  const auto t1 = std::chrono::steady_clock::now();
  if (!result.ok()) refused(result.error());
  const csm::CascadeFrame& f = result.value();

  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> pos(-o.sceneHalfM, o.sceneHalfM), size(0.2, 8.0);
  csm::CasterSet casters;
  casters.reserve(o.casters);
  for (std::uint64_t i = 0; i < o.casters; ++i) {
    const glm::dvec3 p =  // y: ground + size; inside the scene
        glm::clamp(c + glm::dvec3(pos(rng), size(rng) - 30.0, pos(rng)), scene.minWs + 8.0,
                   scene.maxWs - 8.0);
    if (i % 3 == 0) {
      const glm::dvec3 h(size(rng), size(rng), size(rng));
      (void)casters.addBox(p - h, p + h);
    } else {
      (void)casters.addSphere(p, size(rng));
    }
  }
  casters.build();
  csm::CullResult cull;
  const auto t2 = std::chrono::steady_clock::now();
  csm::cullCasters(casters, f, o.settings.minCasterTexels, cull);
  const auto t3 = std::chrono::steady_clock::now();

  if (o.json) {
    nlohmann::json j = frameJson(f, o, o.camera);
    for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
      j["cascades"][i]["casters_drawn"] = cull.visible[i].size();
    }
    j["casters"] = casters.size();
    std::printf("%s\n", j.dump(1).c_str());
    return 0;
  }
  std::printf("camera (%.3f, %.3f, %.3f) forward (%.3f, %.3f, %.3f); light (%.3f, %.3f, %.3f)\n",
              c.x, c.y, c.z, f.cameraForwardWs.x, f.cameraForwardWs.y, f.cameraForwardWs.z,
              f.lightDirectionWs.x, f.lightDirectionWs.y, f.lightDirectionWs.z);
  std::printf("%u cascades of %u^2, %s, shadows end at %.3f m (shadow distance %.3f m)\n",
              f.cascadeCount, f.resolution,
              o.settings.diagnostics.stabilize ? "stabilised" : "unstabilised", f.shadowFarM,
              o.settings.shadowDistanceM);
  for (std::uint32_t i = 0; i < f.cascadeCount; ++i) {
    const csm::Cascade& k = f.cascades[i];
    std::printf("\ncascade %u%s: view depth [%.4f, %.4f) m\n", i, k.empty ? " (empty)" : "",
                k.splitNearM, k.splitFarM);
    std::printf("  sphere centre (%.4f, %.4f, %.4f) radius %.6f m\n", k.sphereCenterWs.x,
                k.sphereCenterWs.y, k.sphereCenterWs.z, k.sphereRadiusM);
    std::printf(
        "  box centre (%.4f, %.4f, %.4f), half extent %.6f x %.6f m, depth [%.3f, %.3f] m\n",
        k.boxCenterWs.x, k.boxCenterWs.y, k.boxCenterWs.z, k.halfExtentLs.x, k.halfExtentLs.y,
        k.depthNearLs, k.depthFarLs);
    std::printf("  texel %.6f m (%s fit, needed half extent %.6f m); casters drawn %zu of %zu\n",
                k.texelSizeM(), k.tightFit ? "tight" : "sphere", k.neededHalfExtentM,
                cull.visible[i].size(), casters.size());
    if (k.sizeRung != csm::kNoRung) {
      std::printf("  ladder rungs: size %d, depth %d, far split %s\n", k.sizeRung, k.depthRung,
                  k.splitFarRung == csm::kNoRung ? "-" : std::to_string(k.splitFarRung).c_str());
    }
    std::printf("  viewProjCr (camera-relative world -> clip, rows):\n");
    for (int r = 0; r < 4; ++r) {
      std::printf("    [% .6e % .6e % .6e % .6e]\n", k.viewProjCr[0][r], k.viewProjCr[1][r],
                  k.viewProjCr[2][r], k.viewProjCr[3][r]);
    }
  }
  const auto us = [](auto a, auto b) {
    return std::chrono::duration<double, std::micro>(b - a).count();
  };
  std::printf("\nsetup %.2f us (first call, cold); culling %.1f us (%llu nodes, %llu tests)\n",
              us(t0, t1), us(t2, t3), static_cast<unsigned long long>(cull.nodesVisited),
              static_cast<unsigned long long>(cull.castersTested));
  return 0;
}
