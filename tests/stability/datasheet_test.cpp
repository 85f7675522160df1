// csm_datasheet's measurement of the default row against the committed datasheet
// (tools/datasheet/results/datasheet.json): the code measures what is committed, a figure changed
// by hand beyond the tolerance is found, and the default row's own figures hold what the module
// promises (no shimmer under translation, rotation or zoom at 0, 10^6 or 10^7 m; no acne on the
// forest path); the committed speed/accuracy sweep's default row and its rival kernels likewise.
#include <gtest/gtest.h>

#include <csm/names.hpp>
#include <csm/presets.hpp>
#include <engine/errors.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "datasheet.hpp"
#include "datasheet_measure.hpp"
#include "tradeoff.hpp"

namespace {

nlohmann::json committedSheet() {
  std::ifstream in(std::string(CSM_SOURCE_DIR) + "/tools/datasheet/results/datasheet.json");
  std::stringstream ss;
  ss << in.rdbuf();
  return nlohmann::json::parse(ss.str());
}

TEST(Datasheet, DefaultRowMatchesTheCommittedSheetAndAHandEditIsFound) {
  datasheet::MeasureOptions o;
  o.timing = false;
  o.onlyRows = {"high"};
  nlohmann::json measured;
  try {
    measured = datasheet::measure(o, [] { return 0.0; });
  } catch (const engine::NoDeviceError& e) {
    GTEST_SKIP() << "no Vulkan device: " << e.what();
  }
  ASSERT_EQ(measured["rows"].size(), 1u);
  const nlohmann::json& row = measured["rows"][0];
  EXPECT_TRUE(row["default"].get<bool>());
  const nlohmann::json& f = row["figures"];
  EXPECT_GT(f["misclassification"].get<double>(), 0.0);
  EXPECT_LT(f["misclassification"].get<double>(), 0.01);
  EXPECT_LT(f["acne"].get<double>(), 1e-4) << "lit interior pixels below 0.99";
  for (const char* motion : {"translate", "rotate", "zoom"}) {
    for (const char* d : {"0", "1e+06", "1e+07"}) {
      EXPECT_EQ(f["shimmer"][motion][d]["visible"].get<double>(), 0.0)
          << "stabilised cascades shimmer under " << motion << " at " << d << " m";
    }
  }
  EXPECT_FALSE(row.contains("timing"));

  nlohmann::json committed = committedSheet();
  const std::vector<std::string> now = datasheet::compareFigures(
      committed, measured, datasheet::kRelativeTolerance, datasheet::kAbsoluteTolerance, false);
  EXPECT_TRUE(now.empty()) << "the committed datasheet is stale (regenerate with "
                              "build/bin/csm_datasheet): "
                           << (now.empty() ? "" : now[0]);
  for (nlohmann::json& r : committed["rows"]) {
    if (r["name"] != "high") continue;
    r["figures"]["misclassification"] = r["figures"]["misclassification"].get<double>() * 1.05;
  }
  const std::vector<std::string> edited = datasheet::compareFigures(
      committed, measured, datasheet::kRelativeTolerance, datasheet::kAbsoluteTolerance, false);
  ASSERT_EQ(edited.size(), now.size() + 1);
  EXPECT_NE(edited.back().find("row 'high'.figures.misclassification"), std::string::npos)
      << edited.back();
}

// The datasheet's rows are every preset with its own filter, then every filter of the module
// (csm::kAllFilters, the prefiltered ones included) over the default preset, each once; the
// committed datasheet holds exactly those rows, in that order, so that a filter or preset added
// to the module without a regenerated datasheet is found without measuring anything.
TEST(Datasheet, RowsAreEveryPresetAndEveryFilterAndTheCommittedSheetHoldsThem) {
  const std::vector<datasheet::RowSpec> specs = datasheet::rowSpecs();
  std::set<std::string> names;
  for (const datasheet::RowSpec& s : specs) EXPECT_TRUE(names.insert(s.name).second) << s.name;
  for (csm::Preset p : csm::kAllPresets) {
    EXPECT_EQ(std::count_if(specs.begin(), specs.end(),
                            [&](const datasheet::RowSpec& s) {
                              return s.preset == p &&
                                     s.kernel == csm::presetConfig(p).settings.kernel;
                            }),
              1)
        << csm::presetName(p);
  }
  for (csm::PcfKernel k : csm::kAllFilters) {
    EXPECT_EQ(std::count_if(specs.begin(), specs.end(),
                            [&](const datasheet::RowSpec& s) {
                              return s.preset == csm::Preset::kHigh && s.kernel == k;
                            }),
              1)
        << csm::kernelName(k) << " over the default preset";
  }
  const nlohmann::json committed = committedSheet();
  std::vector<std::string> committedNames, specNames;
  for (const nlohmann::json& r : committed.at("rows")) committedNames.push_back(r.at("name"));
  for (const datasheet::RowSpec& s : specs) specNames.push_back(s.name);
  EXPECT_EQ(committedNames, specNames)
      << "the committed datasheet's rows are not the code's (regenerate with "
         "build/bin/csm_datasheet)";
}

// The committed speed/accuracy sweep (tools/tradeoff/results/tradeoff.csv, whose figures
// tools/tradeoff/README.md quotes) against the code: the accuracy columns of its default row and
// of the kernels the README weighs against it (the single tap, PCSS), measured again as
// csm_tradeoff measures them (forest path, 5 poses, no timing). A figure within the datasheet's
// tolerance, or half a unit of the CSV's last written digit where that is coarser, is the same.
// A committed figure changed by 5% is found.
std::vector<std::string> sweepMismatches(const std::vector<tradeoff::Row>& committed,
                                         const std::vector<tradeoff::Row>& measured) {
  std::vector<std::string> out;
  for (const tradeoff::Row& m : measured) {
    const auto c = std::find_if(committed.begin(), committed.end(), [&](const tradeoff::Row& r) {
      return r.config.label() == m.config.label();
    });
    if (c == committed.end()) {
      out.push_back(m.config.label() + ": not in the committed sweep");
      continue;
    }
    const auto check = [&](const char* column, double was, double now, double halfUnit) {
      const double tol = std::max(
          datasheet::kAbsoluteTolerance + datasheet::kRelativeTolerance * std::abs(was), halfUnit);
      if (!(std::abs(now - was) <= tol)) {
        char line[256];
        std::snprintf(line, sizeof line, "%s: %s committed %.6g, measured %.6g (tolerance %.2g)",
                      m.config.label().c_str(), column, was, now, tol);
        out.emplace_back(line);
      }
    };
    check("misclassification", c->misclassification, m.misclassification, 5e-6);
    check("mean_abs_error", c->meanError, m.meanError, 5e-6);
    check("mean_abs_error_soft", c->softError, m.softError, 5e-6);
    check("shimmer_max", c->shimmerMax, m.shimmerMax, 5e-5);
    check("shadow_triangles", c->triangles, m.triangles, 0.5);
  }
  return out;
}

TEST(TradeoffSweep, CommittedFiguresOfTheDefaultAndItsRivalKernelsAreWhatTheCodeMeasures) {
  const std::vector<tradeoff::Row> committed =
      tradeoff::readCsv(std::string(CSM_SOURCE_DIR) + "/tools/tradeoff/results/tradeoff.csv");
  std::vector<tradeoff::Config> configs(3);
  configs[1].kernel = csm::PcfKernel::k1Tap;
  configs[2].kernel = csm::PcfKernel::kPcss;
  ASSERT_TRUE(configs[0].isDefault());
  tradeoff::Options o;
  o.timing = false;
  std::string info, device;
  std::vector<tradeoff::Row> measured;
  try {
    measured = tradeoff::runSweep(o, configs, info, device, [] { return 0.0; });
  } catch (const engine::NoDeviceError& e) {
    GTEST_SKIP() << "no Vulkan device: " << e.what();
  }
  ASSERT_EQ(measured.size(), configs.size());
  for (const tradeoff::Row& m : measured) {
    std::printf(
        "%s: misclassified %.5f, mean error %.5f, soft %.5f, shimmer max %.4f, %.0f "
        "triangles\n",
        m.config.label().c_str(), m.misclassification, m.meanError, m.softError, m.shimmerMax,
        m.triangles);
  }
  const std::vector<std::string> now = sweepMismatches(committed, measured);
  EXPECT_TRUE(now.empty())
      << "the committed sweep is stale (regenerate with build/bin/csm_tradeoff "
         "--out tools/tradeoff/results): "
      << (now.empty() ? "" : now[0]);

  std::vector<tradeoff::Row> edited = committed;
  for (tradeoff::Row& r : edited) {
    if (r.config.isDefault()) r.misclassification *= 1.05;
  }
  const std::vector<std::string> found = sweepMismatches(edited, measured);
  ASSERT_EQ(found.size(), now.size() + 1);
  EXPECT_NE(found.back().find("misclassification"), std::string::npos) << found.back();
}

}  // namespace
