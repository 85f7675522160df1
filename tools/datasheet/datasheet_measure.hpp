// csm_datasheet's measurement (GPU): every row's figures and timings.
#pragma once

#include <csm/gpu_layout.hpp>
#include <csm/presets.hpp>
#include <nlohmann/json.hpp>

#include <functional>
#include <string>
#include <vector>

namespace datasheet {

/// One row of the datasheet: a preset, with its own filter or another.
struct RowSpec {
  std::string name;
  csm::Preset preset = csm::Preset::kHigh;
  csm::PcfKernel kernel = csm::PcfKernel::kTent3;
};

/// Every preset (its own filter), cheapest first, then every other filter over the default
/// preset ("high tent5x5", ...).
std::vector<RowSpec> rowSpecs();

struct MeasureOptions {
  /// Time the passes (else the figures alone: the check).
  bool timing = true;
  /// Interleaved timing rounds; each row's ms are the median.
  int timingRounds = 3;
  /// Only these rows (names of rowSpecs()); empty: every row.
  std::vector<std::string> onlyRows;
  std::string command;  ///< recorded in the JSON
};

/// Measures the rows; returns the datasheet JSON (datasheet.hpp describes it). Throws
/// std::invalid_argument for an unknown row name, engine::NoDeviceError without a device.
nlohmann::json measure(const MeasureOptions& o, const std::function<double()>& elapsed);

}  // namespace datasheet
