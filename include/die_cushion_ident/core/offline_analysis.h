#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "die_cushion_ident/core/effect_ranking.h"
#include "die_cushion_ident/core/identification_pipeline.h"
#include "die_cushion_ident/core/model_assessment.h"
#include "die_cushion_ident/core/recorded_sweep.h"

namespace die_cushion_ident {

/// The online estimate at one identification step (for the time series in analysis.bag and CSV).
struct EstimateSample {
  double t = 0.0;
  std::vector<double> values, stds;
  double equation_error_rms = 0.0;
};

/// Everything analyze_bag reports.
struct OfflineResult {
  std::uint64_t messages = 0;
  std::uint64_t grid_samples = 0;
  std::vector<std::string> effects;
  /// The model fitted to the whole recording without forgetting (the best constant parameters); the
  /// online estimate with forgetting is in `estimates`.
  HydraulicEstimate model;
  bool hydraulics = false;  ///< pressure and position were there to identify the hydraulics
  StrokeSegmentation strokes;
  ModelAssessment assessment;
  EffectRankingResult ranking;
  std::vector<EstimateSample> estimates;
  std::optional<RecordedSweep> valve;  ///< present when the recording holds a sine sweep
  std::array<StreamHealth, kInputStreamCount> health;
  std::uint64_t restarts = 0;
  std::vector<std::string> warnings;
};

/// The offline analysis on the same core as the node: messages in, the pipeline's uniform samples kept, and
/// at the end the whole-recording fit, the free-run comparison, the effect ranking and the valve sweep.
class OfflineAnalysis {
 public:
  explicit OfflineAnalysis(const IdentificationConfig& config);

  void push(InputStream stream, const StreamSample& sample);
  /// Runs the analyses; `progress` (may be empty) is told what runs.
  OfflineResult finish(const std::function<void(const std::string&)>& progress = {});

  const std::vector<GridSample>& grid() const { return grid_; }
  const IdentificationConfig& config() const { return config_; }

 private:
  IdentificationConfig config_;
  IdentificationPipeline pipeline_;
  std::vector<GridSample> grid_;
  std::vector<ValveSample> valve_;
  std::vector<EstimateSample> estimates_;
  std::uint64_t messages_ = 0;
};

}  // namespace die_cushion_ident
