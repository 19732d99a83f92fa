#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "die_cushion_ident/core/adequacy/effect_onset.h"
#include "die_cushion_ident/core/adequacy/effect_ranking.h"
#include "die_cushion_ident/core/adequacy/model_assessment.h"
#include "die_cushion_ident/core/analysis/estimate_series.h"
#include "die_cushion_ident/core/estimation/identification_pipeline.h"
#include "die_cushion_ident/core/estimation/topic_delay_estimator.h"
#include "die_cushion_ident/core/fits/output_error_refinement.h"
#include "die_cushion_ident/core/fits/parameter_uncertainty.h"
#include "die_cushion_ident/core/segmentation/evenly_thinned_cycles.h"
#include "die_cushion_ident/core/settings/settings_from_recording.h"
#include "die_cushion_ident/core/signal/message_noise.h"
#include "die_cushion_ident/core/trend/reference_temperature.h"
#include "die_cushion_ident/core/valve/recorded_sweep.h"
#include "die_cushion_ident/core/valve/step_response.h"

namespace die_cushion_ident {

/// What the grid holds: samples with all three inputs, with a velocity, and the highest pressure; counted
/// over every sample read, kept or not.
struct GridCoverage {
  std::uint64_t complete = 0, with_velocity = 0;
  double highest = -std::numeric_limits<double>::infinity();  ///< [Pa], for a hint about its unit
  void add(const GridSample& g);
};

/// How much of a long recording the cycle-based analyses judged (EvenlyThinnedCycles).
struct GridThinning {
  int stride = 1;       ///< every stride-th cycle was kept; 1: the whole recording
  int cycles_seen = 0;  ///< impacts in the recording
  int cycles_kept = 0;  ///< of them kept
  std::size_t samples_kept = 0;
};

/// The recording's oil temperature (the optional topic), where it has one.
struct OilTemperatureRecord {
  StreamHealth health;      ///< the topic's messages: rate, rejections, gaps
  std::uint64_t jumps = 0;  ///< of health.implausible: a step faster than max_plausible_oil_temperature_rate
  /// [degC] over the accepted messages.
  double mean = std::numeric_limits<double>::quiet_NaN();
  double lowest = std::numeric_limits<double>::quiet_NaN();
  double highest = std::numeric_limits<double>::quiet_NaN();
  /// [s] the messages' mean stamp against the other topics' newest when they arrived (informative).
  double stamp_offset = std::numeric_limits<double>::quiet_NaN();
  /// Of the analysed grid's complete samples, the share with a temperature (1: the topic never fell silent).
  double grid_share = 0.0;
  /// [degC] the temperature the model's parameters hold at: the analysed grid's mean oil temperature.
  double origin = std::numeric_limits<double>::quiet_NaN();
  /// [degC] and the model's parameters carried there (parametersAtTemperature).
  double reference = std::numeric_limits<double>::quiet_NaN();
  std::vector<ParameterAtTemperature> at_reference;
};

/// Everything analyze_bag reports.
struct OfflineResult {
  std::uint64_t messages = 0;
  std::uint64_t grid_samples = 0;  ///< read; the analyses beyond the online estimate judged `thinning`'s
  GridThinning thinning;
  std::vector<std::string> effects;
  /// The model fitted to the whole recording without forgetting (the best constant parameters); the
  /// online estimate with forgetting is in `estimates`.
  HydraulicEstimate model;
  /// The refinement of `model` by the free run's error (its values and stds are then `model`'s), when run.
  std::optional<OutputErrorFit> output_error;
  /// A library effect that starts within the recording, and the cycle it starts in (findEffectOnset).
  std::optional<EffectOnset> onset;
  /// What each of `model`'s stds is made of (model order; combineUncertainty).
  std::vector<ParameterUncertainty> uncertainty;
  bool hydraulics = false;  ///< pressure and position were there to identify the hydraulics
  /// The recording holds no press stroke (holdsNoPressStroke): a step test or sweep, not identified as a
  /// press.
  bool no_press_stroke = false;
  StrokeSegmentation strokes;
  ModelAssessment assessment;
  EffectRankingResult ranking;
  EstimateSeries estimates;
  std::optional<RecordedSweep> valve;  ///< present when the recording holds a sine sweep
  /// Whose valve model judged the port side near the spool's kink in the fits: "configured", or "sweep"
  /// (the recording's own, when its fit succeeded and its command hold is known).
  std::string valve_model_source = "configured";
  std::vector<StepResponse> step_responses;  ///< valve command steps at rest found in the recording
  std::array<StreamHealth, kInputStreamCount> health;
  std::uint64_t restarts = 0;
  /// [s] the clock offsets subtracted from each topic's stamps, and where they came from.
  std::array<double, kInputStreamCount> topic_delays = {0.0, 0.0, 0.0};
  std::string topic_delays_source = "none";  ///< "configured", "estimated" or "none" (estimate not usable)
  std::optional<TopicDelayEstimate> delay_estimate;  ///< when estimated from the data
  std::uint64_t derived_velocity_samples = 0;       ///< grid samples whose velocity came from the position
  std::uint64_t predicted_spool_messages = 0;  ///< valve messages whose spool the valve model stood in for
  std::vector<AnalysisWarning> warnings;
  /// The settings chosen from the recording (analyze_bag's survey), when they were.
  std::optional<SettingsChoice> settings;
  /// The oil temperature, where the recording has the topic (a message of it, accepted or not).
  std::optional<OilTemperatureRecord> oil_temperature;
  /// Part of the analysis could not run (no complete stroke, no usable sample, an implausible parameter):
  /// the reasons are in `warnings`; analyze_bag exits with 5.
  bool partial = false;
};

/// Significance of the test in parametersThatVaryOverTheRecording (per parameter), and how many times their
/// own stds the groups must disagree. A group of one cycle has a Newey-West std too small (few rows for the
/// long-run covariance): on 60 steady random plants with 10 cycles sqrt(Q / (G-1)) had median 1.2, 99th
/// percentile 2.4, max 3.0 (instead of about 1); a bulk modulus falling by a third halfway gives 8.4.
constexpr double kVariationSignificance = 1e-3;
constexpr double kVariationScatter = 4.0;

/// A warning, in words, for each parameter that changes over the recording. The press cycles split into
/// `groups` contiguous groups (at most one per cycle), each fitted alone; Cochran's Q (the groups' estimates
/// around their weighted mean, in units of their own stds, chi-square with G-1 degrees of freedom) above
/// its 1 - kVariationSignificance point, with sqrt(Q / (G-1)) above kVariationScatter, means they disagree
/// more than their noise explains. Worded as a drift when a step between the first and the second half of
/// the groups explains most of Q (the plant changed while it was recorded), else as stroke-to-stroke
/// variation (an effect the model lacks). The groups are fitted on up to `jobs` threads (0: one per core).
std::vector<std::string> parametersThatVaryOverTheRecording(const std::vector<GridSample>& grid,
                                                             const StrokeSegmentation& strokes,
                                                             const IdentificationConfig& config,
                                                             const HydraulicEstimate& estimate, int groups = 10,
                                                             int jobs = 1);
class CycleGroupFits;
/// The same on groups already fitted.
std::vector<std::string> parametersThatVaryOverTheRecording(const CycleGroupFits& groups,
                                                             const HydraulicEstimate& estimate);

/// The offline analysis on the same core as the node: messages in, the pipeline's uniform samples kept, and
/// at the end the whole-recording fit, the free-run comparison, the effect ranking and the valve sweep.
class OfflineAnalysis {
 public:
  explicit OfflineAnalysis(const IdentificationConfig& config);
  /// Threads for the effect ranking's candidates (0, the default: one per core).
  void setJobs(int jobs) { jobs_ = jobs; }
  /// The analysis's own resolution error [Pa] at its sample period and what to do about it (from
  /// SettingsFromRecording): the ranking names no effect for an error of that size.
  void setResolution(double error, const std::string& remedy) {
    resolution_error_ = std::isfinite(error) ? error : 0.0;
    resolution_remedy_ = remedy;
  }

