#pragma once

#include <string>

#include "die_cushion_ident/core/analysis/offline_analysis.h"

namespace die_cushion_ident {

/// Where the analysis came from, for summary.yaml's `input` section.
struct AnalysisInput {
  std::string bag;
  std::string topics[kInputStreamCount];
  std::uint64_t messages[kInputStreamCount] = {0, 0, 0};
  double duration = 0.0;  ///< [s] of the bag
  double start = 0.0;     ///< [s] record time of its first message (seconds since the epoch)
  std::string joint_name;  ///< configured cushion joint ("" = the only one / position[0])
};

/// Writes DIR/summary.yaml (interface contract), DIR/analysis.bag (the online estimates, the model
/// comparison at 100 Hz and the valve's frequency response, on the input's time stamps) and CSV files.
/// Throws std::runtime_error when a file cannot be written.
void writeAnalysis(const std::string& directory, const AnalysisInput& input,
                   const IdentificationConfig& config, const OfflineResult& result,
                   const std::vector<GridSample>& grid);

}  // namespace die_cushion_ident
