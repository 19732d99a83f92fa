#include "die_cushion_ident/core/valve/valve_operation_fit.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "die_cushion_ident/core/signal/white_noise_estimator.h"
#include "die_cushion_ident/core/util/formatted.h"

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

// Measured minus modelled spool at every sample, the model restarted at the measurement after a gap.
void residuals(const std::vector<ValveSample>& samples, const ServoValveParameters& valve, double max_gap,
               double* out) {
  ServoValve model = ServoValve::exact(valve);
  double last_t = -std::numeric_limits<double>::infinity(), last_u = 0.0;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const ValveSample& s = samples[k];
    const double dt = s.t - last_t;
    const double y = dt > 0.0 && dt <= max_gap ? model.advance(dt, last_u) : (model.reset(s.spool), s.spool);
    out[k] = s.spool - y;
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

double rms(const std::vector<double>& r) {
  double sum = 0.0;
  for (double e : r) sum += e * e;
  return r.empty() ? 0.0 : std::sqrt(sum / r.size());
}

// Ceres on the output error from `v` (changed in place); the final cost. The starts' search takes forward
// differences (half the free runs of central ones; the valve fit then no longer outlasted the clock offsets'
// search it runs beside on a fast press: 0.06 -> 0.045 s), the refinement on all samples central ones: the
// fitted valves of the four press classes moved by at most 0.002 Hz and 0.01 us.
template <ceres::NumericDiffMethodType kMethod>
double solveOutputError(const std::vector<ValveSample>& samples, double max_gap, int iterations, double* v) {
  ceres::Problem problem;
  // Steps of a thousandth of each parameter: the model's stretches are timed to the nanosecond
  // (ServoValve's cache), and a dead time moved by less would not move them.
  ceres::NumericDiffOptions differences;
  differences.relative_step_size = 1e-3;
  auto* cost = new ceres::DynamicNumericDiffCostFunction<OutputError, kMethod>(
      new OutputError{&samples, max_gap}, ceres::TAKE_OWNERSHIP, differences);
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
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  return summary.final_cost;
}

}  // namespace

namespace {

// The finite samples with a measured spool, in time order, up to max_samples.
std::vector<ValveSample> usableSamples(const std::vector<ValveSample>& all, std::size_t max_samples) {
  std::vector<ValveSample> samples;
  for (const ValveSample& s : all) {
    if (samples.size() >= max_samples) break;
    if (std::isfinite(s.t) && std::isfinite(s.voltage) && std::isfinite(s.spool) &&
        (samples.empty() || s.t > samples.back().t)) {
      samples.push_back(s);
    }
  }
  return samples;
}

// From the starting model and from starts at half and twice its natural frequency and other dead times,
// the best kept: a start far off settles in a local minimum where the natural frequency trades against the
// dead time (104 Hz and no dead time for a 164 Hz, 0.85 ms valve, its spool residual only 7 % above the
// sensor's noise). Fills `best`.
void bestStart(const std::vector<ValveSample>& search, const ServoValveParameters& start, double max_gap,
               double best[kParameters]) {
  double best_cost = std::numeric_limits<double>::infinity();
  for (const auto& [f_factor, dead_time_factor] :
       {std::pair<double, double>{1.0, 1.0}, {0.5, 1.0}, {2.0, 1.0}, {1.0, 0.4}, {2.0, 0.4}, {0.5, 2.0}}) {
    double v[kParameters] = {std::log(std::clamp(start.natural_frequency * f_factor, 5.0, 2000.0)),
                             std::log(std::clamp(start.damping, 0.1, 3.0)), start.gain,
                             std::clamp(start.dead_time * dead_time_factor * 1e3, 0.0, 20.0)};
    if (!std::isfinite(v[2]) || v[2] == 0.0) v[2] = 0.1;
    const double cost = solveOutputError<ceres::FORWARD>(search, max_gap, 20, v);
    if (cost < best_cost) {
      best_cost = cost;
      std::copy(v, v + kParameters, best);
    }
  }
}

}  // namespace

ValveOperationFit fitValveToOperation(const std::vector<ValveSample>& all, const ServoValveParameters& start,
                                      double max_gap, std::size_t max_samples) {
  ValveOperationFit fit;
  fit.parameters = start;
  const std::vector<ValveSample> samples = usableSamples(all, max_samples);
  fit.samples = static_cast<int>(samples.size());
  if (samples.size() < 200) {
    fit.message = "too few valve messages with a measured spool (" + std::to_string(samples.size()) + ")";
    return fit;
  }
  WhiteNoiseEstimator noise(1);
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (std::size_t k = 1; k + 1 < samples.size(); ++k) {
    noise.add(samples[k - 1].spool, samples[k].spool, samples[k + 1].spool);
    low = std::min(low, samples[k].spool);
    high = std::max(high, samples[k].spool);
  }
  fit.noise_sigma = noise.sigma();
  if (!(high - low > 20.0 * fit.noise_sigma)) {
    fit.message = "the spool hardly moved (range " + formatted("%.3g", high - low) + ", noise " +
                  formatted("%.2g", fit.noise_sigma) + ")";
    return fit;
  }
  std::vector<double> r(samples.size());
  residuals(samples, start, max_gap, r.data());
  fit.start_residual_rms = rms(r);
  // The starts are searched on the first stretch, the best refined on all: the spool near a valve's overlap
  // decides the flow, and 3000 samples left a 160 Hz valve at 164 Hz (a 0.6 bar free-run error on a fast
  // press whose flow starts at 3 % opening); refined on up to 15000 it came to 161-162 Hz.
  const std::vector<ValveSample> search(samples.begin(),
                                        samples.begin() + std::min(samples.size(), kSearchSamples));
  double best[kParameters] = {0.0, 0.0, 0.0, 0.0};
  bestStart(search, start, max_gap, best);
  if (samples.size() > search.size()) solveOutputError<ceres::CENTRAL>(samples, max_gap, 10, best);
  fit.parameters = fromVector(best);
  fit.parameters.max_spool_velocity = start.max_spool_velocity;
  residuals(samples, fit.parameters, max_gap, r.data());
  fit.residual_rms = rms(r);
  fit.success = std::isfinite(fit.residual_rms) && fit.residual_rms <= 3.0 * fit.noise_sigma;
  fit.message = formatted("%.1f Hz, damping %.2f, gain %.4g 1/V, dead time %.2f ms from %.0f valve messages of "
                          "operation: spool residual %.2g against a sensor noise of %.2g (%.2g with the model "
                          "it started from)",
                          fit.parameters.natural_frequency, fit.parameters.damping, fit.parameters.gain,
                          1e3 * fit.parameters.dead_time, fit.samples, fit.residual_rms, fit.noise_sigma,
                          fit.start_residual_rms);
  if (!fit.success) fit.message = "the valve model does not follow the spool: " + fit.message;
  return fit;
}

}  // namespace die_cushion_ident
