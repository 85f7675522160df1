// Settings of the fly-through: one table of keys, their parsers and their JSON form.
#include "sample_world/settings.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

#include "csm/names.hpp"

namespace world {

namespace {

// The quality tier (csm::Preset), applied before the other settings.
constexpr const char* kPresetKey = "preset";

using Setter = std::function<std::optional<std::string>(AppSettings&, const std::string&)>;
using Getter = std::function<nlohmann::json(const AppSettings&)>;

struct Entry {
  const char* key;
  const char* allowed;
  Setter set;
  Getter get;
};

// The whole text as one number: no leading blanks, no hex, no trailing text, finite.
std::optional<double> parseNumber(const std::string& v) {
  std::string_view t(v);
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  if (t.empty()) return std::nullopt;
  double d = 0.0;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), d);
  if (r.ec != std::errc() || r.ptr != t.data() + t.size() || !std::isfinite(d)) {
    return std::nullopt;
  }
  return d;
}

// An integer setting: digits parsed exactly (2^53 + 1 is not rounded to 2^53); a number with a
// fraction or exponent only when it is integral and below 2^53 (where doubles are exact).
std::optional<double> parseInteger(const std::string& v) {
  std::string_view t(v);
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  if (t.empty()) return std::nullopt;
  std::int64_t i = 0;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), i);
  if (r.ec == std::errc() && r.ptr == t.data() + t.size()) {
    if (std::abs(i) > (std::int64_t(1) << 53)) return std::nullopt;
    return static_cast<double>(i);
  }
  if (r.ec == std::errc::result_out_of_range) return std::nullopt;
  const std::optional<double> d = parseNumber(v);
  if (!d || std::floor(*d) != *d || std::abs(*d) >= 9007199254740992.0) return std::nullopt;
  return d;
}

std::optional<bool> parseBool(const std::string& v) {
  if (v == "1" || v == "true" || v == "on" || v == "yes") return true;
  if (v == "0" || v == "false" || v == "off" || v == "no") return false;
  return std::nullopt;
}

std::string bad(const char* key, const std::string& value, const char* allowed) {
  std::string out(key);
  out.append(" = '").append(value).append("' is invalid: allowed ").append(allowed);
  return out;
}

// Numeric setting in [lo, hi] (integers when `integer`).
template <class T, class F>
Entry number(const char* key, const char* allowed, double lo, double hi, bool integer, F field) {
  return {key, allowed,
          [=](AppSettings& s, const std::string& v) -> std::optional<std::string> {
            const std::optional<double> d = integer ? parseInteger(v) : parseNumber(v);
            if (!d || !(*d >= lo && *d <= hi) || (integer && std::floor(*d) != *d)) {
              return bad(key, v, allowed);
            }
            field(s) = static_cast<T>(*d);
            return std::nullopt;
          },
          [=](const AppSettings& s) { return nlohmann::json(field(const_cast<AppSettings&>(s))); }};
}

template <class F>
Entry boolean(const char* key, F field) {
  return {key, "true/false (also 1/0, on/off, yes/no)",
          [=](AppSettings& s, const std::string& v) -> std::optional<std::string> {
            const std::optional<bool> b = parseBool(v);
            if (!b) return bad(key, v, "true/false (also 1/0, on/off, yes/no)");
            field(s) = *b;
            return std::nullopt;
          },
          [=](const AppSettings& s) {
            return nlohmann::json(static_cast<bool>(field(const_cast<AppSettings&>(s))));
          }};
}

// A choice among names.
template <class T, std::size_t N, class F>
Entry choice(const char* key, const char* allowed,
             const std::array<std::pair<const char*, T>, N>& names, F field) {
  return {key, allowed,
          [=](AppSettings& s, const std::string& v) -> std::optional<std::string> {
            for (const auto& [name, value] : names) {
              if (v == name) {
                field(s) = value;
                return std::nullopt;
              }
            }
            return bad(key, v, allowed);
          },
          [=](const AppSettings& s) -> nlohmann::json {
            for (const auto& [name, value] : names) {
              if (field(const_cast<AppSettings&>(s)) == value) return name;
            }
            return "?";
          }};
}

