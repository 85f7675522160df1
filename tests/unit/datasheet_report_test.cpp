// csm_datasheet's report (tools/datasheet/datasheet.hpp): a figure changed beyond the tolerance,
// a row missing or reconfigured, a hand-edited markdown or README table are all found; timings
// and figures within the tolerance are not.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "datasheet.hpp"

namespace {

nlohmann::json sampleSheet() {
  nlohmann::json row = {
      {"name", "high"},
      {"preset", "high"},
      {"filter", "tent3x3"},
      {"cascades", 4},
      {"resolution", 2048},
      {"default", true},
      {"figures",
       {{"memory_mib", 64.0},
        {"misclassification", 0.00355},
        {"mean_abs_error", 0.0058},
        {"mean_abs_error_soft", 0.0058},
        {"acne", 0.0},
        {"leak", 0.1389},
        {"shimmer",
         {{"translate", {{"0", {{"visible", 0.0}, {"mean", 1e-7}}}}},
          {"rotate", {{"0", {{"visible", 0.00523}, {"mean", 2e-4}}}}}}}}},
      {"timing", {{"shadow_ms", 32.4}, {"lit_ms", 86.7}, {"cpu_ms", 0.9}, {"front", true}}}};
  nlohmann::json low = row;
  low["name"] = "low";
  low["preset"] = "low";
  low["cascades"] = 6;
  low["resolution"] = 512;
  low["default"] = false;
  low["figures"]["misclassification"] = 0.00799;
  return {{"command", "build/bin/csm_datasheet"},
          {"machine", {{"device", "llvmpipe"}, {"cpu", "test"}, {"cores", 2}}},
          {"measured", {{"path", "forest"}, {"poses", 3}, {"timing_rounds", 3}}},
          {"tolerance", {{"relative", 0.02}, {"absolute", 2e-5}}},
          {"rows", {low, row}}};
}

std::vector<std::string> diff(const nlohmann::json& a, const nlohmann::json& b,
                              bool complete = true) {
  return datasheet::compareFigures(a, b, datasheet::kRelativeTolerance,
                                   datasheet::kAbsoluteTolerance, complete);
}

TEST(DatasheetCompare, TheSameFiguresMatch) {
  EXPECT_TRUE(diff(sampleSheet(), sampleSheet()).empty());
}

TEST(DatasheetCompare, AFigureChangedByHandIsFoundByRowAndField) {
  nlohmann::json edited = sampleSheet();
  edited["rows"][1]["figures"]["misclassification"] = 0.00300;  // 0.355% written as 0.300%
  const std::vector<std::string> d = diff(edited, sampleSheet());
  ASSERT_EQ(d.size(), 1u);
  EXPECT_NE(d[0].find("row 'high'.figures.misclassification"), std::string::npos) << d[0];
  EXPECT_NE(d[0].find("committed 0.003"), std::string::npos) << d[0];
  EXPECT_NE(d[0].find("measured 0.00355"), std::string::npos) << d[0];
  // Nested figures too: one shimmer value.
  edited = sampleSheet();
  edited["rows"][1]["figures"]["shimmer"]["rotate"]["0"]["visible"] = 0.001;
  ASSERT_EQ(diff(edited, sampleSheet()).size(), 1u);
  EXPECT_NE(diff(edited, sampleSheet())[0].find("shimmer.rotate.0.visible"), std::string::npos);
}

TEST(DatasheetCompare, WithinTheToleranceAndTimingsAreNotDifferences) {
  nlohmann::json moved = sampleSheet();
  moved["rows"][1]["figures"]["misclassification"] = 0.00355 * 1.015;  // 1.5% < 2%
  moved["rows"][1]["figures"]["acne"] = 1.5e-5;                        // under the 2e-5 floor
  moved["rows"][1]["timing"]["shadow_ms"] = 99.0;
  moved["rows"][1]["timing"]["front"] = false;
  moved["machine"]["device"] = "another GPU";
  EXPECT_TRUE(diff(moved, sampleSheet()).empty());
  moved["rows"][1]["figures"]["misclassification"] = 0.00355 * 1.025;  // 2.5% > 2%
  EXPECT_EQ(diff(moved, sampleSheet()).size(), 1u);
}

TEST(DatasheetCompare, RowsMissingAddedOrReconfiguredAreFound) {
  nlohmann::json oneRow = sampleSheet();
  oneRow["rows"].erase(0);  // only "high" measured
  EXPECT_EQ(diff(sampleSheet(), oneRow).size(), 1u) << "'low' committed, not measured";
  EXPECT_TRUE(diff(sampleSheet(), oneRow, false).empty()) << "a check of some rows";
  EXPECT_EQ(diff(oneRow, sampleSheet()).size(), 1u) << "'low' measured, not committed";
  nlohmann::json reconfigured = sampleSheet();
  reconfigured["rows"][0]["resolution"] = 1024;  // the preset changed since
  const std::vector<std::string> d = diff(sampleSheet(), reconfigured);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_NE(d[0].find("row 'low'.resolution"), std::string::npos) << d[0];
  nlohmann::json lost = sampleSheet();
  lost["rows"][1]["figures"].erase("leak");  // a figure no longer measured
  EXPECT_EQ(diff(sampleSheet(), lost).size(), 1u);
}

TEST(DatasheetReport, MarkdownAndReadmeBlockComeFromTheJson) {
  const nlohmann::json sheet = sampleSheet();
  const std::string table = datasheet::headlineTable(sheet);
  EXPECT_NE(table.find("| high (default) | 4 x 2048² | tent3x3 | 64 MiB | 32.4 | 86.7 | "
                       "0.355% | 0.0058 | 0.000% | 13.89% | 0.523% | yes |"),
            std::string::npos)
      << table;
  const std::string md = datasheet::renderMarkdown(sheet);
  EXPECT_NE(md.find(table), std::string::npos);
  const std::string readme = std::string("# X\n\n") + datasheet::kReadmeBegin + "\nold\n" +
                             datasheet::kReadmeEnd + "\nafter\n";
  const std::string updated = datasheet::replaceReadmeBlock(readme, table);
  EXPECT_EQ(datasheet::readmeBlock(updated), table);
  EXPECT_NE(updated.find("after\n"), std::string::npos);
  EXPECT_TRUE(datasheet::consistencyErrors(sheet, md, updated).empty());
  EXPECT_THROW(datasheet::readmeBlock("no markers"), std::runtime_error);
}

TEST(DatasheetReport, HandEditsOfTheMarkdownOrReadmeAreFound) {
  const nlohmann::json sheet = sampleSheet();
  const std::string table = datasheet::headlineTable(sheet);
  const std::string md = datasheet::renderMarkdown(sheet);
  const std::string readme =
      std::string(datasheet::kReadmeBegin) + "\n" + table + datasheet::kReadmeEnd + "\n";
  std::string editedMd = md;
  editedMd.replace(editedMd.find("0.355%"), 6, "0.300%");
  EXPECT_EQ(datasheet::consistencyErrors(sheet, editedMd, readme).size(), 1u);
  std::string editedReadme = readme;
  editedReadme.replace(editedReadme.find("0.355%"), 6, "0.300%");
  EXPECT_EQ(datasheet::consistencyErrors(sheet, md, editedReadme).size(), 1u);
  EXPECT_EQ(datasheet::consistencyErrors(sheet, md, "markers gone").size(), 1u);
}

}  // namespace
