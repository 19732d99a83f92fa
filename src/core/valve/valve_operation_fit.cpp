#include "die_cushion_ident/core/valve/valve_operation_fit.h"

#include <ceres/ceres.h>

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <limits>

#include "die_cushion_ident/core/signal/white_noise_estimator.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "die_cushion_ident/core/util/parallel_numeric_diff.h"

namespace die_cushion_ident {

namespace {

// Parameters as Ceres sees them: log natural frequency [log Hz], log damping, gain [1/V], dead time [ms].
constexpr int kParameters = 4;
constexpr std::size_t kSearchSamples = 3000;

ServoValveParameters fromVector(const double* v) {
  ServoValveParameters p;
  p.natural_frequency = std::exp(v[0]);
  p.damping = std::exp(v[1]);
  p.gain = v[2];
  p.dead_time = std::max(v[3], 0.0) * 1e-3;
  return p;
}

// Measured minus modelled spool at every sample (0 at a command without a spool reading), the model
// restarted at the measurement (else where it was) after a gap.
void residuals(const std::vector<ValveSample>& samples, const ServoValveParameters& valve, double max_gap,
               double* out) {
  ServoValve model = ServoValve::exact(valve);
  double last_t = -std::numeric_limits<double>::infinity(), last_u = 0.0;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const ValveSample& s = samples[k];
    const double dt = s.t - last_t;
    const bool measured = std::isfinite(s.spool);
    const double y = dt > 0.0 && dt <= max_gap
                         ? model.advance(dt, last_u)
                         : (model.reset(measured ? s.spool : model.position()), model.position());
    out[k] = measured ? s.spool - y : 0.0;
    last_t = s.t;
    last_u = s.voltage;
  }
}

struct OutputError {
  const std::vector<ValveSample>* samples;
  double max_gap;
  bool operator()(double const* const* parameters, double* out) const {
    residuals(*samples, fromVector(parameters[0]), max_gap, out);
    for (std::size_t k = 0; k < samples->size(); ++k) {
      if (!std::isfinite(out[k])) return false;  // Ceres then shortens its step
    }
    return true;
  }
};

// Over the `measured` samples (the others' residuals are 0).
double rms(const std::vector<double>& r, std::size_t measured) {
  double sum = 0.0;
  for (double e : r) sum += e * e;
  return measured == 0 ? 0.0 : std::sqrt(sum / measured);
}

// Ceres on the output error from `v` (changed in place); the final cost. The starts' search takes forward
// differences (half the free runs of central ones; the valve fit then no longer outlasted the clock offsets'
// search it runs beside on a fast press: 0.06 -> 0.045 s), the refinement on all samples central ones: the
// fitted valves of the four press classes moved by at most 0.002 Hz and 0.01 us.
// The Jacobian's columns on up to `jobs` threads (ParallelNumericDiffCost: Ceres's differences bit for bit).
template <ceres::NumericDiffMethodType kMethod>
double solveOutputError(const std::vector<ValveSample>& samples, double max_gap, int iterations, double* v,
                        int jobs = 1) {
  ceres::Problem problem;
  // Steps of a thousandth of each parameter: the model's stretches are timed to the nanosecond
  // (ServoValve's cache), and a dead time moved by less would not move them.
  ceres::NumericDiffOptions differences;
  differences.relative_step_size = 1e-3;
  auto* cost =
      new ParallelNumericDiffCost<OutputError, kMethod>(OutputError{&samples, max_gap}, differences, jobs);
  cost->AddParameterBlock(kParameters);
  cost->SetNumResiduals(static_cast<int>(samples.size()));
  problem.AddResidualBlock(cost, nullptr, v);
  problem.SetParameterLowerBound(v, 0, std::log(5.0));
  problem.SetParameterUpperBound(v, 0, std::log(2000.0));
  problem.SetParameterLowerBound(v, 1, std::log(0.1));
  problem.SetParameterUpperBound(v, 1, std::log(3.0));
  problem.SetParameterLowerBound(v, 3, 0.0);
  problem.SetParameterUpperBound(v, 3, 20.0);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = iterations;
  options.function_tolerance = 1e-5;  // a thousandth of the noise's share of the cost
  // No projected line search (refineByOutputError says why: a Jacobian more per candidate).
  options.max_num_line_search_step_size_iterations = 0;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  return summary.final_cost;
}

}  // namespace

