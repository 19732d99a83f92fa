#pragma once

#include <cstdint>
#include <functional>
#include <future>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "die_cushion_ident/core/estimation/estimate_scatter.h"
#include "die_cushion_ident/core/estimation/identification_pipeline.h"
#include "die_cushion_ident/core/monitoring/health_report.h"
#include "die_cushion_ident/core/monitoring/live_diagnostics.h"
#include "die_cushion_ident/core/monitoring/live_model_monitor.h"
#include "die_cushion_ident/core/settings/settings_from_recording.h"
#include "die_cushion_ident/core/signal/message_noise.h"

namespace die_cushion_ident {

/// How the live identification starts: what the node's parameters say beyond the configuration.
struct LiveIdentificationSettings {
  LiveMonitorSettings monitor;
  /// Choose sample period, filter widths, identification period, velocity window, clock offsets and the
  /// valve model from the first `survey_seconds` of messages (as analyze_bag does), unless configured.
  bool choose_settings = true;
  double survey_seconds = 24.0;  ///< [s] of stamps surveyed
  /// The configuration keys the user set: kept and judged by the survey, never replaced.
  std::set<std::string> configured;
};

/// What an event says, for owners and tests to match by (the words are for people).
enum class LiveEventCode {
  kSurveyed,              ///< the survey's seconds are in: the settings are being chosen
  kSettingsChosen,        ///< the settings chosen from the recording (applied, or as running)
  kSettingsNotChosen,     ///< the study failed: the configured settings stay
  kSettingBiased,         ///< a warning of the study (a configured setting, the valve model, the filters)
  kResolutionLimited,     ///< the recording's rates limit the resolution
  kClockOffsetCorrected,  ///< the topics' stamps offset: corrected, identification restarted
  kTimeBaseRestarted,     ///< the stamps jumped back (a bag played again): identification restarted
};
const char* liveEventCodeName(LiveEventCode code);

/// Something the owner should tell its user (the node logs it; tests read it).
struct LiveEvent {
  HealthLevel level = HealthLevel::kOk;  ///< kOk: information, kWarn: a warning
  LiveEventCode code = LiveEventCode::kSurveyed;
  std::string text;
};

/// The live identification free of ROS: the pipeline (resampling, filters, RLS), the model comparison and
/// ranking (LiveModelMonitor), and the decisions taken on the data as they come — one place for each:
/// - the settings survey: the first seconds of messages are kept, SettingsFromRecording chooses the
///   resolution on another thread (the same study as analyze_bag), and the pipeline is rebuilt with it
///   where it differs (the identification then starts over on the chosen grid);
/// - the clock offsets: the monitor's on its first ranking window with strokes, superseded by the survey's
///   (finer, on all its seconds) once the study is done;
/// - stamps that jump back (rosbag play --loop): the pipeline restarts, counted and timed.
/// A change of model (setEffects), settings or offsets never happens inside a pipeline callback: it is
/// applied after the message that triggered it.
class LiveIdentification {
 public:
  /// Every grid sample, with the identifier after it and a ranking that finished since the last sample.
  using GridCallback =
      std::function<void(const GridSample&, const HydraulicIdentifier&, const std::optional<LiveRanking>&)>;
  using StepCallback = IdentificationPipeline::StepCallback;

  LiveIdentification(const IdentificationConfig& config, LiveIdentificationSettings settings);
  /// Waits for a running survey study (its result is dropped).
  ~LiveIdentification();
  void setCallbacks(GridCallback on_grid, StepCallback on_step);

  /// One input message (stamps in seconds, values in SI). The resampler's verdict on it.
  UniformResampler::PushResult push(InputStream stream, const StreamSample& sample);
  /// One message of the optional oil temperature topic (`sample.first` in degC): the grid samples carry it
  /// from now on (the oil_temperature effect reads it). Its checks' verdict (OilTemperatureInput).
  UniformResampler::PushResult pushOilTemperature(const StreamSample& sample) {
    return pipeline_->pushOilTemperature(sample);
  }
  /// Takes a finished settings study (push does so too): for an owner whose messages have stopped.
  void poll();
  /// What happened since the last call, oldest first.
  std::vector<LiveEvent> takeEvents();