// A choice among the module's names (csm/names.hpp): parsed by csm's parser, written by its one
// spelling.
template <class Parse, class Name, class F>
Entry named(const char* key, const char* allowed, Parse parse, Name name, F field) {
  return {key, allowed,
          [=](AppSettings& s, const std::string& v) -> std::optional<std::string> {
            const auto r = parse(v, key);
            if (!r) return bad(key, v, allowed);
            field(s) = r.value();
            return std::nullopt;
          },
          [=](const AppSettings& s) -> nlohmann::json {
            return name(field(const_cast<AppSettings&>(s)));
          }};
}

constexpr std::array<std::pair<const char*, SplitScheme>, 3> kSchemes{{
    {"practical", SplitScheme::kPractical},
    {"uniform", SplitScheme::kUniform},
    {"log", SplitScheme::kLogarithmic},
}};
constexpr std::array<std::pair<const char*, csm::BoxFit>, 2> kBoxFits{
    {{"sphere", csm::BoxFit::kSphere}, {"tight", csm::BoxFit::kTight}}};
constexpr std::array<std::pair<const char*, csm::CacheRestore>, 4> kCacheRestores{
    {{"shadercopy", csm::CacheRestore::kShaderCopy},
     {"redraw", csm::CacheRestore::kRedraw},
     {"copyrects", csm::CacheRestore::kCopyRects},
     {"wholelayer", csm::CacheRestore::kWholeLayer}}};
constexpr std::array<std::pair<const char*, csm::ReceiverSplitScheme>, 2> kReceiverSchemes{
    {{"range", csm::ReceiverSplitScheme::kRange},
     {"histogram", csm::ReceiverSplitScheme::kHistogram}}};

// The depth format by csm's names ("d32", "d16"; parseDepthFormat also takes "D32", "D16").
Entry depthFormatEntry() {
  static const std::string kAllowed = "one of " + csm::depthFormatNames();
  return {
      "shadow.depthFormat", kAllowed.c_str(),
      [](AppSettings& s, const std::string& v) -> std::optional<std::string> {
        const csm::Result<csm::DepthFormat> r = csm::parseDepthFormat(v, "shadow.depthFormat");
        if (!r) return bad("shadow.depthFormat", v, kAllowed.c_str());
        s.depth16 = r.value() == csm::DepthFormat::kD16;
        return std::nullopt;
      },
      [](const AppSettings& s) -> nlohmann::json {
        return csm::depthFormatName(s.depth16 ? csm::DepthFormat::kD16 : csm::DepthFormat::kD32);
      }};
}

