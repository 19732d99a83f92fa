#pragma once

#include <optional>
#include <string>
#include <vector>

namespace die_cushion_ident {

/// One recording's estimate of one parameter.
struct TrendPoint {
  double stamp = 0.0;  ///< [s] start of the recording (seconds since the epoch)
  double value = 0.0;  ///< in the parameter's SI unit
  double std = 0.0;    ///< its reported standard deviation
};

/// A change found in a parameter's series (doc/condition_monitoring.md).
struct ParameterChange {
  std::string shape;            ///< "step" (a jump) or "drift" (a ramp that starts)
  std::size_t start_index = 0;  ///< the first recording after the change began
  double start_stamp = 0.0;     ///< [s] its start
  double before = 0.0;          ///< the level before the change
  double after = 0.0;           ///< the level at the last recording
  double statistic = 0.0;       ///< the likelihood-ratio statistic
  double threshold = 0.0;       ///< what it had to exceed (Bonferroni over every change point and shape)
  double day_to_day_std = 0.0;  ///< the variation between recordings beyond their stds, estimated
};

struct ChangeDetectionOptions {
  /// Probability of reporting a change in a series without one (per series; a caller testing several
  /// series divides its own rate among them).
  double false_alarm_rate = 0.01;
  int min_baseline = 3;  ///< recordings before a change point, at least
};

/// A step or a starting drift in a series of estimates, by a generalised likelihood-ratio test with the
/// points' own stds. Each point has variance std^2 + tau^2; tau^2, the variation between recordings that
/// their stds do not cover (temperature, load, the stds' own error), is estimated robustly from the second
/// differences, which neither a step nor a ramp disturbs much. Under no change, for a fixed change point,
/// the drop of the weighted residual sum of squares is chi-square with 1 degree of freedom, F(1, nu) with
/// tau^2 estimated (nu = 0.64 (n - 2), the median's efficiency); the largest over every change point (at
/// least `min_baseline` points before it) and both shapes must pass the Bonferroni threshold for
/// `false_alarm_rate`. Nothing with fewer than min_baseline + 3 points, or non-finite input.
std::optional<ParameterChange> detectParameterChange(const std::vector<TrendPoint>& series,
                                                     const ChangeDetectionOptions& options = {});

/// The change in words for maintenance: "leakage_conductance has risen 2.8-fold (1.1e-12 -> 3.1e-12
/// m^3/(s*Pa)) since 2026-03-04: a worn piston seal or valve leakage". `since` is the date in words.
std::string explainChange(const std::string& parameter, const std::string& unit, const ParameterChange& change,
                          const std::string& since);

/// "2026-03-04T06:00:00Z" for a stamp in seconds since the epoch (UTC).
std::string isoTime(double stamp);

}  // namespace die_cushion_ident
