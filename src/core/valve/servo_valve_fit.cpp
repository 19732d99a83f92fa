#include "die_cushion_ident/core/valve/servo_valve_fit.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace die_cushion_ident {

namespace {

struct MagnitudeResidual {
  double frequency, magnitude, sigma;

  template <typename T>
  bool operator()(const T* const x, T* residual) const {
    // x = [natural frequency, damping, |gain|]
    const T ratio = T(frequency) / x[0];
    const T real = T(1.0) - ratio * ratio;
    const T imag = T(2.0) * x[1] * ratio;
    residual[0] = (x[2] / sqrt(real * real + imag * imag) - T(magnitude)) / T(sigma);
    return true;
  }
};

// The complex response the sweep measures at `frequency`: the valve's own G(f) plus the images of the held
// command at f + m/hold, which the spool sampled at the command updates folds back onto f. For a zero-order
// hold the image's weight relative to the fundamental is H(f + m fu) / H(f) = f / (f + m fu), real
// (doc/valve_sweep.md). Without a hold (continuous command) only m = 0 is left.
struct ComplexResidual {
  double frequency, re, im, sigma, update_rate;
  static constexpr int kImages = 2;

  template <typename T>
  void addResponse(const T* const x, double nu, double weight, T* re_out, T* im_out) const {
    // x = [natural frequency, damping, gain, dead time]; valid for negative nu (a real system).
    const T ratio = T(nu) / x[0];
    const T a = T(1.0) - ratio * ratio;
    const T b = T(2.0) * x[1] * ratio;
    const T angle = T(2.0 * M_PI * nu) * x[3];
    const T c = cos(angle), s = sin(angle);
    const T scale = T(weight) * x[2] / (a * a + b * b);
    *re_out += scale * (c * a - s * b);
    *im_out -= scale * (c * b + s * a);
  }

  template <typename T>
  bool operator()(const T* const x, T* residual) const {
    T re_model(0.0), im_model(0.0);
    addResponse(x, frequency, 1.0, &re_model, &im_model);
    if (update_rate > 0.0) {
      for (int m = -kImages; m <= kImages; ++m) {
        if (m == 0) continue;
        const double nu = frequency + m * update_rate;
        addResponse(x, nu, frequency / nu, &re_model, &im_model);
      }
    }
    residual[0] = (re_model - T(re)) / T(sigma);
    residual[1] = (im_model - T(im)) / T(sigma);
    return true;
  }
};

double unitMagnitude(double frequency, double natural_frequency, double damping) {
  const double r = frequency / natural_frequency;
  return 1.0 / std::hypot(1.0 - r * r, 2.0 * damping * r);
}

double secondOrderPhase(double frequency, double natural_frequency, double damping) {
  const double r = frequency / natural_frequency;
  return -std::atan2(2.0 * damping * r, 1.0 - r * r);  // in (-pi, 0]
}

struct WeightedPoint {
  double f, m, sigma, phase, phase_sigma;
  double re, im;
  double update_rate;  ///< [Hz] 1 / command hold; 0 for a continuous command
};

// Best (natural frequency, damping, gain) on a log grid; the gain is linear and solved in closed form.
void gridStart(const std::vector<WeightedPoint>& points, double x[3]) {
  double best = std::numeric_limits<double>::infinity();
  const double f_low = points.front().f, f_high = points.back().f;
  for (int i = 0; i <= 120; ++i) {
    const double f0 = 0.3 * f_low * std::pow(30.0 * f_high / (0.3 * f_low), i / 120.0);
    for (int j = 0; j <= 40; ++j) {
      const double damping = 0.05 * std::pow(60.0, j / 40.0);
      double gg = 0.0, gm = 0.0;
      for (const auto& p : points) {
        const double g = unitMagnitude(p.f, f0, damping) / p.sigma;
        gg += g * g;
        gm += g * p.m / p.sigma;
      }
      const double gain = gm / gg;
      const double cost = -gm * gm / gg;  // sum of squares minus the constant sum (m/sigma)^2
      if (cost < best) {
        best = cost;
        x[0] = f0;
        x[1] = damping;
        x[2] = gain;
      }
    }
  }
}

// Dead time by weighted least squares through the origin on the phase left after the 2nd-order phase: the
// joint fit's start.
double fitDeadTime(const std::vector<WeightedPoint>& points, double static_phase, double f0, double damping) {
  double swo = 0.0, sww = 0.0;
  for (const auto& p : points) {
    const double left = p.phase - static_phase - secondOrderPhase(p.f, f0, damping);
    const double w = 1.0 / (p.phase_sigma * p.phase_sigma);
    const double omega = 2.0 * M_PI * p.f;
    swo += w * omega * left;
    sww += w * omega * omega;
  }
  return -swo / sww;
}

}  // namespace