const std::vector<Entry>& table() {
  // Kernel names: csm's ("tent3x3"); parseKernel also takes the older "tent3", "tent5", "tent7".
  static const std::string kKernelAllowed = "one of " + csm::kernelNames();
  static const std::string kDebugAllowed = "one of " + csm::debugModeNames();
  static const std::vector<Entry> entries = {
      number<double>("light.azimuth", "a number of degrees in [0, 360]", 0, 360, false,
                     [](AppSettings& s) -> double& { return s.lightAzimuthDeg; }),
      number<double>("light.elevation", "a number of degrees in [1, 90]", 1, 90, false,
                     [](AppSettings& s) -> double& { return s.lightElevationDeg; }),
      number<double>("day.lengthS", "seconds from sunrise to sunset in [10, 86400] (path day)",
                     kMinDayLengthS, kMaxDayLengthS, false,
                     [](AppSettings& s) -> double& { return s.clock.dayLengthS; }),
      number<double>("cut.everyS", "seconds between camera cuts in [0.05, 600] (path cut)",
                     kMinCutEveryS, kMaxCutEveryS, false,
                     [](AppSettings& s) -> double& { return s.clock.cutEveryS; }),
      number<std::uint32_t>("shadow.cascades", "an integer in [1, 8]", 1, csm::kMaxCascades, true,
                            [](AppSettings& s) -> std::uint32_t& { return s.shadow.cascadeCount; }),
      number<std::uint32_t>("shadow.resolution", "a power of two in [256, 16384]", 256, 16384, true,
                            [](AppSettings& s) -> std::uint32_t& { return s.shadow.resolution; }),
      choice("shadow.scheme", "one of practical, uniform, log", kSchemes,
             [](AppSettings& s) -> SplitScheme& { return s.scheme; }),
      number<double>("shadow.lambda", "a number in [0, 1]", 0, 1, false,
                     [](AppSettings& s) -> double& { return s.shadow.splitLambda; }),
      number<double>("shadow.distance", "metres in [1, 100000]", 1, 1e5, false,
                     [](AppSettings& s) -> double& { return s.shadow.shadowDistanceM; }),
      number<double>("shadow.blend", "a fraction in [0, 0.5]", 0, 0.5, false,
                     [](AppSettings& s) -> double& { return s.shadow.blendBand; }),
      number<double>("shadow.fade", "a fraction of the shadow distance in [0, 1] (0: hard cut)", 0,
                     1, false, [](AppSettings& s) -> double& { return s.shadow.fadeFraction; }),
      named("shadow.kernel", kKernelAllowed.c_str(), csm::parseKernel, csm::kernelName,
            [](AppSettings& s) -> csm::PcfKernel& { return s.shadow.kernel; }),
      number<double>("shadow.lightAngleDeg", "degrees in [0, 20] (the sun: 0.53)", 0, 20, false,
                     [](AppSettings& s) -> double& { return s.shadow.lightAngularDiameterDeg; }),
      number<double>("shadow.maxPenumbra", "metres in [0, 100]", 0, 100, false,
                     [](AppSettings& s) -> double& { return s.shadow.maxPenumbraM; }),
      boolean("shadow.worldKernel",
              [](AppSettings& s) -> bool& { return s.shadow.worldSpaceKernel; }),
      // The prefiltered filters (issue 25: shadow.kernel=vsm|evsm|msm).
      number<double>("shadow.momentBlur", "metres in [0, 10]", 0, 10, false,
                     [](AppSettings& s) -> double& { return s.shadow.momentBlurM; }),
      number<float>("shadow.momentBleed", "a fraction in [0, 0.95]", 0, 0.95, false,
                    [](AppSettings& s) -> float& { return s.shadow.momentBleedReduction; }),
      number<float>("shadow.evsmPositive", "an exponent in (0, 42]", 1e-3, CSM_EVSM_MAX_EXPONENT,
                    false, [](AppSettings& s) -> float& { return s.shadow.evsmPositiveExponent; }),
      number<float>("shadow.evsmNegative", "an exponent in (0, 42]", 1e-3, CSM_EVSM_MAX_EXPONENT,
                    false, [](AppSettings& s) -> float& { return s.shadow.evsmNegativeExponent; }),
      number<float>("shadow.msmBias", "a weight in [1e-7, 0.01]", 1e-7, 0.01, false,
                    [](AppSettings& s) -> float& { return s.shadow.msmMomentBias; }),
      number<float>("shadow.biasConstant", "a number in [0, 1000]", 0, 1000, false,
                    [](AppSettings& s) -> float& { return s.shadow.depthBiasConstant; }),
      number<float>("shadow.biasSlope", "a number in [0, 100]", 0, 100, false,
                    [](AppSettings& s) -> float& { return s.shadow.depthBiasSlope; }),
      number<float>("shadow.normalOffset", "texels in [0, 16]", 0, 16, false,
                    [](AppSettings& s) -> float& { return s.shadow.normalOffsetTexels; }),
      boolean("shadow.stabilize",
              [](AppSettings& s) -> bool& { return s.shadow.diagnostics.stabilize; }),
      boolean("shadow.cache", [](AppSettings& s) -> bool& { return s.shadowCache; }),
      boolean("shadow.thinCasters", [](AppSettings& s) -> bool& { return s.thinCasters; }),
      boolean("shadow.cullClosed",
              [](AppSettings& s) -> bool& { return s.shadow.diagnostics.cullClosedCasters; }),
      number<float>("shadow.thinWiden", "texels in [0, 4]", 0, 4, false,
                    [](AppSettings& s) -> float& { return s.thinWidenTexels; }),
      number<std::uint64_t>(
          "shadow.cacheBudgetTexels",
          "an integer in [0, 2^40]: 0 = no cap, else at least shadow.resolution^2", 0,
          1099511627776.0, true,
          [](AppSettings& s) -> std::uint64_t& { return s.cacheBudgetTexels; }),
      // How a cached layer gets its static depth back (a comparison switch: same depth).
      choice(
          "shadow.cacheRestore", "one of shadercopy, redraw, copyrects, wholelayer", kCacheRestores,
          [](AppSettings& s) -> csm::CacheRestore& { return s.shadow.diagnostics.cacheRestore; }),
      number<float>("shadow.minCasterTexels", "texels in [0, 1e6]", 0, 1e6, false,
                    [](AppSettings& s) -> float& { return s.shadow.minCasterTexels; }),
      depthFormatEntry(),
      number<std::uint32_t>("shadow.msmMomentBits", "64 or 128 (bits a texel of msm's moments)", 64,
                            128, true,
                            [](AppSettings& s) -> std::uint32_t& { return s.msmMomentBits; }),
      // The size ladder, the box fit and the stepped sun (issue 10).
      boolean("shadow.ladder",
              [](AppSettings& s) -> bool& { return s.shadow.diagnostics.sizeLadder; }),
      number<double>("shadow.ladderSteps", "rungs per doubling in [1, 64]", 1, 64, false,
                     [](AppSettings& s) -> double& { return s.shadow.ladderStepsPerOctave; }),
      number<double>("shadow.ladderHysteresis", "rungs in [0, 8]", 0, 8, false,
                     [](AppSettings& s) -> double& { return s.shadow.ladderHysteresisSteps; }),
      choice("shadow.boxFit", "one of sphere, tight", kBoxFits,
             [](AppSettings& s) -> csm::BoxFit& { return s.shadow.boxFit; }),
      boolean("shadow.receiverSplits", [](AppSettings& s) -> bool& { return s.receiverSplits; }),
      boolean("shadow.receiverBounds", [](AppSettings& s) -> bool& { return s.receiverBounds; }),
      boolean("shadow.tileMarks", [](AppSettings& s) -> bool& { return s.tileMarks; }),
      boolean("shadow.tiles", [](AppSettings& s) -> bool& { return s.shadowTiles; }),
      number<std::uint64_t>(
          "shadow.tileBudgetTexels",
          "an integer in [0, 2^40]: 0 = no cap, else at least (shadow.resolution / 16)^2", 0,
          1099511627776.0, true,
          [](AppSettings& s) -> std::uint64_t& { return s.tileBudgetTexels; }),
      choice(
          "shadow.receiverSplitScheme", "one of range, histogram", kReceiverSchemes,
          [](AppSettings& s) -> csm::ReceiverSplitScheme& { return s.shadow.receiverSplitScheme; }),
      number<double>("shadow.lightStep", "degrees in [0, 10] (0 = the exact sun)", 0, 10, false,
                     [](AppSettings& s) -> double& { return s.shadow.lightStepDeg; }),
      boolean("lod.enabled", [](AppSettings& s) -> bool& { return s.casterLods; }),
      {"lod.cascades", "comma-separated LOD indices in [0, 2], one per cascade (e.g. 0,1,2,2)",
       [](AppSettings& s, const std::string& v) -> std::optional<std::string> {
         std::array<std::uint32_t, csm::kMaxCascades> lod{};
         std::size_t k = 0;
         std::uint32_t last = 0;
         // Every item between commas must be 0, 1 or 2: "0,1," and ",0" and "0,,1" are refused.
         std::size_t start = 0;
         while (start <= v.size()) {
           const std::size_t comma = std::min(v.find(',', start), v.size());
           const std::string item = v.substr(start, comma - start);
           if (k >= lod.size() || (item != "0" && item != "1" && item != "2")) {
             return bad("lod.cascades", v,
                        "comma-separated LOD indices in [0, 2], at most 8 (e.g. 0,1,2,2)");
           }
           lod[k++] = last = static_cast<std::uint32_t>(item[0] - '0');
           start = comma + 1;
         }
         if (k == 0) return bad("lod.cascades", v, "comma-separated LOD indices in [0, 2]");
         for (; k < lod.size(); ++k) lod[k] = last;  // later cascades keep the last LOD
         s.cascadeLod = lod;
         return std::nullopt;
       },
       [](const AppSettings& s) {
         return nlohmann::json(
             std::vector<std::uint32_t>(s.cascadeLod.begin(), s.cascadeLod.end()));
       }},
      number<float>("lod.maxErrorTexels", "texels in [0, 64] (0 = the lod.cascades schedule alone)",
                    0, 64, false, [](AppSettings& s) -> float& { return s.lodMaxErrorTexels; }),
      number<float>("ambient", "a number in [0, 1]", 0, 1, false,
                    [](AppSettings& s) -> float& { return s.ambient; }),
      named("debug", kDebugAllowed.c_str(), csm::parseDebugMode, csm::debugModeName,
            [](AppSettings& s) -> csm::DebugMode& { return s.debug; }),
      boolean("overlay", [](AppSettings& s) -> bool& { return s.overlay; }),
      boolean("overlay.tint", [](AppSettings& s) -> bool& { return s.overlayTint; }),
      boolean("overlay.checker", [](AppSettings& s) -> bool& { return s.overlayChecker; }),
      boolean("overlay.thumbnails", [](AppSettings& s) -> bool& { return s.overlayThumbnails; }),
      boolean("overlay.map", [](AppSettings& s) -> bool& { return s.overlayMap; }),
      number<std::uint32_t>("view.width", "an integer in [64, 7680]", 64, 7680, true,
                            [](AppSettings& s) -> std::uint32_t& { return s.width; }),
      number<std::uint32_t>("view.height", "an integer in [64, 4320]", 64, 4320, true,
                            [](AppSettings& s) -> std::uint32_t& { return s.height; }),
      boolean("view.depthPrepass", [](AppSettings& s) -> bool& { return s.depthPrepass; }),
      boolean("view.deferred", [](AppSettings& s) -> bool& { return s.deferred; }),
      boolean("view.cullBackFaces", [](AppSettings& s) -> bool& { return s.cullBackFaces; }),
      number<double>("camera.fov", "degrees in [1, 170]", 1, 170, false,
                     [](AppSettings& s) -> double& { return s.fovDeg; }),
      number<double>("camera.far", "metres in [10, 1000000]", 10, 1e6, false,
                     [](AppSettings& s) -> double& { return s.farM; }),
      number<std::uint64_t>("world.seed", "an integer in [0, 2^53]", 0, 9007199254740992.0, true,
                            [](AppSettings& s) -> std::uint64_t& { return s.world.seed; }),
      number<std::uint32_t>("world.trees", "an integer in [0, 500000]", 0, 500000, true,
                            [](AppSettings& s) -> std::uint32_t& { return s.world.treeCount; }),
      number<std::uint32_t>("world.rocks", "an integer in [0, 100000]", 0, 100000, true,
                            [](AppSettings& s) -> std::uint32_t& { return s.world.rockCount; }),
      number<std::uint32_t>("world.buildings", "an integer in [0, 5000]", 0, 5000, true,
                            [](AppSettings& s) -> std::uint32_t& { return s.world.buildingCount; }),
  };
  return entries;
}

}  // namespace

