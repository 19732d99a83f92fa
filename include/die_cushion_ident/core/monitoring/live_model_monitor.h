#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <deque>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "die_cushion_ident/core/adequacy/effect_ranking.h"
#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"
#include "die_cushion_ident/core/estimation/identification_config.h"
#include "die_cushion_ident/core/estimation/topic_delay_estimator.h"
#include "die_cushion_ident/core/fits/free_run_pressure.h"
#include "die_cushion_ident/core/model/stroke_phase.h"
#include "die_cushion_ident/core/monitoring/live_change_point.h"
#include "die_cushion_ident/core/segmentation/stroke_phase_classifier.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"

namespace die_cushion_ident {

/// How the live model comparison judges and how often it ranks the effect library.
struct LiveMonitorSettings {
  // The node's defaults (~effect_ranking_window, ~effect_ranking_period), so that README, node and core
  // agree.
  double ranking_window = 30.0;  ///< [s] grid samples kept for the ranking (and the step test's timing)
  double ranking_period = 10.0;  ///< [s] of grid time between rankings
};

/// One finished effect ranking of the live window (with the formula search where error is left).
struct LiveRanking {
  EffectRankingResult result;
  int cycles = 0;        ///< press cycles in the window (since `onset` where there is one)
  double seconds = 0.0;  ///< wall-clock duration of the ranking [s]
  /// The plant changed within the window (LiveChangePoint): the ranking judged only the cycles from the
  /// onset on, and its conclusion begins with the change.
  std::optional<LiveOnset> onset;
};

/// The live model comparison of the node, free of ROS: runs the identified model freely next to the
/// measurement on every grid sample, keeps the error per stroke phase, says why it cannot compare when it
/// cannot, and ranks the effect library on a window of the last grid samples on its own thread.
///
/// The ranking takes up to seconds on a long window, so it runs on a copy of the window (std::async):
/// nothing that feeds samples waits for it. restart() (a new model) drops a ranking started before it.
/// After every press cycle the window is checked for a change of the plant (LiveChangePoint); once one is
/// found a ranking starts at once, on the cycles since the change only, and the rankings after it leave the
/// cycles before the change out until they have left the window.
class LiveModelMonitor {
 public:
  /// RLS updates (10 ms each, only while excited) before the comparison counts: about one stroke.
  static constexpr std::uint64_t kUpdatesBeforeComparison = 100;
  /// Compared samples before the error is judged (1 s of the 2 ms grid).
  static constexpr std::uint64_t kSamplesBeforeVerdict = 500;

  LiveModelMonitor(const IdentificationConfig& config, const HydraulicModel& model,
                   LiveMonitorSettings settings);
  /// Waits for a running ranking (its result is dropped).
  ~LiveModelMonitor();

  /// A new model (or new settings): the comparison, the window and the schedule start over, a running
  /// ranking is dropped when it ends. The topic delay estimate is kept: it is the topics', not the model's.
  void restart(const IdentificationConfig& config, const HydraulicModel& model);
  /// The stamps jumped (a bag restarted): the free run starts again at the measured pressure.
  void resync();
  /// The ranking's window and period from the next grid sample on (the node reconfigured live): the window is
  /// cut to, or grows to, the new length; the next ranking is due the new period after the last one. The
  /// comparison, the window's samples and a running ranking go on.
  void setSettings(const LiveMonitorSettings& settings) { settings_ = settings; }
  const LiveMonitorSettings& settings() const { return settings_; }
  /// [Pa] the pressure sensor's noise from its messages, for the rankings where the grid lies between them
  /// (IdentificationConfig::grid_pressure_noise; 0: estimated on the grid).
  void setGridPressureNoise(double sigma) { config_.grid_pressure_noise = sigma; }
  /// The recording's own resolution error [Pa] and what to record instead (the survey's
  /// SettingsChoice::resolution_error and resolution_remedy), for the rankings started from now on: as
  /// offline, an effect whose gain lies within twice it is resolution-limited, not missing, and the floor a
  /// formula search must clear includes it.
  void setResolution(double error, const std::string& remedy) {
    ranking_options_.resolution_error = std::isfinite(error) ? error : 0.0;
    ranking_options_.resolution_remedy = remedy;
  }