namespace {

// The samples with a finite stamp and command, in time order, from the first with a measured spool on (the
// model starts there), up to max_samples.
std::vector<ValveSample> usableSamples(const std::vector<ValveSample>& all, std::size_t max_samples) {
  std::vector<ValveSample> samples;
  for (const ValveSample& s : all) {
    if (samples.size() >= max_samples) break;
    if (std::isfinite(s.t) && std::isfinite(s.voltage) && (std::isfinite(s.spool) || !samples.empty()) &&
        (samples.empty() || s.t > samples.back().t)) {
      samples.push_back(s);
    }
  }
  return samples;
}

// The search samples' squared spool error at the gain that fits them best, for a valve's other parameters.
// The exact model is linear in its target K u(t - T_dead), and a reset holds the target at the measured spool
// until the first command arrives, whatever K: the spool is A + K B, A and B from two runs at gains +g and -g
// (small, so that no run reaches the stop), and the best gain and its cost follow in closed form.
double costAtBestGain(const std::vector<ValveSample>& search, ServoValveParameters valve, double max_gap,
                      double* gain) {
  constexpr double kProbeGain = 1e-3;
  std::vector<double> plus(search.size()), minus(search.size());
  valve.gain = kProbeGain;
  residuals(search, valve, max_gap, plus.data());
  valve.gain = -kProbeGain;
  residuals(search, valve, max_gap, minus.data());
  // With r = s - y: s - A = (r+ + r-) / 2 and B = (r- - r+) / (2 g).
  double ab = 0.0, bb = 0.0, aa = 0.0;
  for (std::size_t k = 0; k < search.size(); ++k) {
    const double a = 0.5 * (plus[k] + minus[k]), b = (minus[k] - plus[k]) / (2.0 * kProbeGain);
    ab += a * b;
    bb += b * b;
    aa += a * a;
  }
  if (!(bb > 0.0) || !std::isfinite(aa + ab + bb)) return std::numeric_limits<double>::infinity();
  *gain = ab / bb;
  return aa - ab * ab / bb;
}

// The starts the fit is run from: a screen of natural frequencies (0.3 to 5 times the start's) and dead
// times (none to 6 ms) at the start's damping, each at its best gain; the lowest two that are not neighbours
// on the screen. A start far off settles in a local minimum where the natural frequency trades against the
// dead time (104 Hz and no dead time for a 164 Hz, 0.85 ms valve, its spool residual only 7 % above the
// sensor's noise; a fast press's 203 Hz, 0.79 ms valve, from the default 80 Hz and 2 ms, ended at 121 Hz and
// none from five of the six fixed starts this screen replaces; a 300 Hz, 0.3 ms valve ended at 237 Hz and
// none from all six, and from a screen that reached 3.2 times the start). The screen's 49 points cost two
// runs each, where each fixed start took up to a hundred: the valve fit then outlasted the clock offsets'
// search beside it on a fast press.
std::vector<std::array<double, kParameters>> screenedStarts(const std::vector<ValveSample>& search,
                                                            const ServoValveParameters& start,
                                                            double max_gap) {
  constexpr double kFrequencyFactors[] = {0.3, 0.5, 0.8, 1.25, 2.0, 3.2, 5.0};
  constexpr double kDeadTimes[] = {0.0, 0.25, 0.5, 1.0, 2.0, 3.5, 6.0};  // [ms]
  struct Point {
    double cost;
    int f, t;
    std::array<double, kParameters> v;
  };
  std::vector<Point> screen;
  ServoValveParameters valve = start;
  valve.damping = std::clamp(start.damping, 0.1, 3.0);
  for (int f = 0; f < static_cast<int>(std::size(kFrequencyFactors)); ++f) {
    valve.natural_frequency = std::clamp(start.natural_frequency * kFrequencyFactors[f], 5.0, 2000.0);
    for (int t = 0; t < static_cast<int>(std::size(kDeadTimes)); ++t) {
      valve.dead_time = 1e-3 * kDeadTimes[t];
      double gain = start.gain;
      const double cost = costAtBestGain(search, valve, max_gap, &gain);
      if (!std::isfinite(cost) || !std::isfinite(gain) || gain == 0.0) continue;
      screen.push_back(
          {cost, f, t, {std::log(valve.natural_frequency), std::log(valve.damping), gain, kDeadTimes[t]}});
    }
  }
  std::sort(screen.begin(), screen.end(), [](const Point& a, const Point& b) { return a.cost < b.cost; });
  std::vector<std::array<double, kParameters>> starts;
  std::vector<const Point*> taken;
  for (const Point& p : screen) {
    if (taken.size() >= 2) break;
    bool neighbour = false;
    for (const Point* q : taken) neighbour |= std::abs(p.f - q->f) <= 1 && std::abs(p.t - q->t) <= 1;
    if (neighbour) continue;
    taken.push_back(&p);
    starts.push_back(p.v);
  }
  if (starts.empty()) {  // no point followed the commands: the start as it is
    starts.push_back({std::log(std::clamp(start.natural_frequency, 5.0, 2000.0)), std::log(valve.damping),
                      std::isfinite(start.gain) && start.gain != 0.0 ? start.gain : 0.1,
                      std::clamp(start.dead_time * 1e3, 0.0, 20.0)});
  }
  return starts;
}

// The screened starts fitted on the search samples; the best kept in `best`.
void bestStart(const std::vector<ValveSample>& search, const ServoValveParameters& start, double max_gap,
               double best[kParameters]) {
  double best_cost = std::numeric_limits<double>::infinity();
  for (std::array<double, kParameters> v : screenedStarts(search, start, max_gap)) {
    const double cost = solveOutputError<ceres::FORWARD>(search, max_gap, 20, v.data());
    if (cost < best_cost) {
      best_cost = cost;
      std::copy(v.begin(), v.end(), best);
    }
  }
}

// s^2 (J'J)^-1 of the fitted parameters in physical units (natural_frequency, damping, gain, dead_time), J
// by central differences in the fit's own units (forward where the dead time is at its bound of 0), s^2 the
// residual's mean square over the measured samples less the four parameters. Zero where J'J is singular.
Eigen::Matrix4d parameterCovariance(const std::vector<ValveSample>& samples, const double fitted[kParameters],
                                    double max_gap, const std::vector<double>& residual,
                                    std::size_t measured) {
  Eigen::MatrixXd jacobian(samples.size(), kParameters);
  std::vector<double> plus(samples.size()), minus(samples.size());
  for (int i = 0; i < kParameters; ++i) {
    double v[kParameters];
    std::copy(fitted, fitted + kParameters, v);
    const double h = 1e-3 * std::max(std::abs(fitted[i]), i == 2 ? 1e-6 : 0.1);
    const bool forward = i == 3 && fitted[i] < h;
    v[i] = fitted[i] + h;
    residuals(samples, fromVector(v), max_gap, plus.data());
    v[i] = forward ? fitted[i] : fitted[i] - h;
    residuals(samples, fromVector(v), max_gap, minus.data());
    // r = s - y: dy/dv = -(dr/dv)
    for (std::size_t k = 0; k < samples.size(); ++k)
      jacobian(k, i) = -(plus[k] - minus[k]) / (forward ? h : 2.0 * h);
  }
  double sum = 0.0;
  for (double e : residual) sum += e * e;
  if (measured <= kParameters || !jacobian.allFinite()) return Eigen::Matrix4d::Zero();
  const double variance = sum / static_cast<double>(measured - kParameters);
  const Eigen::Matrix4d information = jacobian.transpose() * jacobian;
  const Eigen::FullPivLU<Eigen::Matrix4d> lu(information);
  if (!lu.isInvertible()) return Eigen::Matrix4d::Zero();
  // d natural_frequency = f d log f, d damping = D d log D, d dead_time = 1e-3 d (dead time in ms).
  const Eigen::Vector4d physical(std::exp(fitted[0]), std::exp(fitted[1]), 1.0, 1e-3);
  return physical.asDiagonal() * (variance * lu.inverse()) * physical.asDiagonal();
}

}  // namespace