  /// A new model: problems (empty: applied, the estimator restarted).
  std::vector<std::string> setEffects(const std::vector<std::string>& effects,
                                      const std::vector<std::string>& custom_effects);
  /// The estimator from its initial values again (the settings and offsets chosen so far are kept).
  void restart();
  /// The valve identified by a sweep: predicts an unmeasured spool from now on, and the survey's valve
  /// model from the operation no longer replaces it.
  void setValveModel(const ServoValveParameters& valve);
  /// The live ranking's window and period from now on, kept across rebuilds (LiveModelMonitor::setSettings).
  void setMonitorSettings(const LiveMonitorSettings& monitor) {
    settings_.monitor = monitor;
    monitor_->setSettings(monitor);
  }

  const IdentificationConfig& config() const { return config_; }
  const IdentificationPipeline& pipeline() const { return *pipeline_; }
  /// The identifier's estimate with each std the larger of its own (the regression's Newey-West sandwich)
  /// and the estimate's scatter over the last 50 s of press cycles (EstimateScatter): what is published.
  HydraulicEstimate estimate() const;
  const LiveModelMonitor& monitor() const { return *monitor_; }
  /// The clock offsets' state for the timing diagnostic (joint fields left to the owner).
  TimingState timing() const;
  /// The settings diagnostic: surveying, what was chosen and why, or the configured values.
  HealthReport settingsHealth() const;
  /// The survey's choice, once made.
  const std::optional<SettingsChoice>& settingsChoice() const { return choice_; }
  bool surveying() const { return survey_ != nullptr || study_.valid(); }
  /// Counts the pipeline's rebuilds (a new model, settings or offsets): the owner compares it to tell.
  std::uint64_t generation() const { return generation_; }

 private:
  void rebuild();
  /// A new survey of the messages from now on, on the user's offsets (not those corrected since).
  void startSurvey();
  void onGridSample(const GridSample& g, const HydraulicIdentifier& identifier);
  void surveyMessage(InputStream stream, const StreamSample& sample);
  void collectStudy();
  void adopt(const SettingsChoice& choice);
  void applyDelayCorrection();
  void event(HealthLevel level, LiveEventCode code, std::string text) {
    events_.push_back({level, code, std::move(text)});
  }

  IdentificationConfig config_;
  LiveIdentificationSettings settings_;
  std::unique_ptr<IdentificationPipeline> pipeline_;
  std::unique_ptr<LiveModelMonitor> monitor_;
  GridCallback on_grid_;
  StepCallback on_step_;
  std::vector<LiveEvent> events_;
  MessageNoise pressure_noise_;   // the sensor's, for grids finer than its messages
  EstimateScatter scatter_{1.0};  // of the converged live estimate, over kScatterHorizon

  std::unique_ptr<SettingsFromRecording> survey_;  // while messages are kept
  std::future<SettingsChoice> study_;              // while the study runs
  std::optional<SettingsChoice> choice_;
  std::string study_failure_;  // why the study threw, if it did
  bool valve_from_sweep_ = false;
  bool delays_configured_;  // by the user: neither the monitor nor the survey replaces them
  std::uint64_t generation_ = 0;

  // [s] the newest accepted input stamp, and the one at which the stamps last jumped back (NaN: never).
  double newest_stamp_ = std::numeric_limits<double>::quiet_NaN();
  double last_restart_stamp_ = std::numeric_limits<double>::quiet_NaN();
  // Counted here: a change of settings or offsets rebuilds the pipeline, and its resampler's count with it.
  std::uint64_t time_base_restarts_ = 0;
};

}  // namespace die_cushion_ident