AppSettings::AppSettings() {
  shadow.cascadeCount = 4;
  shadow.resolution = 2048;
  shadow.shadowDistanceM = 1500.0;
  shadow.splitLambda = 0.8;
  // A moving sun changes the maps only every quarter degree (issue 10).
  shadow.lightStepDeg = 0.25;
}

std::optional<csm::Preset> matchingPreset(const AppSettings& s) noexcept {
  for (csm::Preset p : csm::kAllPresets) {
    const csm::PresetConfig c = csm::presetConfig(p, s.shadow);
    if (c.settings.cascadeCount == s.shadow.cascadeCount &&
        c.settings.resolution == s.shadow.resolution && c.settings.kernel == s.shadow.kernel) {
      return p;
    }
  }
  return std::nullopt;
}

std::optional<std::string> setSetting(AppSettings& s, const std::string& key,
                                      const std::string& value) {
  if (key == kPresetKey) {
    const csm::Result<csm::Preset> p = csm::parsePreset(value, kPresetKey);
    if (!p.ok()) return p.error().message();
    const csm::PresetConfig c = csm::presetConfig(p.value(), s.shadow);
    s.preset = p.value();
    s.shadow = c.settings;
    return std::nullopt;
  }
  for (const Entry& e : table()) {
    if (key == e.key) return e.set(s, value);
  }
  std::string keys = kPresetKey;
  for (const Entry& e : table()) {
    keys.append(", ");
    keys.append(e.key);
  }
  return "unknown setting '" + key + "': allowed keys are " + keys;
}

