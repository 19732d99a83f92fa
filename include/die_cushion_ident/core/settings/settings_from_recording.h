#pragma once

#include <array>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "die_cushion_ident/core/adequacy/analysis_warning.h"
#include "die_cushion_ident/core/estimation/identification_config.h"
#include "die_cushion_ident/core/estimation/topic_delay_estimator.h"
#include "die_cushion_ident/core/valve/valve_operation_fit.h"

namespace die_cushion_ident {

/// What the first seconds of a recording say about the resolution the analysis needs.
struct RecordingSurvey {
  double seconds = 0.0;  ///< [s] of stamps surveyed
  std::array<double, kInputStreamCount> message_interval = {0.0, 0.0, 0.0};  ///< [s] median per topic
  double pressure_noise = 0.0;  ///< [Pa] white noise of the pressure messages
  int cycles = 0;               ///< complete press cycles in the survey
  double shortest_drawing = 0.0;  ///< [s] the shortest drawing phase seen (0: none)
  bool spool_measured = false;
};

/// One candidate sample period of the resolution study: the model identified once on the survey at the
/// finest period, run free on this period's grid.
struct ResolutionCandidate {
  double sample_period = 0.0;       ///< [s]
  double simulation_error_rms = 0.0;  ///< [Pa] free run against the measurement
  /// [Pa] rms difference of its free run from the next finer period's (same parameters), at the
  /// samples both have; NaN for the finest. This is the resolution's share of the error: a free run that
  /// is resolved no longer changes as the period halves.
  double change_to_finer = std::numeric_limits<double>::quiet_NaN();
  double bulk_modulus = 0.0;  ///< [Pa] of the one fit the study runs (for the report)
};

/// A setting the analysis chose (or took from the configuration), and why.
struct ChosenSetting {
  std::string key;
  double value = 0.0;
  bool configured = false;  ///< the user's value, kept
  std::string reason;
};

/// The settings chosen for a recording.
struct SettingsChoice {
  IdentificationConfig config;  ///< the configuration with the chosen settings
  RecordingSurvey survey;
  std::vector<ChosenSetting> settings;  ///< sample_period, moving_average_width, derivative_width, identification_period
  std::vector<ResolutionCandidate> study;  ///< coarsest first
  std::optional<ValveOperationFit> valve;  ///< the valve model fitted to the survey's operation (spool measured)
  /// The topics' clock offsets estimated on the survey at the finest period the recording supports (where
  /// topic_delays is not configured), and whether they were applied (distinguishable from 0).
  std::optional<TopicDelayEstimate> delays;
  bool delays_applied = false;
  bool valve_from_operation = false;       ///< that fit replaced the configured valve model
  /// [s] how much the free run moved the position's estimated offset, where it refined it (its std is then
  /// delays->resolution: 0.1 ms, as far off as it came over the press classes).
  std::optional<double> position_delay_shift;
  /// [s] where the free run refined the topics' common offset against the pressure too (the offsets were
  /// applied), how much later it read the pressure: the valve's offset moved by minus it, the position's
  /// shift above includes it.
  double pressure_delay_shift = 0.0;
  /// [s] the position's and the common shift's sandwich stds, where the common offset was tried (NaN
  /// elsewhere).
  double position_delay_std = std::numeric_limits<double>::quiet_NaN();
  double pressure_delay_std = std::numeric_limits<double>::quiet_NaN();
  double pressure_delay_prior = 0.0;  ///< [s] the common offset's resolution before (its search's unit)
  /// [Pa] the free run's change from the chosen period to half of it: its own resolution error.
  double resolution_error = 0.0;
  /// The configured model's free run did not converge as the period halved (or moved with its own
  /// tolerance): the model fails, and no resolution error is claimed (resolution_error NaN).
  bool resolution_not_converging = false;
  /// [Pa] the free run's error from the position topic's message rate (where it is slower than the grid;
  /// NaN otherwise): by Richardson's estimate from the free runs on every second and fourth position message.
  /// Part of resolution_error (added in quadrature to the grid's).
  double position_rate_error = std::numeric_limits<double>::quiet_NaN();
  /// [Pa] how much the free run depends on commands between the valve topic's messages (where they come
  /// fewer than 4 per period of the valve's natural frequency and the spool is measured; NaN otherwise): the
  /// rms difference between the free runs with each command held to the next message and with one more
  /// command between each two, the valve model fitted to the spool under each. Part of resolution_error.
  double valve_rate_error = std::numeric_limits<double>::quiet_NaN();
  /// [Pa] the free run's numerical error at the chosen period: its difference from a run with a twenty times
  /// tighter tolerance.
  double numerical_error = std::numeric_limits<double>::quiet_NaN();
  /// Non-empty when the recording's rates, not the analysis, limit the resolution: the finding in words and
  /// what to record instead (resolution_remedy alone).
  std::string resolution_limit;
  std::string resolution_remedy;
  std::vector<AnalysisWarning> warnings;  ///< a configured value that biases the result on this recording
  double seconds_spent = 0.0;          ///< [s] wall time of choose()
  /// [s] Where it went: the clock offsets (their search and the position offset's refinement by the free
  /// run: estimates the analysis makes without a survey too, on the whole recording), the valve model fitted
  /// to the operation (on the other core, beside the offsets: its own wall time), and the rest, the choice
  /// itself (the survey's rates and noise, the grids, fit and free runs of the resolution study, and any
  /// wait for the valve model). clock_offsets + resolution_study = seconds_spent.
  struct Spent {
    double clock_offsets = 0.0, valve_model = 0.0, resolution_study = 0.0;
  } seconds_spent_on;
};

/// Whether the user configured the valve model (any of its keys): without a measured spool the model then is
/// theirs to answer for, not the default's.
bool valveModelConfigured(const std::set<std::string>& configured_keys);

/// Without a survey (analyze_bag --fixed-settings, the node's ~choose_settings false) nothing fits the valve
/// model to the operation: a configured one is taken as it is and drives the free run. The survey lets a
/// model drive it only where it follows the measured spool; without one the measured spool's noise drove
/// it, which a shut valve integrates: a clean fast press given the very settings and valve model the survey
/// had chosen ran 3.9 bar off (0.21 bar with the survey) and was told its error was structured.
void takeConfiguredValveModel(const std::set<std::string>& configured_keys, IdentificationConfig* config);

/// Without a survey the valve model drives the free run from the recorded commands, each held to the next
/// valve message, and nothing measures what commands between the messages would change (the survey's study
/// of the valve topic's rate, SettingsChoice::valve_rate_error). Where the messages come fewer than 4 per
/// period of the valve's natural frequency and valve_command_hold does not say the amplifier holds each a
/// whole message interval, a warning's text (else empty): a clean fast press with its valve reported at
/// 500 Hz by a 1 kHz controller, given its true valve model, ran 3.9 bar off and was told its error was
/// structured. `valve_interval` [s]: the valve topic's mean message interval.
std::string valveRateUnstudiedWarning(const IdentificationConfig& config, double valve_interval);

/// The paper's settings study (§5) run on the recording itself, before the analysis: the first
/// `survey_seconds` of messages are kept; their message rates, pressure noise and press cycles are surveyed,
/// the valve model is fitted to the commands and spool of operation (when the spool is measured), the
/// topics' clock offsets are estimated at the finest period the recording supports (a 2 ms grid left a
/// small stiff chamber's 0.5 ms off), and the model is identified and run free at 2, 1, 0.5 and 0.25 ms (no
/// finer than half the finest topic's message interval). The coarsest sample period whose free run changes by
/// less than kResolutionShare of the pressure noise when the period halves is chosen: a coarser grid throws
/// away what the recording holds (a fast press's 4 ms impact on the paper's 2 ms grid), a finer one only
/// costs. The filters keep the paper's windows in time (62 ms moving average, 50 ms derivative: 31 and 25
/// samples at 2 ms), shortened to half the shortest drawing phase; the identification period stays 10 ms.
/// Settings the user configured are kept and judged against the study (a warning where they leave a
/// resolution error above the share).
class SettingsFromRecording {
 public:
  static constexpr double kResolutionShare = 0.25;
  SettingsFromRecording(const IdentificationConfig& config, std::set<std::string> configured_keys,
                        double survey_seconds = 24.0, std::size_t max_messages = 400000);

