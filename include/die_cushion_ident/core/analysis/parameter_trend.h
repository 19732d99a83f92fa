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
  std::size_t start_index = 0;  ///< the first recording after the change began (of the finite ones)
  double start_stamp = 0.0;     ///< [s] its start
  std::size_t alarm_index = 0;  ///< the recording that raised the alarm (what was known then decided it)
  double alarm_stamp = 0.0;     ///< [s] its start
  double before = 0.0;          ///< the level before the change (the recordings in control)
  double after = 0.0;      ///< the level since the change began (detectChangesSequentially: its regime's)
  double statistic = 0.0;  ///< the CUSUM at the alarm, in units of the recordings' own scatter
  double threshold = 0.0;  ///< what it had to exceed
};

/// How the sequential test is designed: its average run length between false alarms.
struct SequentialDetectionOptions {
  /// Recordings between two false alarms on a steady series, on average (the in-control ARL). analyze_trend
  /// sets it from the false alarms per press-year allowed and the recordings a press makes in a year.
  double recordings_between_false_alarms = 22500.0;
  /// The step to detect fastest, in units of the recordings' scatter (the CUSUM's reference is half of it).
  double shift = 2.0;
  /// Recordings in control before the first test (the self-starting standardisation needs their scatter).
  int warm_up = 4;
};

/// The in-control average run length of a one-sided CUSUM on standard normal steps with reference k and
/// threshold h (Brook and Evans's Markov chain, 240 states).
double cusumRunLength(double threshold, double reference);
/// The threshold h of the two-sided scheme with reference k = shift / 2 whose in-control average run length
/// is `recordings_between_false_alarms` (each side twice that), solved on cusumRunLength. The self-starting
/// scheme's own rate is measured by simulation in test_parameter_trend.
double cusumThreshold(const SequentialDetectionOptions& options);

/// A two-sided self-starting CUSUM (Hawkins 1987) over one parameter's series, one recording at a time.
/// Each recording is standardised against the mean and scatter of the recordings in control before it: T =
/// (x_n - mean) / (s sqrt(1 + 1/m)) is Student's t with m - 1 degrees of freedom for m earlier points, and
/// U = Phi^-1(F_t(T)) exactly standard normal on a steady series, whatever its level and scatter (the
/// reported stds and the day-to-day variation they miss are both in s). S+ = max(0, S+ + U - k), S- alike;
/// an alarm where either exceeds h. The change is dated by maximum likelihood among the recordings since
/// the CUSUM last stood at 0; the baseline restarts with the next recording (the alarm's own are a biased
/// sample of the new regime). A recording is tested once, when it
/// arrives: adding one never re-tests the past, and a later recording cannot move an earlier alarm.
class SelfStartingCusum {
 public:
  explicit SelfStartingCusum(const SequentialDetectionOptions& options = {});
  /// The next recording, in time order; a change when it raises the alarm. Non-finite points are skipped.
  std::optional<ParameterChange> add(const TrendPoint& point);
  double threshold() const { return threshold_; }

 private:
  void restartFrom(std::size_t first);
  /// The newest recording as a standard normal score against the in-control ones before it (`baseline`
  /// of them); NaN where their scatter is 0.
  double normalScore(const TrendPoint& point, std::size_t baseline) const;
  /// The alarm raised by the recording at `index`, dated and shaped.
  ParameterChange describeAlarm(std::size_t index, bool rise) const;

  SequentialDetectionOptions options_;
  double threshold_, reference_;
  std::vector<TrendPoint> points_;              // every recording added (their count indexes the alarms)
  std::size_t baseline_begin_ = 0;              // the in-control recordings: [baseline_begin_, end)
  double high_ = 0.0, low_ = 0.0;               // S+ and S-
  std::size_t high_start_ = 0, low_start_ = 0;  // the recording after each last stood at 0
};

/// Every change in a series, as SelfStartingCusum finds them adding one recording after the other, each
/// then described by its whole regime (up to the next change or the newest recording): its shape and the
/// level reached (`after`: the regime's mean, or a drift's line at its end).
std::vector<ParameterChange> detectChangesSequentially(const std::vector<TrendPoint>& series,
                                                       const SequentialDetectionOptions& options = {});

/// The change in words for maintenance: "leakage_conductance has risen 2.8-fold (1.1e-12 -> 3.1e-12
/// m^3/(s*Pa)) since 2026-03-04: a worn piston seal or valve leakage". `since` is the date in words.
std::string explainChange(const std::string& parameter, const std::string& unit,
                          const ParameterChange& change, const std::string& since);

/// "2026-03-04T06:00:00Z" for a stamp in seconds since the epoch (UTC).
std::string isoTime(double stamp);

}  // namespace die_cushion_ident
