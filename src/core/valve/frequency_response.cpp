#include "die_cushion_ident/core/valve/frequency_response.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace die_cushion_ident {

namespace {
int harmonicsBelowNyquist(double frequency, const FrequencyPointEstimator::Options& options) {
  const int below = static_cast<int>(std::ceil(0.5 * options.sample_rate / frequency) - 1);  // k f < Nyquist
  return std::clamp(std::min(options.harmonics, below), 1, OrthogonalCorrelator::kMaxHarmonics);
}

// Upper 99.9 % point of chi-square with `dof` degrees of freedom (Wilson-Hilferty, within 1 % for dof >= 2).
double chiSquare999(int dof) {
  const double z = 3.090232;
  const double a = 2.0 / (9.0 * dof);
  const double c = 1.0 - a + z * std::sqrt(a);
  return dof * c * c * c;
}
}  // namespace

double wrapAngle(double angle) {
  double wrapped = std::remainder(angle, 2.0 * M_PI);
  if (wrapped <= -M_PI) wrapped += 2.0 * M_PI;
  return wrapped;
}

FrequencyPointEstimator::FrequencyPointEstimator(double frequency, double window_begin, double periods,
                                                 const Options& options)
    : frequency_(frequency),
      window_begin_(window_begin),
      window_end_(window_begin + periods / frequency),
      periods_(periods),
      options_(options),
      command_(frequency, harmonicsBelowNyquist(frequency, options), window_begin),
      spool_(frequency, harmonicsBelowNyquist(frequency, options), window_begin),
      command_history_(frequency, 1, window_begin),
      spool_history_(frequency, 1, window_begin) {
  if (!(periods >= 1.0)) throw std::invalid_argument("a frequency point needs at least one period");
}

bool FrequencyPointEstimator::add(double t, double voltage, double spool) {
  if (complete_) return true;
  if (t >= window_end_) {
    complete_ = true;
    return true;
  }
  if (t < window_begin_ || !std::isfinite(voltage) || !std::isfinite(spool)) return false;
  // A period is complete when the first sample past its end arrives.
  const double period_end = window_begin_ + next_period_ / frequency_;
  if (t >= period_end) {
    command_history_.solve();
    spool_history_.solve();
    history_.push_back(response(command_history_, spool_history_));
    ++next_period_;
  }
  command_.add(t, voltage);
  spool_.add(t, spool);
  command_history_.add(t, voltage);
  spool_history_.add(t, spool);
  return false;
}

std::complex<double> FrequencyPointEstimator::holdResponse() const {
  if (!(options_.command_hold > 0.0)) return {1.0, 0.0};
  const double half = M_PI * frequency_ * options_.command_hold;  // w * hold / 2
  return std::polar(std::sin(half) / half, -half);
}

std::complex<double> FrequencyPointEstimator::response(OrthogonalCorrelator& command,
                                                       OrthogonalCorrelator& spool) const {
  const std::complex<double> input = command.phasor(1) * holdResponse();
  if (std::abs(input) == 0.0) return {0.0, 0.0};
  return spool.phasor(1) / input;
}

FrequencyResponsePoint FrequencyPointEstimator::result() {
  FrequencyResponsePoint point;
  point.frequency = frequency_;
  point.command_hold = options_.command_hold > 0.0 ? options_.command_hold : 0.0;
  command_.solve();
  spool_.solve();
  point.samples = spool_.samples();
  point.periods = periods_;
  if (!spool_.solvable()) return point;

  const std::complex<double> g = response(command_, spool_);
  point.re = g.real();
  point.im = g.imag();
  point.magnitude = std::abs(g);
  point.phase = std::arg(g);

  const std::complex<double> y1 = spool_.phasor(1), u1 = command_.phasor(1);
  const double relative_variance =
      (std::norm(y1) > 0.0 ? spool_.phasorComponentVariance(1) / std::norm(y1) : 0.0) +
      (std::norm(u1) > 0.0 ? command_.phasorComponentVariance(1) / std::norm(u1) : 0.0);
  point.phase_std = std::sqrt(relative_variance);
  point.magnitude_std = point.magnitude * point.phase_std;

  double harmonic_power = 0.0, chi_square = 0.0;
  for (int k = 2; k <= spool_.harmonics(); ++k) {
    harmonic_power += std::norm(spool_.phasor(k));
    const double variance = spool_.phasorComponentVariance(k);
    if (variance > 0.0) chi_square += std::norm(spool_.phasor(k)) / variance;
  }
  const int dof = 2 * (spool_.harmonics() - 1);
  point.harmonic_distortion = std::norm(y1) > 0.0 ? std::sqrt(harmonic_power / std::norm(y1)) : 0.0;
  point.harmonics_significant = dof > 0 && chi_square > chiSquare999(dof);
  point.distorted = point.harmonics_significant && point.harmonic_distortion > options_.max_distortion;
  const auto unexplained = [](const OrthogonalCorrelator& c) {
    const double ac = c.acVariance();
    return ac > 0.0 ? std::clamp(1.0 - 0.5 * std::norm(c.phasor(1)) / ac, 0.0, 1.0) : 0.0;
  };
  point.unexplained_share = unexplained(spool_);
  point.command_unexplained_share = unexplained(command_);

  point.history = history_;
  if (history_.size() >= 2) {
    const std::complex<double> half = history_[history_.size() / 2 - 1];
    point.convergence = std::abs(g) > 0.0 ? std::abs(g - half) / std::abs(g) : 0.0;
  }
  return point;
}

void unwrapPhases(std::vector<FrequencyResponsePoint>* points) {
  auto& p = *points;
  std::sort(p.begin(), p.end(), [](const auto& a, const auto& b) { return a.frequency < b.frequency; });
  if (p.empty()) return;
  p[0].phase = wrapAngle(p[0].phase);
  // At zero frequency the phase is 0, or pi for a valve wired with inverted polarity.
  const double static_phase = std::abs(p[0].phase) > 0.5 * M_PI ? std::copysign(M_PI, p[0].phase) : 0.0;
  for (std::size_t i = 1; i < p.size(); ++i) {
    // Phase lag grows about in proportion to frequency (dead time), so extrapolate from the static phase.
    const double predicted =
        static_phase + (p[i - 1].phase - static_phase) * p[i].frequency / p[i - 1].frequency;
    p[i].phase = predicted + wrapAngle(p[i].phase - predicted);
  }
}

}  // namespace die_cushion_ident