std::complex<double> servoValveResponse(const ServoValveParameters& parameters, double frequency) {
  const double r = frequency / parameters.natural_frequency;
  const std::complex<double> second_order(1.0 - r * r, 2.0 * parameters.damping * r);
  return parameters.gain * std::polar(1.0, -2.0 * M_PI * frequency * parameters.dead_time) / second_order;
}

namespace {

// The undistorted, finite points with their noise; counts the distorted ones in `fit`.
std::vector<WeightedPoint> weightedPoints(const std::vector<FrequencyResponsePoint>& measured,
                                          ServoValveFit& fit) {
  std::vector<WeightedPoint> points;
  for (const auto& p : measured) {
    if (p.distorted) {
      ++fit.points_rejected;
      continue;
    }
    if (!(p.magnitude > 0.0 && std::isfinite(p.magnitude) && std::isfinite(p.phase))) continue;
    // A floor on the noise keeps one very clean point from dominating a model that is not exact.
    const double sigma = std::max(p.magnitude_std, 1e-3 * p.magnitude);
    const double phase_sigma = std::max(p.phase_std, 1e-3);
    const double update_rate = p.command_hold > 0.0 ? 1.0 / p.command_hold : 0.0;
    points.push_back({p.frequency, p.magnitude, sigma, p.phase, phase_sigma, p.re, p.im, update_rate});
  }
  return points;
}

ceres::Solver::Options solverOptions() {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = 200;
  options.function_tolerance = 1e-12;
  options.parameter_tolerance = 1e-12;
  options.logging_type = ceres::SILENT;
  return options;
}

// Natural frequency and damping inside the bounds the sweep's frequencies can tell.
void boundFrequencyAndDamping(ceres::Problem& problem, double* x, const std::vector<WeightedPoint>& points) {
  problem.SetParameterLowerBound(x, 0, 1e-2 * points.front().f);
  problem.SetParameterUpperBound(x, 0, 1e3 * points.back().f);
  problem.SetParameterLowerBound(x, 1, 1e-3);
  problem.SetParameterUpperBound(x, 1, 20.0);
}

// x = [natural frequency, damping, |gain|] fitted to the magnitudes from the grid's start; "" or why not.
std::string fitMagnitudes(const std::vector<WeightedPoint>& points, double x[3]) {
  gridStart(points, x);
  ceres::Problem problem;
  for (const auto& p : points) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<MagnitudeResidual, 1, 3>(new MagnitudeResidual{p.f, p.m, p.sigma}),
        nullptr, x);
  }
  boundFrequencyAndDamping(problem, x, points);
  problem.SetParameterLowerBound(x, 2, 0.0);
  ceres::Solver::Summary summary;
  ceres::Solve(solverOptions(), &problem, &summary);
  return summary.IsSolutionUsable() ? "" : "the magnitude fit did not converge: " + summary.message;
}