std::optional<std::string> loadConfig(AppSettings& s, const std::string& path) {
  if (path.empty()) return std::string("--config: the path is empty (allowed a JSON file)");
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return "--config " + path + ": " +
           (std::filesystem::exists(path, ec) ? "not a regular file" : "file not found");
  }
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) return "--config " + path + ": cannot read its size (" + ec.message() + ")";
  if (size > kMaxConfigBytes) {
    return "--config " + path + ": the file has " + std::to_string(size) +
           " bytes, allowed at most " + std::to_string(kMaxConfigBytes);
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return "--config " + path + ": cannot open the file";
  std::string text(static_cast<std::size_t>(size), '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  if (in.gcount() != static_cast<std::streamsize>(text.size())) {
    return "--config " + path + ": could not read all " + std::to_string(size) + " bytes";
  }
  return applyConfigText(s, text, "--config " + path);
}

std::optional<std::string> applyConfigText(AppSettings& s, std::string_view text,
                                           const std::string& name) {
  if (text.size() > kMaxConfigBytes) {
    return name + ": " + std::to_string(text.size()) + " bytes, allowed at most " +
           std::to_string(kMaxConfigBytes);
  }
  // Nesting is bounded while parsing (the parser itself is iterative, but nothing deeper than
  // the object of settings and one array is meaningful); duplicate keys are refused, not
  // silently resolved; trailing text after the object is an error (strict parse).
  struct Refusal {
    std::string message;
  };
  std::vector<std::string> keys;
  const nlohmann::json::parser_callback_t limit =
      [&](int depth, nlohmann::json::parse_event_t event, nlohmann::json& parsed) -> bool {
    using E = nlohmann::json::parse_event_t;
    if ((event == E::object_start || event == E::array_start) && depth >= kMaxConfigDepth) {
      throw Refusal{"nesting deeper than the allowed " + std::to_string(kMaxConfigDepth) +
                    " levels (an object of settings, lod.cascades an array)"};
    }
    if (event == E::key && depth == 1) {
      const std::string key = parsed.get<std::string>();
      if (std::find(keys.begin(), keys.end(), key) != keys.end()) {
        throw Refusal{"key '" + key + "' appears twice"};
      }
      keys.push_back(key);
    }
    return true;
  };
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text.begin(), text.end(), limit, /*allow_exceptions=*/true,
                              /*ignore_comments=*/false);
  } catch (const Refusal& r) {
    return name + ": " + r.message;
  } catch (const std::exception& e) {
    return name + ": not valid JSON (" + e.what() + ")";
  }
  if (!j.is_object()) return name + ": must hold a JSON object of key: value";
  // The preset first, so that the file's other settings go on top of it.
  if (const auto p = j.find(kPresetKey); p != j.end()) {
    if (!p->is_string()) {
      return name + ": preset is " + std::string(p->type_name()) + ": allowed one of " +
             csm::presetNames();
    }
    if (auto err = setSetting(s, kPresetKey, p->get<std::string>())) return name + ": " + *err;
  }
  for (const auto& [key, value] : j.items()) {
    if (key == kPresetKey) continue;
    std::string text;
    if (value.is_string()) {
      text = value.get<std::string>();
    } else if (value.is_array()) {
      if (key != "lod.cascades") {
        return name + ": " + key + " is an array: allowed a number, string or boolean";
      }
      for (const auto& v : value) {
        if (!v.is_number_integer()) {
          return name + ": lod.cascades holds " + std::string(v.type_name()) +
                 ": allowed an array of integers in [0, 2]";
        }
        if (!text.empty()) text.push_back(',');
        text.append(v.dump());
      }
    } else if (value.is_number() || value.is_boolean()) {
      text = value.dump();
    } else {
      return name + ": " + key + " is " + std::string(value.type_name()) +
             ": allowed a number, string or boolean";
    }
    if (auto err = setSetting(s, key, text)) return name + ": " + *err;
  }
  return std::nullopt;
}

