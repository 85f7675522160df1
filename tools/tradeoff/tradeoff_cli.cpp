// csm_tradeoff: the command line.
#include "tradeoff.hpp"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <stdexcept>
#include <string>

namespace tradeoff {

void usage(std::FILE* out) {
  std::fprintf(
      out,
      "usage: csm_tradeoff [--quick] [--path NAME] [--out DIR] [--budget-ms X]... [--replot] "
      "[--width W --height H] [--lod-study] [--presets] [--timing-rounds N]\n"
      "                    [--fit-study [--fit-resolution N]]\n"
      "  --presets: only the module's presets (low, medium, high, ultra: csm::presetConfig).\n"
      "  --lod-study: only the default configuration, with per-cascade caster LOD schedules "
      "(0122 .. 0000) and without LODs.\n"
      "  --timing-rounds N: time every configuration N times in interleaved rounds and report "
      "the\n  median (default 1).\n"
      "  --budget-ms X (repeatable): recommend the most accurate configuration whose GPU ms "
      "fits X.\n"
      "  --replot: re-draw table, plot and recommendations from DIR/tradeoff.csv, no "
      "measuring.\n"
      "  --fit-study: sphere vs tight box x full range vs receiver-driven splits on the zoom "
      "path\n  at 8 degrees and the forest path at 60 degrees; writes DIR/fit_study.json.\n"
      "  --fit-resolution N: the fit study's shadow maps N x N (a power of two in [256, "
      "16384];\n  default the fly-through's 2048).\n"
      "  sweeps cascades 1..6 x resolution 512..8192 x caster LODs on/off, then split "
      "lambda,\n  filter (every kernel and prefiltered filter), blend band and depth format around "
      "the\n  defaults; writes "
      "DIR/tradeoff.csv and\n  DIR/tradeoff.png (Pareto front of GPU ms vs "
      "misclassification, defaults marked).\n"
      "  full mode: 5 poses, 640x360 timing view, 320x180 accuracy view (about 10 min "
      "on 2-core lavapipe);\n  --quick: 2 poses, 320x180 / 240x135, fewer counts "
      "and resolutions,\n  no prefiltered filters (under a minute).\n  paths:");
  for (const std::string& n : world::pathNames()) std::fprintf(out, " %s", n.c_str());
  std::fprintf(out, "\n");
}

namespace {

// A whole decimal number, all of `v`; nothing when it is not one (or out of long's range).
std::optional<long> wholeNumber(const std::string& v) {
  char* end = nullptr;
  errno = 0;
  const long n = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0' || errno == ERANGE) return std::nullopt;
  return n;
}

}  // namespace

std::optional<int> parseArgs(int argc, char** argv, Options& o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--quick") {
      o.quick = true;
    } else if (a == "--replot") {
      o.replot = true;
    } else if (a == "--fit-study") {
      o.fitStudy = true;
    } else if (a == "--path") {
      o.path = next();
    } else if (a == "--out") {
      o.out = next();
    } else if (a == "--budget-ms") {
      o.budgetsMs.push_back(std::stod(next()));
    } else if (a == "--width") {
      o.width = uint32_t(std::stoul(next()));
    } else if (a == "--height") {
      o.height = uint32_t(std::stoul(next()));
    } else if (a == "--lod-study") {
      o.lodStudy = true;
    } else if (a == "--presets") {
      o.presets = true;
    } else if (a == "--timing-rounds") {
      const std::string v = next();
      const std::optional<int> n = parseTimingRounds(v);
      if (!n) {
        std::fprintf(stderr, "--timing-rounds %s is invalid: allowed an integer in [1, 20]\n",
                     v.c_str());
        return 2;
      }
      o.timingRounds = *n;
    } else if (a == "--fit-resolution") {
      // The module's own check of ShadowSettings::resolution decides what is allowed.
      const std::string v = next();
      const std::optional<long> n = wholeNumber(v);
      csm::ShadowSettings s;
      s.resolution = n && *n > 0 && *n <= long(csm::kMaxResolution) ? uint32_t(*n) : 0u;
      if (const std::optional<csm::ValidationError> e = csm::validate(s)) {
        std::fprintf(stderr, "--fit-resolution %s is invalid: allowed %s\n", v.c_str(),
                     e->allowed.c_str());
        return 2;
      }
      o.fitResolution = s.resolution;
    } else if (a == "--help" || a == "-h") {
      usage(stdout);
      return 0;
    } else {
      usage(stderr);
      return 2;
    }
  }
  if (o.quick) {
    o.width = 320;
    o.height = 180;
  }
  return std::nullopt;
}

}  // namespace tradeoff