// The magnitude-then-phase fit is only the start: natural frequency, damping, gain and dead time are fitted
// jointly to the complex points, with the held command's images, so that the covariance sees how the
// phase constrains f0 and D and the dead time is not fitted to the 2nd-order phase of a biased f0.
// y = [natural frequency, damping, gain, dead time]; fills the fit's stds and chi-square; "" or why not.
std::string fitComplexResponse(const std::vector<WeightedPoint>& points, double y[4], ServoValveFit& fit) {
  ceres::Problem joint;
  for (const auto& p : points) {
    joint.AddResidualBlock(new ceres::AutoDiffCostFunction<ComplexResidual, 2, 4>(
                               new ComplexResidual{p.f, p.re, p.im, p.sigma, p.update_rate}),
                           nullptr, y);
  }
  boundFrequencyAndDamping(joint, y, points);
  ceres::Solver::Summary summary;
  ceres::Solve(solverOptions(), &joint, &summary);
  if (!summary.IsSolutionUsable()) return "the complex fit did not converge: " + summary.message;

  const int dof = 2 * static_cast<int>(points.size()) - 4;
  fit.reduced_chi_square = 2.0 * summary.final_cost / dof;
  // The points' noise is measured; a model that misses them by more widens the stds by the excess.
  const double scale = std::max(1.0, fit.reduced_chi_square);
  double covariance[16] = {0.0};
  ceres::Covariance::Options covariance_options;
  ceres::Covariance covariance_estimator(covariance_options);
  const std::vector<std::pair<const double*, const double*>> blocks = {{y, y}};
  const bool have_covariance = covariance_estimator.Compute(blocks, &joint) &&
                               covariance_estimator.GetCovarianceBlock(y, y, covariance);
  const double inf = std::numeric_limits<double>::infinity();
  const auto std_of = [&](int k) { return have_covariance ? std::sqrt(scale * covariance[5 * k]) : inf; };
  fit.natural_frequency_std = std_of(0);
  fit.damping_std = std_of(1);
  fit.gain_std = std_of(2);
  fit.dead_time_std = std_of(3);
  return "";
}

// How far the fitted response misses the points in magnitude and phase.
void residualRms(const std::vector<WeightedPoint>& points, const double y[4], ServoValveFit& fit) {
  double magnitude_squares = 0.0, phase_squares = 0.0;
  for (const auto& p : points) {
    double residual[2];
    ComplexResidual{p.f, p.re, p.im, 1.0, p.update_rate}(y, residual);
    const std::complex<double> model(p.re + residual[0], p.im + residual[1]), measured(p.re, p.im);
    magnitude_squares += std::pow(std::abs(model) - std::abs(measured), 2);
    phase_squares += std::pow(std::arg(model / measured), 2);
  }
  fit.magnitude_residual_rms = std::sqrt(magnitude_squares / points.size());
  fit.phase_residual_rms = std::sqrt(phase_squares / points.size());
}

}  // namespace

ServoValveFit fitServoValve(std::vector<FrequencyResponsePoint> measured) {
  ServoValveFit fit;
  unwrapPhases(&measured);
  const std::vector<WeightedPoint> points = weightedPoints(measured, fit);
  fit.points_used = static_cast<int>(points.size());
  if (points.size() < 5) {
    fit.message = "the fit needs at least 5 undistorted frequency points, got " +
                  std::to_string(points.size()) + " (" + std::to_string(fit.points_rejected) +
                  " rejected as distorted" +
                  (fit.points_rejected > 0 ? ": lower the amplitude until the spool follows linearly)" : ")");
    return fit;
  }
  double x[3];
  fit.message = fitMagnitudes(points, x);
  if (!fit.message.empty()) return fit;
  // A valve wired with inverted polarity starts at a phase of pi instead of 0.
  const double static_phase =
      std::abs(points.front().phase) > 0.5 * M_PI ? std::copysign(M_PI, points.front().phase) : 0.0;
  double y[4] = {x[0], x[1], static_phase != 0.0 ? -x[2] : x[2],
                 fitDeadTime(points, static_phase, x[0], x[1])};
  fit.message = fitComplexResponse(points, y, fit);
  if (!fit.message.empty()) return fit;
  fit.parameters.natural_frequency = y[0];
  fit.parameters.damping = y[1];
  fit.parameters.gain = y[2];
  fit.parameters.dead_time = y[3];
  residualRms(points, y, fit);
  fit.success = true;
  fit.message = "fitted " + std::to_string(points.size()) + " points";
  return fit;
}

}  // namespace die_cushion_ident