std::optional<std::string> validateSettings(const AppSettings& s) {
  if (auto e = csm::validate(effectiveShadow(s))) return e->message();
  if (s.farM <= 1.0) return "camera.far must exceed the near plane (0.5 m)";
  const std::uint64_t layer = std::uint64_t(s.shadow.resolution) * s.shadow.resolution;
  if (s.cacheBudgetTexels != 0 && s.cacheBudgetTexels < layer) {
    return "shadow.cacheBudgetTexels = " + std::to_string(s.cacheBudgetTexels) +
           " is invalid: allowed 0 (no cap) or at least shadow.resolution^2 = " +
           std::to_string(layer);
  }
  const std::uint64_t tile = std::uint64_t(s.shadow.resolution / csm::kTilesPerSide) *
                             (s.shadow.resolution / csm::kTilesPerSide);
  if (s.tileBudgetTexels != 0 && s.tileBudgetTexels < tile) {
    return "shadow.tileBudgetTexels = " + std::to_string(s.tileBudgetTexels) +
           " is invalid: allowed 0 (no cap) or at least one tile, (shadow.resolution / 16)^2 = " +
           std::to_string(tile);
  }
  if (s.msmMomentBits != 64 && s.msmMomentBits != 128) {
    return "shadow.msmMomentBits = " + std::to_string(s.msmMomentBits) +
           " is invalid: allowed 64 or 128";
  }
  if (s.shadowTiles && csm::isPrefiltered(s.shadow.kernel)) {
    return std::string("shadow.tiles = true is invalid with shadow.kernel = ") +
           csm::kernelName(s.shadow.kernel) +
           ": allowed with the depth-comparison kernels (1tap, tent3x3, tent5x5, tent7x7, "
           "poisson16, pcss)";
  }
  return std::nullopt;
}