  void push(InputStream stream, const StreamSample& sample);
  /// One message of the optional oil temperature topic (`sample.first` in degC).
  void pushOilTemperature(const StreamSample& sample);
  /// Reserves the grid for a recording of about `seconds` (a hint: growth by doubling would hold up to twice
  /// the memory an hour of grid needs). Ignored when not finite or beyond `max_seconds`.
  void reserve(double seconds, double max_seconds);
  /// Ends the input and estimates the topics' clock offsets from the grid (TopicDelayEstimator). A caller
  /// that finds them significant analyses the recording again with config.topic_delays set.
  TopicDelayEstimate estimateTopicDelays();
  /// Searches formulas for the error the library leaves even when it is not structured (analyze_bag
  /// --propose); by default the search runs only when it is.
  void proposeAlways(bool always) { always_propose_ = always; }
  /// Runs the analyses; `progress` (may be empty) is told what runs. The same as identify() then explain().
  OfflineResult finish(const std::function<void(const std::string&)>& progress = {});
  /// The first half of finish(): input health, strokes, the model fitted to the whole recording, its
  /// variation over the recording and the free run against the measurement. The result's estimates,
  /// strokes, model and assessment are final after it: a caller may write them out while explain() runs.
  OfflineResult identify(const std::function<void(const std::string&)>& progress = {});
  /// The second half: the effect ranking and formula search, step responses and valve sweeps. Changes only
  /// the result's ranking, step_responses, valve, warnings and partial.
  void explain(OfflineResult* result, const std::function<void(const std::string&)>& progress = {});

