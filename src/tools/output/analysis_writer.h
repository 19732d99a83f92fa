#pragma once

#include <future>
#include <memory>
#include <string>

#include "die_cushion_ident/core/analysis/offline_analysis.h"
#include "output/output_files.h"

namespace die_cushion_ident {

/// Where the analysis came from, for summary.yaml's `input` section.
struct AnalysisInput {
  std::string bag;
  std::string topics[kInputStreamCount];
  std::uint64_t messages[kInputStreamCount] = {0, 0, 0};
  /// Messages that gave no sample (damaged, or a JointState without the cushion's joint or its position):
  /// counted with the resampler's rejections, as the node counts them.
  std::uint64_t unusable[kInputStreamCount] = {0, 0, 0};
  /// Message records in the file that could not be read (the one a killed recording's end cuts, damaged
  /// ones outside the index's count): summary.yaml's input.records_unreadable.
  std::uint64_t records_unreadable = 0;
  double duration = 0.0;  ///< [s] of the bag
  double start = 0.0;     ///< [s] record time of its first message (seconds since the epoch)
  std::string joint_name;  ///< configured cushion joint ("" = the only one / position[0])
  std::string oil_temperature_topic;           ///< the optional oil temperature's topic
  std::uint64_t oil_temperature_messages = 0;  ///< its messages in the bag
  std::uint64_t oil_temperature_unusable = 0;  ///< of them damaged
};

/// Writes DIR/summary.yaml (interface contract), DIR/analysis.bag (the online estimates, the model
/// comparison at 100 Hz and the valve's frequency response, on the input's time stamps) and CSV files.
///
/// In two steps, because writing an hour's estimates and comparison into the bag takes seconds: the
/// constructor starts writing them (and their CSVs) on their own threads as soon as
/// OfflineAnalysis::identify() has made them final, so that it runs while OfflineAnalysis::explain() ranks
/// the effects; finish() waits for them and writes the rest. Every file is written whole or not at all
/// (OutputFiles: NAME.partial, on the disk and renamed when all are whole, summary.yaml last, listing them
/// under `outputs`); a failed run leaves neither. Throws WriteError (a std::runtime_error) when a file cannot
/// be written.
class AnalysisWriter {
 public:
  /// Removes a previous run's outputs from `directory` (which must exist) and starts writing. The result's
  /// estimates, strokes, model and assessment and the grid must not change until finish().
  AnalysisWriter(const std::string& directory, const IdentificationConfig& config, const OfflineResult& result,
                 const std::vector<GridSample>& grid);
  /// Waits for a running write (its error, if any, is lost: the program is failing already).
  ~AnalysisWriter();
  /// Waits for the long series, then writes the valve's results, summary.yaml and the small CSVs.
  void finish(const AnalysisInput& input, const OfflineResult& result);

 private:
  OutputFiles files_;  // first: destroyed last, after the bag's file is closed
  std::string directory_;
  IdentificationConfig config_;
  HydraulicModel model_;  // read only, by the threads that write the series
  std::unique_ptr<class AnalysisBag> bag_;
  std::future<void> bag_series_, comparison_csv_, estimates_csv_;
};

}  // namespace die_cushion_ident
