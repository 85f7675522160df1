// csm_datasheet's report: the datasheet as JSON (what was measured, per row), its markdown, the
// headline table that the root README includes, and the check of a committed datasheet against a
// fresh measurement. Pure (JSON and strings, no GPU): the unit tests run it without a device.
//
// A datasheet's JSON:
//   machine    {device, cpu, cores}: where the timings were measured
//   measured   what the rows were measured on (path, poses, views, rounds, shimmer set-up)
//   tolerance  {relative, absolute}: how far a re-measured figure may move and still match
//   rows[]     {name, preset, filter, cascades, resolution, default,
//               figures {memory_mib, misclassification, mean_abs_error, mean_abs_error_soft,
//                        acne, leak, shimmer {translate|rotate|zoom {"0"|"1e+06"|"1e+07"
//                        {visible, mean}}}},
//               timing {shadow_ms, lit_ms, cpu_ms, front}}
// Everything under "figures" is deterministic and checked; "timing" (and the Pareto front,
// which follows from the ms) is not.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace datasheet {

/// The default tolerance of the check: a figure matches when |a - b| <= max(absolute,
/// relative x max(|a|, |b|)).
inline constexpr double kRelativeTolerance = 0.02;
inline constexpr double kAbsoluteTolerance = 2e-5;

/// The shimmer motions (the datasheet's names and csm_measure::motionCamera's) and distances
/// from the world origin (csm_measure::distanceKey's spelling).
struct ShimmerMotion {
  const char* name;    ///< "translate", "rotate", "zoom"
  const char* motion;  ///< motionCamera's name
};
inline constexpr ShimmerMotion kShimmerMotions[] = {
    {"translate", "subtexel"}, {"rotate", "yaw"}, {"zoom", "zoom"}};
inline constexpr double kShimmerDistances[] = {0.0, 1e6, 1e7};

/// The datasheet's markdown: what it ran on, the table of every row (the headline columns), the
/// shimmer of every row per motion and distance, the plots.
std::string renderMarkdown(const nlohmann::json& sheet);

/// The headline table alone (what README includes between kReadmeBegin and kReadmeEnd).
std::string headlineTable(const nlohmann::json& sheet);

inline constexpr const char* kReadmeBegin = "<!-- datasheet:begin -->";
inline constexpr const char* kReadmeEnd = "<!-- datasheet:end -->";

/// The text between README's markers (excluding the marker lines); throws std::runtime_error
/// when a marker is missing or out of order.
std::string readmeBlock(const std::string& readme);
/// `readme` with the text between its markers replaced by `block`.
std::string replaceReadmeBlock(const std::string& readme, const std::string& block);

/// Where a committed datasheet and a fresh measurement disagree, one line each: a row missing in
/// either, a row's configuration (preset, filter, cascades, resolution) changed, a figure under
/// "figures" beyond the tolerance. With `complete` false only the rows `measured` holds are
/// compared (a check of some rows); with true a committed row that was not measured is a
/// difference too. An empty result means the committed figures are current.
std::vector<std::string> compareFigures(const nlohmann::json& committed,
                                        const nlohmann::json& measured, double relative,
                                        double absolute, bool complete = true);

/// Where committed files disagree with a committed datasheet JSON, one line each: `markdown` is
/// not what it renders to (renderMarkdown), or README's block is not its headline table. A hand
/// edit of either file shows here without measuring anything.
std::vector<std::string> consistencyErrors(const nlohmann::json& sheet, const std::string& markdown,
                                           const std::string& readme);

/// The worst visible shimmer of a row (the largest "visible" over its motions and distances).
double worstShimmer(const nlohmann::json& row);

}  // namespace datasheet