  /// The grid the analyses judge: the whole recording's, or evenly spaced whole cycles of a long one.
  const std::vector<GridSample>& grid() const { return grid_.grid(); }
  const IdentificationConfig& config() const { return config_; }

 private:
  IdentificationConfig config_;
  /// The valve model whose spool the grid holds (y_model), with config_.valve_covariance: a sweep analysed
  /// after the reading replaces config_.valve, not the grid's spool.
  ServoValveParameters free_run_valve_;
  int jobs_ = 0;
  double resolution_error_ = 0.0;
  std::string resolution_remedy_;
  IdentificationPipeline pipeline_;
  EvenlyThinnedCycles grid_;
  GridCoverage coverage_;
  std::vector<ValveSample> valve_;
  EstimateSeries estimates_;
  SweepCandidateFilter valve_filter_;
  MessageNoise pressure_noise_;  // the sensor's, for grids finer than its messages
  std::vector<std::pair<double, double>> oil_messages_;  // the oil temperature's accepted (stamp, degC)
  std::uint64_t oil_received_ = 0;
  void endInput();  // flushes the pipeline once
  // The grid's oil temperature from every accepted message (a sample took the newest that had arrived while
  // reading), the model's temperature origin at its mean, and what the topic gave.
  void settleOilTemperature(OfflineResult* result);
  // identify()'s steps: the strokes, the fit to the whole recording, whether it is plausible and whether a
  // parameter changes within it; then the free run's refinement, the stds and the model comparison.
  void fitTheWholeRecording(const HydraulicModel& model, bool velocity, double highest, OfflineResult* result,
                            const std::function<void(const std::string&)>& tell);
  void refineAndCompare(const HydraulicModel& model, OfflineResult* result,
                        const std::function<void(const std::string&)>& tell);
  // Finds and fits a recorded valve sweep; its model becomes the one the fits judge the port side with.
  void analyzeValveSweep(OfflineResult* result, const std::function<void(const std::string&)>& tell);
  // Warns (and says so) where the valve messages are too slow for the recording to tell the amplifier's
  // command hold.
  bool warnIfTheHoldDecidesTheValveFit(const RecordedSweep& sweep,
                                       std::vector<AnalysisWarning>* warnings) const;

  std::uint64_t messages_ = 0;
  bool flushed_ = false;
  bool always_propose_ = false;
};

}  // namespace die_cushion_ident