  /// One grid sample with the identifier's state after it: the free-run step, the phase, the errors.
  /// Starts a ranking when one is due and none runs; returns a ranking that finished since the last call.
  std::optional<LiveRanking> addSample(const GridSample& g, const HydraulicIdentifier& identifier);

  // ---- the comparison ----
  const GridSample& lastSample() const { return last_; }
  double modelledPressure() const { return modelled_pressure_; }  ///< [Pa], NaN while the model cannot run
  StrokePhase phase() const { return phase_; }
  double simulationErrorRms() const;              ///< [Pa], over about one press cycle
  double phaseErrorRms(StrokePhase phase) const;  ///< [Pa], same weighting, per phase
  std::uint64_t comparedSamples() const { return compared_; }
  std::uint64_t identifierUpdates() const { return updates_; }
  bool estimatorStarted() const { return updates_ >= kUpdatesBeforeComparison; }
  /// Why the last grid sample could not be compared with the model, in words; "" when it could.
  const char* comparisonBlocker() const { return blocker_; }

  // ---- the ranking window ----
  const std::deque<GridSample>& window() const { return window_; }
  const std::optional<EffectRankingResult>& ranking() const { return ranking_; }
  double lastRankingSeconds() const { return last_ranking_seconds_; }  ///< NaN before the first
  bool rankingRunning() const { return job_.valid(); }
  /// Blocks until a running ranking and change check have finished (their results come with the next
  /// sample), for a caller that feeds samples faster than real time (a test, a bag played at full speed).
  void waitForJobs() const {
    if (job_.valid()) job_.wait();
    change_point_.waitForCheck();
  }
  /// The check for a change of the plant within the window, and the last change it found.
  const LiveChangePoint& changePoint() const { return change_point_; }
  /// The last change of the plant while the window still reaches back before it (the ranking leaves the
  /// cycles before it out); null otherwise.
  const LiveOnset* changeWithinWindow() const;

  // ---- the topics' clock offsets, estimated once on the first window with strokes ----
  const std::optional<TopicDelayEstimate>& topicDelayEstimate() const { return delay_estimate_; }
  /// Offsets worth correcting, once: the owner applies them and rebuilds the pipeline.
  std::optional<std::array<double, kInputStreamCount>> takeDelayCorrection();
  /// A new valve model for the rankings from now on (the comparison goes on: the spool it reads is the
  /// pipeline's).
  void setValveModel(const ServoValveParameters& valve, bool drives_free_run) {
    config_.valve = valve;
    config_.valve_model_drives_free_run = drives_free_run;
  }

 private:
  struct Job {
    LiveRanking ranking;
    int generation = 0;
  };
  void startRanking();
  /// The window from the last change of the plant on: what the ranking judges.
  std::vector<GridSample> currentPlantWindow() const;
  std::optional<LiveRanking> collectRanking();

  IdentificationConfig config_;
  LiveMonitorSettings settings_;
  EffectRankingOptions ranking_options_;
  std::unique_ptr<FreeRunPressure> free_run_;
  StrokePhaseClassifier classifier_;

  GridSample last_;
  double modelled_pressure_ = 0.0;
  StrokePhase phase_ = StrokePhase::kRest;
  double square_error_ = 0.0;  // exponentially weighted over ~one cycle of free-run samples
  std::array<double, kStrokePhaseCount> phase_square_error_{};
  std::uint64_t compared_ = 0;
  std::uint64_t updates_ = 0;
  const char* blocker_ = "";

  std::deque<GridSample> window_;
  double last_ranking_time_ = -1e18;
  bool ranking_now_ = false;  // the plant changed: rank the cycles since at once
  std::optional<EffectRankingResult> ranking_;
  double last_ranking_seconds_;
  std::future<Job> job_;
  int generation_ = 0;
  LiveChangePoint change_point_;

  std::optional<TopicDelayEstimate> delay_estimate_;
  bool delays_pending_ = false;
};

}  // namespace die_cushion_ident
