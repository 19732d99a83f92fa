#include "die_cushion_ident/core/valve/orthogonal_correlator.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace die_cushion_ident {

OrthogonalCorrelator::OrthogonalCorrelator(double frequency, int harmonics, double time_origin)
    : frequency_(frequency), harmonics_(harmonics), time_origin_(time_origin) {
  if (!(std::isfinite(frequency) && frequency > 0.0)) {
    throw std::invalid_argument("correlator frequency must be > 0 Hz, got " + std::to_string(frequency));
  }
  if (harmonics < 1 || harmonics > kMaxHarmonics) {
    throw std::invalid_argument("correlator harmonics must be in [1, " + std::to_string(kMaxHarmonics) +
                                "], got " + std::to_string(harmonics));
  }
  omega_ = 2.0 * M_PI * frequency;
  reset();
}

void OrthogonalCorrelator::reset() {
  samples_ = 0;
  value_origin_ = 0.0;
  normal_ = Eigen::MatrixXd::Zero(unknowns(), unknowns());
  moment_ = Eigen::VectorXd::Zero(unknowns());
  sum_squares_ = 0.0;
  solution_ = Eigen::VectorXd::Zero(unknowns());
  inverse_ = Eigen::MatrixXd::Zero(unknowns(), unknowns());
  residual_variance_ = ac_variance_ = 0.0;
}

void OrthogonalCorrelator::add(double t, double value) {
  if (!std::isfinite(t) || !std::isfinite(value)) return;
  if (samples_ == 0) value_origin_ = value;
  const double centred = value - value_origin_;
  Eigen::Matrix<double, 1 + 2 * kMaxHarmonics, 1> basis;
  const double angle = omega_ * (t - time_origin_);
  basis(0) = 1.0;
  for (int k = 1; k <= harmonics_; ++k) {
    basis(2 * k - 1) = std::sin(k * angle);
    basis(2 * k) = std::cos(k * angle);
  }
  const auto phi = basis.head(unknowns());
  normal_.selfadjointView<Eigen::Lower>().rankUpdate(phi);
  moment_ += phi * centred;
  sum_squares_ += centred * centred;
  ++samples_;
}

void OrthogonalCorrelator::solve() {
  if (!solvable()) {
    solution_.setZero();
    inverse_.setZero();
    residual_variance_ = ac_variance_ = 0.0;
    return;
  }
  const Eigen::MatrixXd normal = normal_.selfadjointView<Eigen::Lower>();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(normal);
  solution_ = ldlt.solve(moment_);
  inverse_ = ldlt.solve(Eigen::MatrixXd::Identity(unknowns(), unknowns()));
  const double explained = solution_.dot(moment_);
  const double residual_sum = std::max(sum_squares_ - explained, 0.0);
  residual_variance_ = residual_sum / (samples_ - unknowns());
  const double mean = moment_(0) / samples_;
  ac_variance_ = std::max(sum_squares_ / samples_ - mean * mean, 0.0);
}

std::complex<double> OrthogonalCorrelator::phasor(int harmonic) const {
  if (harmonic < 1 || harmonic > harmonics_) return {0.0, 0.0};
  return {solution_(2 * harmonic - 1), solution_(2 * harmonic)};
}

double OrthogonalCorrelator::phasorComponentVariance(int harmonic) const {
  if (harmonic < 1 || harmonic > harmonics_) return 0.0;
  const double trace = inverse_(2 * harmonic - 1, 2 * harmonic - 1) + inverse_(2 * harmonic, 2 * harmonic);
  return 0.5 * trace * residual_variance_;
}

}  // namespace die_cushion_ident
