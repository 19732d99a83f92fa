#pragma once

#include <ros/node_handle.h>

#include <limits>
#include <set>
#include <string>
#include <vector>

#include "die_cushion_ident/core/control/feed_forward_output.h"
#include "die_cushion_ident/core/estimation/identification_config.h"
#include "die_cushion_ident/core/monitoring/live_identification.h"
#include "die_cushion_ident/core/valve/valve_sweep.h"
#include "feed_forward_publisher.h"

namespace die_cushion_ident {

/// Settings of the live node beyond the identification and sweep configuration.
struct NodeSettings {
  double adequacy_warn_error = 3e5;    ///< [Pa] free-run pressure error RMS above which the model is doubtful
  double adequacy_error_error = 10e5;  ///< [Pa] ... and above which it is wrong
  double effect_ranking_window = 30.0;  ///< [s] of recent data the live effect ranking looks at
  double effect_ranking_period = 10.0;  ///< [s] between two rankings
  std::string joint_name;  ///< the cushion's joint in the position topic; "" = the only one, else index 0
  /// [1/V] the valve's static gain for ~feed_forward until a sweep identifies the valve; NaN: no
  /// feed-forward before a sweep (an unknown valve gain must not become a command).
  double valve_gain = std::numeric_limits<double>::quiet_NaN();
  double feed_forward_max_age = 0.05;     ///< [s] an older pressure_setpoint (stamp or arrival) is not used
  double feed_forward_slew_rate = 100.0;  ///< [V/s] fastest change of the feed-forward command (steady time)
  double feed_forward_parameter_rate = 0.5;  ///< [1/s] fastest relative change of a parameter it uses
  double feed_forward_max_lead = 0.03;       ///< [s] longest lag of the valve the set-point is previewed over
  double feed_forward_rate_window = 0.02;    ///< [s] the set-point's rate: its slope over this window
  double feed_forward_max_setpoint_rate = 2e9;  ///< [Pa/s] the set-point's rate is never taken beyond this
  bool feed_forward_enabled = true;             ///< at start (~enable_feed_forward switches it later)
  /// Choose the sample period, filters, clock offsets and valve model from the first `survey_seconds` of
  /// messages (the settings study analyze_bag runs), unless configured.
  bool choose_settings = true;
  double survey_seconds = 24.0;  ///< [s]
};

/// The feed-forward's output stage: inside the requested safe command range on both sides, slew-limited.
FeedForwardOutputLimits feedForwardOutputLimits(const NodeSettings& settings, const SweepLimits& limits);
/// The feed-forward's inverse: its set-point stream and interlock limits.
FeedForwardPublisher::Settings feedForwardSettings(const NodeSettings& settings, const SweepLimits& limits);

/// The live ranking's window and period from the node's settings.
LiveMonitorSettings liveMonitorSettings(const NodeSettings& settings);
/// The configuration keys among the private parameters (kept and judged by the settings survey).
std::set<std::string> configuredKeys(const ros::NodeHandle& pnh);
/// The live identification's settings from the node's (and which keys the user configured).
LiveIdentificationSettings liveIdentificationSettings(const NodeSettings& settings,
                                                      const ros::NodeHandle& pnh);

/// A list of strings: a YAML list, or one string "a,b" / "[a, b]" as given on a command line (commas
/// inside parentheses stay: a custom effect may hold max(p, 0)). Problems are appended to `problems`.
void readStrings(const ros::NodeHandle& pnh, const std::string& key, std::vector<std::string>* out,
                 std::vector<std::string>* problems);

/// What is wrong with the live thresholds (adequacy_*_error, effect_ranking_*), as "~name = value is invalid:
/// allowed ..."; empty when they are usable. Checked at start-up and on every dynamic_reconfigure request.
std::vector<std::string> liveThresholdProblems(const NodeSettings& settings);

/// Reads the private parameters (same names as the analyze_bag config keys) into `config`, `limits` and
/// `settings`. Returns every problem as "~name = value is invalid: allowed ..."; empty when all are usable.
std::vector<std::string> loadParameters(const ros::NodeHandle& pnh, IdentificationConfig* config,
                                        SweepLimits* limits, NodeSettings* settings);

}  // namespace die_cushion_ident
