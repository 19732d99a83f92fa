#include "die_cushion_ident/core/servo_valve_fit.h"

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

// Dead time by weighted least squares through the origin on the phase left after the 2nd-order phase.
double fitDeadTime(const std::vector<WeightedPoint>& points, double static_phase, double f0, double damping,
                   double* variance, double* residual_rms) {
  double swo = 0.0, sww = 0.0;
  std::vector<double> left(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    left[i] = points[i].phase - static_phase - secondOrderPhase(points[i].f, f0, damping);
    const double w = 1.0 / (points[i].phase_sigma * points[i].phase_sigma);
    const double omega = 2.0 * M_PI * points[i].f;
    swo += w * omega * left[i];
    sww += w * omega * omega;
  }
  const double dead_time = -swo / sww;
  double chi = 0.0, sum_squares = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double e = left[i] + 2.0 * M_PI * points[i].f * dead_time;
    sum_squares += e * e;
    chi += e * e / (points[i].phase_sigma * points[i].phase_sigma);
  }
  const double dof = std::max<double>(1.0, static_cast<double>(points.size()) - 1.0);
  if (variance) *variance = std::max(1.0, chi / dof) / sww;
  if (residual_rms) *residual_rms = std::sqrt(sum_squares / points.size());
  return dead_time;
}

}  // namespace

std::complex<double> servoValveResponse(const ServoValveParameters& parameters, double frequency) {
  const double r = frequency / parameters.natural_frequency;
  const std::complex<double> second_order(1.0 - r * r, 2.0 * parameters.damping * r);
  return parameters.gain * std::polar(1.0, -2.0 * M_PI * frequency * parameters.dead_time) / second_order;
}

ServoValveFit fitServoValve(std::vector<FrequencyResponsePoint> measured) {
  ServoValveFit fit;
  unwrapPhases(&measured);
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
    points.push_back({p.frequency, p.magnitude, sigma, p.phase, phase_sigma});
  }
  fit.points_used = static_cast<int>(points.size());
  if (points.size() < 5) {
    fit.message = "the fit needs at least 5 undistorted frequency points, got " +
                  std::to_string(points.size()) + " (" + std::to_string(fit.points_rejected) +
                  " rejected as distorted" +
                  (fit.points_rejected > 0 ? ": lower the amplitude until the spool follows linearly)" : ")");
    return fit;
  }

  double x[3];
  gridStart(points, x);
  ceres::Problem problem;
  for (const auto& p : points) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<MagnitudeResidual, 1, 3>(new MagnitudeResidual{p.f, p.m, p.sigma}),
        nullptr, x);
  }
  problem.SetParameterLowerBound(x, 0, 1e-2 * points.front().f);
  problem.SetParameterUpperBound(x, 0, 1e3 * points.back().f);
  problem.SetParameterLowerBound(x, 1, 1e-3);
  problem.SetParameterUpperBound(x, 1, 20.0);
  problem.SetParameterLowerBound(x, 2, 0.0);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = 200;
  options.function_tolerance = 1e-12;
  options.parameter_tolerance = 1e-12;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    fit.message = "the magnitude fit did not converge: " + summary.message;
    return fit;
  }

  const int dof = static_cast<int>(points.size()) - 3;
  fit.reduced_chi_square = 2.0 * summary.final_cost / dof;
  const double scale = std::max(1.0, fit.reduced_chi_square);
  double covariance[9] = {0.0};
  ceres::Covariance::Options covariance_options;
  ceres::Covariance covariance_estimator(covariance_options);
  const std::vector<std::pair<const double*, const double*>> blocks = {{x, x}};
  const bool have_covariance = covariance_estimator.Compute(blocks, &problem) &&
                               covariance_estimator.GetCovarianceBlock(x, x, covariance);
  const double inf = std::numeric_limits<double>::infinity();
  fit.natural_frequency_std = have_covariance ? std::sqrt(scale * covariance[0]) : inf;
  fit.damping_std = have_covariance ? std::sqrt(scale * covariance[4]) : inf;
  fit.gain_std = have_covariance ? std::sqrt(scale * covariance[8]) : inf;

  double sum_squares = 0.0;
  for (const auto& p : points) {
    const double e = x[2] * unitMagnitude(p.f, x[0], x[1]) - p.m;
    sum_squares += e * e;
  }
  fit.magnitude_residual_rms = std::sqrt(sum_squares / points.size());

  // A valve wired with inverted polarity starts at a phase of pi instead of 0.
  const double static_phase =
      std::abs(points.front().phase) > 0.5 * M_PI ? std::copysign(M_PI, points.front().phase) : 0.0;
  double dead_time_variance = 0.0;
  const double dead_time =
      fitDeadTime(points, static_phase, x[0], x[1], &dead_time_variance, &fit.phase_residual_rms);
  // How the dead time moves with natural frequency and damping, propagated through their covariance.
  double gradient[2];
  for (int k = 0; k < 2; ++k) {
    double shifted[2] = {x[0], x[1]};
    const double h = 1e-6 * std::max(std::abs(x[k]), 1e-3);
    shifted[k] += h;
    gradient[k] =
        (fitDeadTime(points, static_phase, shifted[0], shifted[1], nullptr, nullptr) - dead_time) / h;
  }
  const double propagated = have_covariance ? scale * (gradient[0] * gradient[0] * covariance[0] +
                                                       2.0 * gradient[0] * gradient[1] * covariance[1] +
                                                       gradient[1] * gradient[1] * covariance[4])
                                            : inf;

  fit.parameters.natural_frequency = x[0];
  fit.parameters.damping = x[1];
  fit.parameters.gain = static_phase != 0.0 ? -x[2] : x[2];
  fit.parameters.dead_time = dead_time;
  fit.dead_time_std = std::sqrt(dead_time_variance + propagated);
  fit.success = true;
  fit.message = "fitted " + std::to_string(points.size()) + " points";
  return fit;
}

}  // namespace die_cushion_ident
