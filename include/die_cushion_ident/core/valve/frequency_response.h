#pragma once

#include <complex>
#include <vector>

#include "die_cushion_ident/core/valve/orthogonal_correlator.h"

namespace die_cushion_ident {

/// One measured point of the valve's frequency response G(jw) = spool phasor / voltage phasor [1/V].
struct FrequencyResponsePoint {
  double frequency = 0.0;  ///< [Hz]
  double re = 0.0, im = 0.0;
  double magnitude = 0.0;      ///< [1/V]
  double phase = 0.0;          ///< [rad]; unwrapped across a sweep by unwrapPhases()
  double magnitude_std = 0.0;  ///< [1/V], from the residual noise of both correlations
  double phase_std = 0.0;      ///< [rad]
  int samples = 0;
  double periods = 0.0;  ///< whole periods integrated
  /// [s] the command hold divided out (0 = continuous). The fit needs it for the alias of the held
  /// staircase's images at k/hold +- f, which the sampled spool folds back onto f.
  double command_hold = 0.0;
  /// Relative change of G between half and all of the integration: small when Re/Im have converged.
  double convergence = 0.0;
  /// Re/Im of G after each integrated period (how the correlation converged).
  std::vector<std::complex<double>> history;
  /// Spool harmonics 2..n relative to the fundamental (spool-velocity saturation, stops, nonlinearity).
  double harmonic_distortion = 0.0;
  /// The harmonics stand out of the noise (chi-square test at 99.9 %).
  bool harmonics_significant = false;
  /// Share of the spool signal's variance not explained by the fundamental (noise and harmonics).
  double unexplained_share = 0.0;
  /// Share of the command voltage not explained by its fundamental: ~0 for a clean sine.
  double command_unexplained_share = 0.0;
  /// harmonics_significant and harmonic_distortion above the configured limit: the valve did not respond
  /// linearly and the point must not be trusted (it is left out of the model fit).
  bool distorted = false;
};

/// Measures one point: correlates command voltage and spool position with the same reference over a time
/// window of whole periods. Samples outside [window_begin, window_end) are ignored.
///
/// The command is held for `command_hold` seconds after each valve sample (the amplifier's update period,
/// 0 = continuous). The held staircase's fundamental lags the samples by w*hold/2 and is scaled by
/// sinc(w*hold/2); the estimator divides that out, so G is the valve's own response and its dead time is
/// not inflated by half an update period.
class FrequencyPointEstimator {
 public:
  struct Options {
    double command_hold = 0.0;     ///< [s]
    int harmonics = 3;             ///< incl. the fundamental; capped below the Nyquist frequency
    double sample_rate = 1000.0;   ///< [Hz] nominal, only to cap the harmonics
    double max_distortion = 0.02;  ///< harmonic distortion above which a significant point is flagged
  };

  FrequencyPointEstimator(double frequency, double window_begin, double periods, const Options& options);

  /// Adds one valve sample; returns true once the window is complete (a sample at or past its end).
  bool add(double t, double voltage, double spool);
  bool complete() const { return complete_; }
  double windowBegin() const { return window_begin_; }
  double windowEnd() const { return window_end_; }
  double frequency() const { return frequency_; }

  /// The point from the samples so far (valid once a few periods are in).
  FrequencyResponsePoint result();

 private:
  std::complex<double> holdResponse() const;
  std::complex<double> response(OrthogonalCorrelator& command, OrthogonalCorrelator& spool) const;

  double frequency_;
  double window_begin_, window_end_;
  double periods_;
  Options options_;
  OrthogonalCorrelator command_, spool_;
  // Fundamental-only correlators for the per-period history (cheap, and one solve per period).
  OrthogonalCorrelator command_history_, spool_history_;
  std::vector<std::complex<double>> history_;
  int next_period_ = 1;
  bool complete_ = false;
};

/// Unwraps the phases of points sorted by frequency, predicting each from the previous one's phase delay
/// (phase proportional to frequency) so that a dead time of several ms at 160 Hz is not folded back.
void unwrapPhases(std::vector<FrequencyResponsePoint>* points);

/// Wraps an angle into (-pi, pi].
double wrapAngle(double angle);

}  // namespace die_cushion_ident