nlohmann::json settingsJson(const AppSettings& s) {
  nlohmann::json j = nlohmann::json::object();
  if (s.preset) j[kPresetKey] = csm::presetName(*s.preset);
  for (const Entry& e : table()) j[e.key] = e.get(s);
  return j;
}

std::string settingsHelp() {
  std::string out = std::string("  ") + kPresetKey + ": one of " + csm::presetNames() +
                    " (applied first; the other settings go on top)\n";
  for (const Entry& e : table()) out += std::string("  ") + e.key + ": " + e.allowed + "\n";
  return out;
}

glm::dvec3 lightDirection(const AppSettings& s) noexcept {
  const double az = glm::radians(s.lightAzimuthDeg), el = glm::radians(s.lightElevationDeg);
  // Direction of travel: from the sun toward the ground.
  return -glm::dvec3(std::cos(el) * std::cos(az), std::sin(el), std::cos(el) * std::sin(az));
}

csm::ShadowSettings effectiveShadow(const AppSettings& s) noexcept {
  csm::ShadowSettings out = s.shadow;
  if (s.scheme == SplitScheme::kUniform) out.splitLambda = 0.0;
  if (s.scheme == SplitScheme::kLogarithmic) out.splitLambda = 1.0;
  return out;
}

const char* kernelKey(csm::PcfKernel k) noexcept {
  return csm::kernelName(k);
}
const char* debugKey(csm::DebugMode m) noexcept {
  return csm::debugModeName(m);
}
const char* schemeKey(SplitScheme m) noexcept {
  for (const auto& [name, v] : kSchemes) {
    if (v == m) return name;
  }
  return "?";
}

}  // namespace world
