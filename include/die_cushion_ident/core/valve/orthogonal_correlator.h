#pragma once

#include <Eigen/Dense>
#include <complex>

namespace die_cushion_ident {

/// Orthogonal correlation of a sampled signal with sin and cos of a known frequency and its harmonics:
///   value(t) ~ c + sum_k [ a_k sin(k w tau) + b_k cos(k w tau) ],   tau = t - time_origin,
/// solved as least squares over the samples added so far. Over whole periods of a uniform grid the normal
/// matrix is diagonal and this is the classic correlation a_k = 2/N sum value sin(k w tau); the
/// least-squares form stays exact on jittered stamps and on windows that are not an integer number of
/// samples per period (30 Hz at 1 kHz). The phasor of harmonic k is a_k + j b_k: a sine reference has
/// phasor 1, so the frequency response is the ratio of output and input phasors.
class OrthogonalCorrelator {
 public:
  static constexpr int kMaxHarmonics = 5;

  /// frequency [Hz] > 0, harmonics in [1, kMaxHarmonics] (the fundamental counts as harmonic 1).
  OrthogonalCorrelator(double frequency, int harmonics, double time_origin);

  void add(double t, double value);
  void reset();

  int samples() const { return samples_; }
  int harmonics() const { return harmonics_; }
  double frequency() const { return frequency_; }
  /// True once there are more samples than unknowns.
  bool solvable() const { return samples_ > unknowns(); }

  /// Least-squares solution; call solve() after adding samples and before the accessors below.
  void solve();
  std::complex<double> phasor(int harmonic) const;
  double mean() const { return solution_(0) + value_origin_; }
  /// Variance of one component (a_k or b_k) of a phasor, from the residual (white-noise assumption).
  double phasorComponentVariance(int harmonic) const;
  /// Residual variance after removing the mean and all harmonics.
  double residualVariance() const { return residual_variance_; }
  /// Variance of the signal around its mean (everything the correlation is asked to explain).
  double acVariance() const { return ac_variance_; }

 private:
  int unknowns() const { return 1 + 2 * harmonics_; }

  double frequency_;
  int harmonics_;
  double time_origin_;
  double omega_;
  double value_origin_ = 0.0;  // first value, subtracted to keep the sums of squares well conditioned
  int samples_ = 0;
  Eigen::MatrixXd normal_;
  Eigen::VectorXd moment_;
  double sum_squares_ = 0.0;
  Eigen::VectorXd solution_;
  Eigen::MatrixXd inverse_;
  double residual_variance_ = 0.0;
  double ac_variance_ = 0.0;
};

}  // namespace die_cushion_ident
