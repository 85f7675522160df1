// csm_datasheet's report: markdown, README block and the check (see datasheet.hpp).
#include "datasheet.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace datasheet {

namespace {

std::string fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

// A figure of a row, or -1 when the row lacks it.
double figure(const nlohmann::json& row, const char* key) {
  const nlohmann::json& f = row.value("figures", nlohmann::json::object());
  return f.contains(key) && f[key].is_number() ? f[key].get<double>() : -1.0;
}

double timing(const nlohmann::json& row, const char* key) {
  const nlohmann::json& t = row.value("timing", nlohmann::json::object());
  return t.contains(key) && t[key].is_number() ? t[key].get<double>() : -1.0;
}

std::string percent(double fraction, const char* format) {
  return fraction < 0.0 ? std::string("-") : fmt(format, 100.0 * fraction) + "%";
}

std::string ms(double v) {
  return v < 0.0 ? std::string("-") : fmt("%.1f", v);
}

// A JSON value as the report prints it ("-" when absent).
std::string text(const nlohmann::json& j, const char* key) {
  if (!j.contains(key)) return "-";
  const nlohmann::json& v = j[key];
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

void compareNode(const std::string& where, const nlohmann::json& c, const nlohmann::json& m,
                 double relative, double absolute, std::vector<std::string>& out) {
  if (c.is_object() || m.is_object()) {
    if (!c.is_object() || !m.is_object()) {
      out.push_back(where + ": committed " + c.dump() + ", measured " + m.dump());
      return;
    }
    for (auto it = c.begin(); it != c.end(); ++it) {
      if (!m.contains(it.key())) {
        out.push_back(where + "." + it.key() + ": committed but no longer measured");
      } else {
        compareNode(where + "." + it.key(), it.value(), m[it.key()], relative, absolute, out);
      }
    }
    for (auto it = m.begin(); it != m.end(); ++it) {
      if (!c.contains(it.key())) {
        out.push_back(where + "." + it.key() + ": measured but not in the committed datasheet");
      }
    }
    return;
  }
  if (c.is_number() && m.is_number()) {
    const double a = c.get<double>(), b = m.get<double>();
    const double tol = std::max(absolute, relative * std::max(std::fabs(a), std::fabs(b)));
    if (!(std::fabs(a - b) <= tol)) {
      char buf[256];
      std::snprintf(buf, sizeof buf, ": committed %.6g, measured %.6g (tolerance %.3g)", a, b, tol);
      out.push_back(where + buf);
    }
    return;
  }
  if (c != m) out.push_back(where + ": committed " + c.dump() + ", measured " + m.dump());
}

}  // namespace

std::vector<std::string> consistencyErrors(const nlohmann::json& sheet, const std::string& markdown,
                                           const std::string& readme) {
  std::vector<std::string> out;
  if (markdown != renderMarkdown(sheet)) {
    out.push_back("datasheet.md is not what datasheet.json renders to (edited by hand?)");
  }
  try {
    if (readmeBlock(readme) != headlineTable(sheet)) {
      out.push_back("README's datasheet table is not datasheet.json's (edited by hand?)");
    }
  } catch (const std::runtime_error& e) {
    out.push_back(e.what());
  }
  return out;
}

double worstShimmer(const nlohmann::json& row) {
  double worst = -1.0;
  const nlohmann::json& f = row.value("figures", nlohmann::json::object());
  if (!f.contains("shimmer")) return worst;
  for (const auto& motion : f["shimmer"].items()) {
    for (const auto& distance : motion.value().items()) {
      worst = std::max(worst, distance.value().value("visible", -1.0));
    }
  }
  return worst;
}

std::string headlineTable(const nlohmann::json& sheet) {
  std::string s =
      "| row | cascades | filter | memory | shadow ms | lit ms | misclassified | soft error | "
      "acne | leaks | shimmer | front |\n"
      "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
  for (const nlohmann::json& row : sheet.at("rows")) {
    const nlohmann::json& t = row.value("timing", nlohmann::json::object());
    std::string name = row.at("name").get<std::string>();
    if (row.value("default", false)) name += " (default)";
    s += "| " + name + " | " + std::to_string(row.at("cascades").get<int>()) + " x " +
         std::to_string(row.at("resolution").get<int>()) + "² | " +
         row.at("filter").get<std::string>() + " | " + fmt("%.0f MiB", figure(row, "memory_mib")) +
         " | " + ms(timing(row, "shadow_ms")) + " | " + ms(timing(row, "lit_ms")) + " | " +
         percent(figure(row, "misclassification"), "%.3f") + " | " +
         fmt("%.4f", figure(row, "mean_abs_error_soft")) + " | " +
         percent(figure(row, "acne"), "%.3f") + " | " + percent(figure(row, "leak"), "%.2f") +
         " | " + percent(worstShimmer(row), "%.3f") + " | " +
         (t.value("front", false) ? "yes" : "") + " |\n";
  }
  return s;
}

std::string renderMarkdown(const nlohmann::json& sheet) {
  const nlohmann::json& machine = sheet.value("machine", nlohmann::json::object());
  const nlohmann::json& measured = sheet.value("measured", nlohmann::json::object());
  const nlohmann::json& tol = sheet.value("tolerance", nlohmann::json::object());
  std::string s = "# Datasheet\n\n";
  s += "Generated by `" + text(sheet, "command") +
       "` from the code as it is; do not edit by hand (the check compares this file with "
       "`datasheet.json` and every figure with a fresh measurement).\n\n";
  s += "- Machine: " + text(machine, "device") + "; CPU " + text(machine, "cpu") + ", " +
       text(machine, "cores") + " cores.\n";
  s += "- Rows: every preset (`csm::presetConfig`), then every filter over the default preset. "
       "Each row otherwise at the module's defaults (fade, caster LODs by error, closed-caster "
       "culling, D32).\n";
  s += "- Accuracy on the sample world's `" + text(measured, "path") + "` path, " +
       text(measured, "poses") + " poses, " + text(measured, "accuracy_view") +
       " pixels: misclassified = receiver pixels with |s - v| > 0.5 against Embree shadow "
       "rays; soft error = mean |s - v| against the sun as a 0.53° disk; acne = lit interior "
       "pixels facing the light shaded below 0.99; leaks = shadowed pixels next to a contact "
       "line shaded above 0.5.\n";
  s += "- Timing: shadow pass and lit pass GPU ms (timestamp queries) at " +
       text(measured, "timing_view") + ", median of " + text(measured, "timing_rounds") +
       " interleaved round(s); front = Pareto front of (shadow + lit ms, misclassified).\n";
  s += "- Shimmer: " + text(measured, "shimmer") + "\n";
  s += "- Tolerance of the check: " + text(tol, "relative") + " relative, " +
       text(tol, "absolute") + " absolute; timings are not checked.\n\n";
  s += "## Every row\n\n" + headlineTable(sheet) + "\n";
  s += "## Shimmer per motion and distance from the origin\n\n";
  s += "Stable receivers whose shadow factor changes by more than 1/255 between frames "
       "(percent of pairs).\n\n| row |";
  std::string rule = "|---|";
  for (const ShimmerMotion& m : kShimmerMotions) {
    for (double d : kShimmerDistances) {
      char head[64];
      std::snprintf(head, sizeof head, d == 0.0 ? " %s %.0f m |" : " %s %.0e m |", m.name, d);
      s += head;
      rule += "---:|";
    }
  }
  s += "\n" + rule + "\n";
  for (const nlohmann::json& row : sheet.at("rows")) {
    s += "| " + row.at("name").get<std::string>() + " |";
    const nlohmann::json& sh =
        row.value("figures", nlohmann::json::object()).value("shimmer", nlohmann::json::object());
    for (const ShimmerMotion& m : kShimmerMotions) {
      for (double d : kShimmerDistances) {
        const std::string key = d == 0.0 ? "0" : fmt("%.0e", d);
        double v = -1.0;
        if (sh.contains(m.name) && sh[m.name].contains(key)) {
          v = sh[m.name][key].value("visible", -1.0);
        }
        s += ' ';
        s += percent(v, "%.3f");
        s += " |";
      }
    }
    s += "\n";
  }
  if (measured.value("timing_rounds", 0) > 0) {
    s += "\n## Plots\n\n![Pareto front](datasheet_front.png)\n\n"
         "![Cost per filter](datasheet_filters.png)\n";
  }
  return s;
}

std::string readmeBlock(const std::string& readme) {
  const size_t b = readme.find(kReadmeBegin);
  const size_t e = readme.find(kReadmeEnd);
  if (b == std::string::npos || e == std::string::npos || e < b) {
    throw std::runtime_error(std::string("README: the markers ") + kReadmeBegin + " and " +
                             kReadmeEnd + " are missing or out of order");
  }
  const size_t start = readme.find('\n', b);
  if (start == std::string::npos || start + 1 > e) return "";
  return readme.substr(start + 1, e - start - 1);
}

std::string replaceReadmeBlock(const std::string& readme, const std::string& block) {
  readmeBlock(readme);  // throws without the markers
  const size_t b = readme.find(kReadmeBegin);
  const size_t start = readme.find('\n', b) + 1;
  const size_t e = readme.find(kReadmeEnd);
  return readme.substr(0, start) + block + readme.substr(e);
}

std::vector<std::string> compareFigures(const nlohmann::json& committed,
                                        const nlohmann::json& measured, double relative,
                                        double absolute, bool complete) {
  std::vector<std::string> out;
  std::map<std::string, const nlohmann::json*> byName;
  for (const nlohmann::json& row : committed.at("rows")) {
    byName[row.at("name").get<std::string>()] = &row;
  }
  for (const nlohmann::json& row : measured.at("rows")) {
    const std::string name = row.at("name").get<std::string>();
    const auto it = byName.find(name);
    if (it == byName.end()) {
      out.push_back("row '" + name + "': measured but not in the committed datasheet");
      continue;
    }
    const nlohmann::json& c = *it->second;
    for (const char* key : {"preset", "filter", "cascades", "resolution", "default"}) {
      if (c.value(key, nlohmann::json()) != row.value(key, nlohmann::json())) {
        out.push_back("row '" + name + "'." + key + ": committed " +
                      c.value(key, nlohmann::json()).dump() + ", now " +
                      row.value(key, nlohmann::json()).dump());
      }
    }
    compareNode("row '" + name + "'.figures", c.value("figures", nlohmann::json::object()),
                row.value("figures", nlohmann::json::object()), relative, absolute, out);
    byName.erase(it);
  }
  if (complete) {
    for (const auto& [name, row] : byName) {
      out.push_back("row '" + name + "': committed but no longer measured");
    }
  }
  return out;
}

}  // namespace datasheet
