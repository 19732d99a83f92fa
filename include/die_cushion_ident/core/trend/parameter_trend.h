#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace die_cushion_ident {

/// One recording's estimate of one parameter.
struct TrendPoint {
  double stamp = 0.0;  ///< [s] start of the recording (seconds since the epoch)
  double value = 0.0;  ///< in the parameter's SI unit
  double std = 0.0;    ///< its reported standard deviation
  /// What the value may follow besides wear: the oil temperature [degC] the recording was made at, regressed
  /// out over the baseline (SelfStartingCusum); NaN where none was recorded.
  double covariate = std::numeric_limits<double>::quiet_NaN();
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
  /// [value per covariate unit] the baseline's regression on the covariate at the alarm (NaN: none); `before`
  /// and `after` are then taken at the baseline's mean covariate.
  double slope = std::numeric_limits<double>::quiet_NaN();
  double covariate = std::numeric_limits<double>::quiet_NaN();  ///< that mean
};

/// The smallest step of a parameter that the sequential test would report within `within` recordings with
/// probability `probability`, given the history it has (SelfStartingCusum::smallestDetectableChange).
struct DetectableChange {
  double step =
      std::numeric_limits<double>::quiet_NaN();  ///< in the parameter's unit; NaN: too short a history
  double level = std::numeric_limits<double>::quiet_NaN();  ///< the baseline's level it is measured against
  double scatter =
      std::numeric_limits<double>::quiet_NaN();  ///< the baseline's scatter about its level (or line)
  std::size_t baseline = 0;                      ///< recordings in the baseline
  bool regressed = false;                        ///< the baseline regressed on the covariate
  int within = 3;
  double probability = 0.9;
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
  /// [covariate unit] the baseline is regressed on the covariate (the oil temperature) only where its
  /// covariates spread this much (std): a press always recorded at the same temperature is left alone.
  double min_covariate_spread = 0.5;
  /// Compare the logarithms of the values where all are positive (detectChangesSequentially): a relative
  /// error of the oil's law is then a line in the temperature, which the regression takes out exactly (on the
  /// values themselves a law 1 %/K off over 25-65 degC bent the line, and the false alarms rose to 1.2 times
  /// the design). The changes and detectable steps are reported back in the values' unit.
  bool relative = false;
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
/// reported stds and the day-to-day variation they miss are both in s). Where the recordings carry a
/// covariate (the oil temperature) that spreads over the baseline, the baseline is a least-squares line in it
/// instead of a mean (a regression-adjusted control chart): T = (x_n - line(c_n)) / (s sqrt(1 + 1/m + (c_n -
/// c_mean)^2 / S_cc)), Student's t with m - 2 degrees of freedom, s the scatter about the line: what the
/// weather moves is not counted as wear, and what the oil's law left of it is regressed out. S+ = max(0, S+ +
/// U - k), S- alike; an alarm where either exceeds h. The change is dated by maximum likelihood among the
/// recordings since the CUSUM last stood at 0; the baseline restarts with the next recording (the alarm's own
/// are a biased sample of the new regime). A recording is tested once, when it arrives: adding one never
/// re-tests the past, and a later recording cannot move an earlier alarm.
class SelfStartingCusum {
 public:
  explicit SelfStartingCusum(const SequentialDetectionOptions& options = {});
  /// The next recording, in time order; a change when it raises the alarm. Non-finite points are skipped.
  std::optional<ParameterChange> add(const TrendPoint& point);
  double threshold() const { return threshold_; }
  /// The smallest step, from the next recording on, that this test reports within `within` recordings with
  /// probability `probability`, with the history it has: measured by simulation (`draws` futures of the
  /// baseline's own scatter and covariates, a fixed seed), so that the self-starting standardisation, its
  /// few degrees of freedom early on and the baseline taking in the shifted recordings are all in it.
  DetectableChange smallestDetectableChange(int within = 3, double probability = 0.9, int draws = 200) const;

 private:
  /// The in-control recordings' mean (or line in the covariate) and scatter.
  struct Baseline {
    std::size_t m = 0;
    double mean = 0.0;      ///< of the values (at the covariates' mean where regressed)
    double scatter2 = 0.0;  ///< about the mean or line
    double reported = 0.0;  ///< the mean of the reported variances
    double slope = std::numeric_limits<double>::quiet_NaN();  ///< per covariate unit, where regressed
    double covariate_mean = 0.0, covariate_squares = 0.0;
    double degrees = 0.0;  ///< of the scatter
    bool regressed() const { return std::isfinite(slope); }
    double predict(double covariate) const {
      return regressed() ? mean + slope * (covariate - covariate_mean) : mean;
    }
  };
  /// The `m` recordings in control, against which `point` is judged (regressed where it and they carry
  /// covariates that spread).
  Baseline baselineFor(const TrendPoint& point, std::size_t m) const;
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
/// level reached (`after`: the regime's mean, or a drift's line at its end). `detectable` (may be null)
/// receives the smallest change the test can see after the newest recording.
std::vector<ParameterChange> detectChangesSequentially(const std::vector<TrendPoint>& series,
                                                       const SequentialDetectionOptions& options = {},
                                                       DetectableChange* detectable = nullptr);

/// The change in words for maintenance: "leakage_conductance has risen 2.8-fold (1.1e-12 -> 3.1e-12
/// m^3/(s*Pa)) since 2026-03-04: a worn piston seal or valve leakage". `since` is the date in words.
std::string explainChange(const std::string& parameter, const std::string& unit,
                          const ParameterChange& change, const std::string& since);

/// "2026-03-04T06:00:00Z" for a stamp in seconds since the epoch (UTC).
std::string isoTime(double stamp);

}  // namespace die_cushion_ident
