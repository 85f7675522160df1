// csm_flythrough: the command line, the --config file and --set overrides.
#include "flythrough_app.hpp"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "sample_world/output_dir.hpp"

namespace flythrough {

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

namespace {

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

}  // namespace

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
  // The config file first, then --set in order: the command line wins. A --set preset=NAME
  // goes before the other --set values, wherever it is, so that they go on top of it.
  if (haveConfig) {
    if (auto e = world::loadConfig(o.settings, config)) throw UsageError(*e);
  }
  std::stable_partition(sets.begin(), sets.end(),
                        [](const std::string& s) { return s.rfind("preset=", 0) == 0; });
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
    std::fprintf(stderr, "mesh: reading and checking %s\n", o.meshPath.c_str());
    world::WorldError err;
    if (!world::loadMeshFile(o.meshPath, o.settings.world.userMeshSizeM, &err)) {
      throw UsageError(err.message);
    }
  }
  return o;
}

}  // namespace flythrough