ValveOperationFit fitValveToOperation(const std::vector<ValveSample>& all, const ServoValveParameters& start,
                                      double max_gap, std::size_t max_samples, int jobs) {
  ValveOperationFit fit;
  fit.parameters = start;
  const std::vector<ValveSample> samples = usableSamples(all, max_samples);
  std::vector<double> spool;  // the measured ones
  for (const ValveSample& s : samples) {
    if (std::isfinite(s.spool)) spool.push_back(s.spool);
  }
  fit.samples = static_cast<int>(spool.size());
  if (spool.size() < 200) {
    fit.message = "too few valve messages with a measured spool (" + std::to_string(spool.size()) + ")";
    return fit;
  }
  WhiteNoiseEstimator noise(1);
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (std::size_t k = 1; k + 1 < spool.size(); ++k) {
    noise.add(spool[k - 1], spool[k], spool[k + 1]);
    low = std::min(low, spool[k]);
    high = std::max(high, spool[k]);
  }
  fit.noise_sigma = noise.sigma();
  if (!(high - low > 20.0 * fit.noise_sigma)) {
    fit.message = "the spool hardly moved (range " + formatted(FMT_STRING("{:.3g}"), high - low) +
                  ", noise " + formatted(FMT_STRING("{:.2g}"), fit.noise_sigma) + ")";
    return fit;
  }
  std::vector<double> r(samples.size());
  residuals(samples, start, max_gap, r.data());
  fit.start_residual_rms = rms(r, spool.size());
  // The starts are searched on the first stretch, the best refined on all: the spool near a valve's overlap
  // decides the flow, and 3000 samples left a 160 Hz valve at 164 Hz (a 0.6 bar free-run error on a fast
  // press whose flow starts at 3 % opening); refined on up to 15000 it came to 161-162 Hz.
  const std::vector<ValveSample> search(samples.begin(),
                                        samples.begin() + std::min(samples.size(), kSearchSamples));
  double best[kParameters] = {0.0, 0.0, 0.0, 0.0};
  bestStart(search, start, max_gap, best);
  if (samples.size() > search.size()) solveOutputError<ceres::CENTRAL>(samples, max_gap, 10, best, jobs);
  fit.parameters = fromVector(best);
  fit.parameters.max_spool_velocity = start.max_spool_velocity;
  residuals(samples, fit.parameters, max_gap, r.data());
  fit.residual_rms = rms(r, spool.size());
  fit.success = std::isfinite(fit.residual_rms) && fit.residual_rms <= 3.0 * fit.noise_sigma;
  if (fit.success) fit.covariance = parameterCovariance(samples, best, max_gap, r, spool.size());
  fit.message = formatted(
      FMT_STRING("{:.1f} Hz, damping {:.2f}, gain {:.4g} 1/V, dead time {:.2f} ms from {} valve messages of "
                 "operation: spool residual {:.2g} against a sensor noise of {:.2g} ({:.2g} with the model "
                 "it started from)"),
      fit.parameters.natural_frequency, fit.parameters.damping, fit.parameters.gain,
      1e3 * fit.parameters.dead_time, fit.samples, fit.residual_rms, fit.noise_sigma, fit.start_residual_rms);
  if (!fit.success) fit.message = "the valve model does not follow the spool: " + fit.message;
  return fit;
}

}  // namespace die_cushion_ident
