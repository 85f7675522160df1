// csm_flythrough: the open-world sample. Windowed (GLFW + Dear ImGui panel, mouse and keyboard
// flight) when a display is present, or headless along a named spline path, writing PNG
// screenshots (with and without the cascade-visualisation overlay) and DIR/report.json.
// Exit codes: 0 success, 1 runtime error or validation messages, 2 invalid arguments, settings
// or mesh file, 3 no Vulkan device.
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>

#include "flythrough_app.hpp"

namespace flythrough {

world::World makeWorld(const Options& o, const std::string& pathName) {
  world::WorldDesc desc = o.settings.world;
  desc.originWs = world::pathWorldOrigin(pathName, desc.sizeM);
  desc.userMeshPath = o.meshPath;
  world::WorldError err;
  const auto t0 = Clock::now();
  // Progress on stderr: generation takes seconds (a large --mesh, minutes).
  const world::Progress progress = [&](const std::string& step) {
    std::fprintf(stderr, "world: %6.1f s  %s\n",
                 std::chrono::duration<double>(Clock::now() - t0).count(), step.c_str());
  };
  std::optional<world::World> w = world::generateWorld(desc, &err, progress);
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

}  // namespace flythrough

int main(int argc, char** argv) {
  return engine::runMain([&] { return flythrough::run(argc, argv); });
}