  /// Threads for the study's output-error refinement (0: one per core; 1, the default, where the study runs
  /// beside live work).
  void setJobs(int jobs) { jobs_ = jobs; }
  /// Keeps a message for the survey; false once the survey is complete (later messages are not kept).
  bool push(InputStream stream, const StreamSample& sample);
  bool complete() const { return complete_; }
  /// The study on what was kept (whatever there is, at the end of a short recording).
  SettingsChoice choose() const;
  /// The topics' clock offsets alone, as choose() finds them (searched at the finest period the kept
  /// messages support, the position's refined by the free run of the model as configured), for an analysis
  /// whose settings are fixed. Its own grid at the paper's 2 ms gave a clean small stiff press's position
  /// -0.55 ms, applied it, and the free run ran 6.8 times the noise, "structured"; at 1 ms here 0.01 ms.
  TopicDelayEstimate clockOffsets() const;
  /// The kept messages in arrival order, for the analysis to start with.
  const std::vector<std::pair<InputStream, StreamSample>>& messages() const { return messages_; }

 private:
  IdentificationConfig config_;
  std::set<std::string> configured_;
  double survey_seconds_;
  std::size_t max_messages_;
  int jobs_ = 1;
  std::vector<std::pair<InputStream, StreamSample>> messages_;
  double first_stamp_ = std::numeric_limits<double>::quiet_NaN();
  bool complete_ = false;
};

}  // namespace die_cushion_ident
