// The cascade math demo: prints, for one camera and light, each cascade's split range, sphere,
// texel size, light matrix and how many casters of a random scene it draws.
//   build/bin/csm_cascades [--flag value]...   (--help lists the flags)
// Bad flags print the allowed values and exit with status 2.
#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <string_view>

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
};

void printUsage(std::FILE* out) {
  std::fprintf(
      out,
      "usage: csm_cascades [options]\n"
      "  --pos X,Y,Z            camera position in metres (any finite values; default 0,30,0)\n"
      "  --yaw DEG              camera yaw about +Y (default 30)\n"
      "  --pitch DEG            camera pitch, [-90, 90] (default -10)\n"
      "  --fov DEG              vertical field of view, (0, 180) (default 60)\n"
      "  --aspect A             width / height, (0, 1e4] (default 1.7778)\n"
      "  --near M --far M       camera planes, 0 < near < far (default 0.1, 5000)\n"
      "  --light-az DEG         light azimuth (default 35)\n"
      "  --light-el DEG         light elevation above the horizon, [-90, 90] (default 50)\n"
      "  --cascades N           cascade count, 1..8 (default 4)\n"
      "  --resolution R         power of two in [256, 16384] (default 2048)\n"
      "  --lambda L             split lambda, [0, 1] (default 0.75)\n"
      "  --shadow-distance M    > near (default 400)\n"
      "  --blend B              blend band, [0, 0.5] (default 0.1)\n"
      "  --min-texels T         drop casters under T texels, [0, 1e6] (default 0 = off)\n"
      "  --unstable             tight fit without snapping (comparison mode)\n"
      "  --casters N            random casters in the scene, [0, 10000000] (default 20000)\n"
      "  --scene-half M         half width of the random scene, (0, 1e7] (default 2000)\n"
      "  --seed S               random seed, a non-negative integer (default 1)\n");
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
      o.settings.stabilize = false;
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
        xyz[k] = parseNumber("--pos", std::string_view(s).substr(start, comma - start), -kHuge,
                             kHuge, "finite coordinates X,Y,Z");
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
      o.camera.nearM = parseNumber(flag, v, 1e-300, kHuge, "metres > 0");
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
      o.settings.shadowDistanceM = parseNumber(flag, v, 1e-300, kHuge, "metres > near");
    } else if (flag == "--blend") {
      o.settings.blendBand = parseNumber(flag, v, 0, 0.5, "a fraction in [0, 0.5]");
    } else if (flag == "--min-texels") {
      o.settings.minCasterTexels =
          static_cast<float>(parseNumber(flag, v, 0, 1e6, "texels in [0, 1e6]"));
    } else if (flag == "--casters") {
      o.casters = parseInteger(flag, v, 0, 10000000, "an integer in [0, 10000000]");
    } else if (flag == "--scene-half") {
      o.sceneHalfM = parseNumber(flag, v, 1e-9, 1e7, "metres in (0, 1e7]");
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

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  const double az = glm::radians(o.lightAzimuthDeg), el = glm::radians(o.lightElevationDeg);
  const csm::DirectionalLight light{
      {-std::cos(el) * std::cos(az), -std::sin(el), -std::cos(el) * std::sin(az)}};

  // A random scene around the camera: spheres and boxes on the ground 30 m below it.
  const glm::dvec3 c = o.camera.positionWs;
  const csm::AabbWs scene{c + glm::dvec3(-o.sceneHalfM, -100.0, -o.sceneHalfM),
                          c + glm::dvec3(o.sceneHalfM, 100.0, o.sceneHalfM)};
  csm::CascadeHistory history;
  const auto t0 = std::chrono::steady_clock::now();
  auto result = csm::computeCascades(o.settings, o.camera, light, &scene, &history);
  const auto t1 = std::chrono::steady_clock::now();
  if (!result.ok()) {
    std::fprintf(stderr, "csm_cascades: %s\n\n", result.error().message().c_str());
    printUsage(stderr);
    return kUsageError;
  }
  const csm::CascadeFrame& f = result.value();

  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> pos(-o.sceneHalfM, o.sceneHalfM), size(0.2, 8.0);
  csm::CasterSet casters;
  casters.reserve(o.casters);
  for (std::uint64_t i = 0; i < o.casters; ++i) {
    const glm::dvec3 p = c + glm::dvec3(pos(rng), size(rng) - 30.0, pos(rng));  // y: ground + size
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

  std::printf("camera (%.3f, %.3f, %.3f) forward (%.3f, %.3f, %.3f); light (%.3f, %.3f, %.3f)\n",
              c.x, c.y, c.z, f.cameraForwardWs.x, f.cameraForwardWs.y, f.cameraForwardWs.z,
              f.lightDirectionWs.x, f.lightDirectionWs.y, f.lightDirectionWs.z);
  std::printf("%u cascades of %u^2, %s, shadows end at %.3f m (shadow distance %.3f m)\n",
              f.cascadeCount, f.resolution, o.settings.stabilize ? "stabilised" : "unstabilised",
              f.shadowFarM, o.settings.shadowDistanceM);
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
    std::printf("  texel %.6f m; casters drawn %zu of %zu\n", k.texelSizeM(),
                cull.visible[i].size(), casters.size());
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
