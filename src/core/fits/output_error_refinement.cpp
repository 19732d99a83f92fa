#include "die_cushion_ident/core/fits/output_error_refinement.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <deque>
#include <initializer_list>
#include <memory>
#include <mutex>
#include <optional>

#include "die_cushion_ident/core/fits/free_run_pressure.h"
#include "die_cushion_ident/core/signal/white_noise_estimator.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "die_cushion_ident/core/util/parallel_numeric_diff.h"

namespace die_cushion_ident {

namespace {

// The refinement is tried only up to this multiple of the pressure noise (to save the time on models that
// lack an effect; it is kept only up to OutputErrorOptions::kept_up_to_noise, which is what guards the
// verdicts). The equation-error fit itself leaves up to 25 times the noise on fast presses with a valve
// overlap near 5 % of the spool (the dead volume 3 times its value, its std larger still), which the
// refinement brings to the noise: at 15 such recordings were reported as "the model lacks something" with
// the poor start's estimate (4 of 110 fast overlap recordings in the calibration, 2026-12-07).
constexpr double kWorthRefining = 40.0;
// Blocks of the recording whose scores are taken as independent for the stds.
constexpr std::size_t kBlocks = 8;
// The position's shift is searched within this many of its units (refineByOutputError's position_shift_scale).
constexpr double kMaxShiftUnits = 3.0;

// Measured minus free-run pressure at every sample (0 where the free run is anchored or has no value).
void freeRunResiduals(const std::vector<GridSample>& grid, std::size_t n, const HydraulicModel& model,
                      const ParameterVector& theta, double min_pressure, double tolerance, double* out,
                      int* valid = nullptr) {
  FreeRunPressure free_run(model, min_pressure, tolerance);
  int count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const GridSample* next = i + 1 < n ? &grid[i + 1] : nullptr;
    const double p = free_run.step(grid[i], theta, next);
    const double e = grid[i].p - p;
    const bool ok = std::isfinite(e) && !free_run.anchoredThisStep();
    out[i] = ok ? e : 0.0;
    count += ok ? 1 : 0;
  }
  if (valid) *valid = count;
}

}  // namespace

namespace {

// [s] The grid's period over its first n samples: from its ends, or, where a discontinuity (a gap or a
// restart of the time base) lies between, the mean of the spacings within its stretches.
double periodOf(const std::vector<GridSample>& grid, std::size_t n) {
  double sum = 0.0;
  std::size_t spacings = 0;
  bool broken = false;
  for (std::size_t k = 1; k < n; ++k) {
    if (grid[k].discontinuity) {
      broken = true;
      continue;
    }
    sum += grid[k].t - grid[k - 1].t;
    ++spacings;
  }
  if (!broken) return (grid[n - 1].t - grid[0].t) / static_cast<double>(n - 1);
  return spacings > 0 ? sum / static_cast<double>(spacings) : std::numeric_limits<double>::quiet_NaN();
}

// The channels `members` of the grid's first n samples read `shift` [s] later into `shifted`: Catmull-Rom
// between the grid samples around t + shift (the free run's own interpolation). Within each stretch between
// discontinuities: a sample whose bracket reaches across one, or holds no value, keeps its own (a NaN
// pressure beside a gap did not widen into its neighbour, nor a restart blend two time bases); a neighbour
// across one is left out (the cubic takes the secant there).
void readLater(const std::vector<GridSample>& grid, std::size_t n, double shift,
               std::initializer_list<float GridSample::*> members, std::vector<GridSample>& shifted) {
  if (n < 4) return;
  const double period = periodOf(grid, n);
  if (!(period > 0.0) || !std::isfinite(shift)) return;
  const double offset = shift / period;
  const long whole = static_cast<long>(std::floor(offset));
  const double w = offset - static_cast<double>(whole);
  const long last = static_cast<long>(n) - 1;
  const auto at = [&](long i) { return &grid[static_cast<std::size_t>(std::clamp(i, 0L, last))]; };
  // Whether a discontinuity starts a stretch at any sample in (from, to].
  const auto broken = [&](long from, long to) {
    for (long k = std::max(from + 1, 1L); k <= std::min(to, last); ++k) {
      if (grid[static_cast<std::size_t>(k)].discontinuity) return true;
    }
    return false;
  };
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t i = 0; i < n; ++i) {
    const long j = static_cast<long>(i) + whole;
    if (broken(std::min(static_cast<long>(i), j), std::max(static_cast<long>(i), j + 1))) continue;
    const GridSample *before = at(j - 1), *a = at(j), *b = at(j + 1), *after = at(j + 2);
    const bool with_before = !broken(j - 1, j), with_after = !broken(j + 1, j + 2);
    for (float GridSample::*member : members) {
      if (!std::isfinite(a->*member) || !std::isfinite(b->*member)) continue;
      shifted[i].*member = static_cast<float>(catmullRom(with_before ? before->*member : kNone, a->*member,
                                                         b->*member, with_after ? after->*member : kNone, w));
    }
  }
}

}  // namespace

std::vector<GridSample> positionShifted(const std::vector<GridSample>& grid, std::size_t n, double shift) {
  n = std::min(n, grid.size());
  std::vector<GridSample> shifted(grid.begin(), grid.begin() + static_cast<std::ptrdiff_t>(n));
  readLater(grid, n, shift, {&GridSample::x, &GridSample::v}, shifted);
  return shifted;
}

std::vector<GridSample> timingShifted(const std::vector<GridSample>& grid, std::size_t n,
                                      double position_shift, double pressure_shift) {
  n = std::min(n, grid.size());
  std::vector<GridSample> shifted = positionShifted(grid, n, position_shift);
  if (pressure_shift != 0.0) readLater(grid, n, pressure_shift, {&GridSample::p}, shifted);
  return shifted;
}

namespace {

// The free runs already made, by their unknowns. Ceres asks for the residuals at a candidate and, where it
// is taken, for the Jacobian there, whose base is the same point again; the fit's start was run before the
// fit, and its final residuals are those of its last point: each of these is one free run, not two or three
// (a third of the refinement's runs). Shared by the threads of the Jacobian's columns.
class FreeRunMemo {
 public:
  struct Run {
    std::vector<double> x, residuals;
    int valid = 0;
  };
  std::optional<Run> find(const std::vector<double>& x) const {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const Run& run : runs_) {
      if (run.x == x) return run;
    }
    return std::nullopt;
  }
  void keep(Run run) {
    std::lock_guard<std::mutex> lock(mutex_);
    // The last candidate, its Jacobian's columns (one per unknown), the point before and the start.
    const std::size_t kept = run.x.size() + 3;
    runs_.push_back(std::move(run));
    while (runs_.size() > kept) runs_.pop_front();
  }

 private:
  mutable std::mutex mutex_;
  std::deque<Run> runs_;
};

struct FreeRunError {
  const std::vector<GridSample>* grid;
  std::size_t n;
  const HydraulicModel* model;
  ParameterVector scale;
  double min_pressure;
  double shift_scale = 0.0;           // [s] the unit of the position's shift; 0: not an unknown
  double pressure_shift_scale = 0.0;  // [s] the unit of the pressure's shift (the shifts' second); 0: none
  double tolerance = 1.0;             // [Pa] the free run's (OutputErrorOptions::tolerance)
  std::shared_ptr<FreeRunMemo> memo;

  int shifts() const { return shift_scale > 0.0 ? (pressure_shift_scale > 0.0 ? 2 : 1) : 0; }
  // The unknowns as the memo's key: the parameters in units of their scale, then the shifts (if any).
  std::vector<double> key(double const* const* x) const {
    std::vector<double> k(x[0], x[0] + scale.size());
    for (int i = 0; i < shifts(); ++i) k.push_back(x[1][i]);
    return k;
  }
  // Called from several threads at once (the Jacobian's columns): each call runs its own copy of the model,
  // whose user formulas each hold a parser that reads its variables from the instance (shared, two threads
  // gave a bulk modulus 0.3 % and its std five times off).
  bool operator()(double const* const* x, double* out) const {
    FreeRunMemo::Run run;
    run.x = key(x);
    if (const std::optional<FreeRunMemo::Run> known = memo->find(run.x)) {
      std::copy(known->residuals.begin(), known->residuals.end(), out);
    } else {
      const HydraulicModel own_model(*model);
      ParameterVector theta(scale.size());
      for (Eigen::Index i = 0; i < scale.size(); ++i) theta(i) = x[0][i] * scale(i);
      if (shift_scale > 0.0) {
        const double pressure_shift = shifts() > 1 ? (x[1][1] - 1.0) * pressure_shift_scale : 0.0;
        freeRunResiduals(timingShifted(*grid, n, (x[1][0] - 1.0) * shift_scale, pressure_shift), n, own_model,
                         theta, min_pressure, tolerance, out, &run.valid);
      } else {
        freeRunResiduals(*grid, n, own_model, theta, min_pressure, tolerance, out, &run.valid);
      }
      run.residuals.assign(out, out + n);
      memo->keep(std::move(run));
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (!std::isfinite(out[i])) return false;
    }
    return true;
  }
};

double rmsOf(const std::vector<double>& r, int valid) {
  double sum = 0.0;
  for (double e : r) sum += e * e;
  return valid > 0 ? std::sqrt(sum / valid) : 0.0;
}

}  // namespace

namespace {

// The noise the free run is judged by: the one given, or the grid's own.
double pressureNoise(const std::vector<GridSample>& grid, std::size_t n, const OutputErrorOptions& refine) {
  if (refine.pressure_noise > 0.0) return refine.pressure_noise;
  WhiteNoiseEstimator noise(4);
  for (std::size_t i = 1; i + 1 < n; ++i) noise.add(grid[i - 1].p, grid[i].p, grid[i + 1].p);
  return noise.sigma();
}

// Unknowns in units of each parameter's start (or of its std where the start is zero): all near 1.
ParameterVector unknownScales(const ParameterVector& start, const ParameterVector& start_std) {
  ParameterVector scale(start.size());
  for (Eigen::Index i = 0; i < start.size(); ++i) {
    const double s = std::abs(start(i)) > 0.0 ? std::abs(start(i)) : std::abs(start_std(i));
    scale(i) = std::isfinite(s) && s > 0.0 ? s : 1.0;
  }
  return scale;
}

struct Solved {
  ParameterVector theta;
  double position_shift = 0.0;  // [s]
  double pressure_shift = 0.0;  // [s]
  std::size_t iterations = 0;
  std::optional<FreeRunMemo::Run> run;  // the free run of the solution, where the fit made it
};

// The parameters (and the position's shift, where it is an unknown) that minimise the free run's error over
// the first n samples, within the physical ranges.
// `start_run`: the free run of `start` on the grid as it is (the memo's first point: the start in units of
// its scale is +-1 or 0, which times the scale is the start again, and a shift of 0 leaves the grid as it
// is).
Solved minimiseFreeRunError(const std::vector<GridSample>& grid, std::size_t n, const HydraulicModel& model,
                            const ParameterVector& start, const ParameterVector& scale, double min_pressure,
                            const OutputErrorOptions& refine, FreeRunMemo::Run start_run) {
  const Eigen::Index k = start.size();
  std::vector<double> x(static_cast<std::size_t>(k));
  for (Eigen::Index i = 0; i < k; ++i) x[i] = start(i) / scale(i);
  ceres::NumericDiffOptions differences;
  differences.relative_step_size = 1e-4;
  const double position_shift_scale = refine.position_shift_scale;
  const bool shifting = position_shift_scale > 0.0;
  // The shifts in units of their scales, plus 1: Ceres's relative difference step needs a non-zero start.
  double shift[2] = {1.0, 1.0};
  const FreeRunError error{&grid,
                           n,
                           &model,
                           scale,
                           min_pressure,
                           shifting ? position_shift_scale : 0.0,
                           shifting ? refine.pressure_shift_scale : 0.0,
                           refine.tolerance,
                           std::make_shared<FreeRunMemo>()};
  const int shifts = error.shifts();
  const double* unknowns[2] = {x.data(), shift};
  bool start_exact = true;
  for (Eigen::Index i = 0; i < k; ++i) start_exact &= x[i] * scale(i) == start(i);
  if (start_exact) {
    start_run.x = error.key(unknowns);
    error.memo->keep(std::move(start_run));
  }
  auto* cost = new ParallelNumericDiffCost<FreeRunError, ceres::FORWARD>(error, differences, refine.jobs);
  cost->AddParameterBlock(static_cast<int>(k));
  if (shifting) cost->AddParameterBlock(shifts);
  cost->SetNumResiduals(static_cast<int>(n));
  ceres::Problem problem;
  if (shifting) {
    problem.AddResidualBlock(cost, nullptr, x.data(), shift);
    for (int i = 0; i < shifts; ++i) {
      problem.SetParameterLowerBound(shift, i, 1.0 - kMaxShiftUnits);
      problem.SetParameterUpperBound(shift, i, 1.0 + kMaxShiftUnits);
    }
  } else {
    problem.AddResidualBlock(cost, nullptr, x.data());
  }
  const auto& infos = model.parameterInfos();
  for (Eigen::Index i = 0; i < k && static_cast<std::size_t>(i) < infos.size(); ++i) {
    // Within the physical range (the bounds in units of the scale; a scale is positive).
    if (std::isfinite(infos[i].lower_bound)) problem.SetParameterLowerBound(x.data(), i, infos[i].lower_bound / scale(i));
    if (std::isfinite(infos[i].upper_bound)) problem.SetParameterUpperBound(x.data(), i, infos[i].upper_bound / scale(i));
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = 10;
  options.function_tolerance = refine.function_tolerance > 0.0
                                   ? refine.function_tolerance
                                   : 0.1 / static_cast<double>(std::max<std::size_t>(n, 1));
  // With bounds Ceres follows every trust-region step by a projected line search that asks for the gradient,
  // i.e. a whole Jacobian of free runs more at each candidate: 7 Jacobians in 3 iterations instead of 3.
  // The bounds still hold (the step is projected onto them).
  options.max_num_line_search_step_size_iterations = 0;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  Solved solved;
  solved.theta = ParameterVector(k);
  for (Eigen::Index i = 0; i < k; ++i) solved.theta(i) = x[i] * scale(i);
  solved.position_shift = shifting ? (shift[0] - 1.0) * position_shift_scale : 0.0;
  solved.pressure_shift = shifts > 1 ? (shift[1] - 1.0) * refine.pressure_shift_scale : 0.0;
  solved.iterations = summary.iterations.size();
  solved.run = error.memo->find(error.key(unknowns));
  return solved;
}

// Each reconstructed input's part of the stds: the free run at theta with the input moved one std either way,
// its residuals' half difference dr projected as the refit would, (J'J)^-1 J' dr (`projection`); the parts
// of one input in quadrature. On both cores: two free runs a perturbation.
void setInputStds(const std::vector<GridSample>& fitted, std::size_t n, const HydraulicModel& model,
                  const Eigen::MatrixXd& projection, double min_pressure, const OutputErrorOptions& refine,
                  OutputErrorFit& fit) {
  const std::vector<InputPerturbation>& inputs = refine.inputs;
  std::vector<Eigen::VectorXd> shifts(inputs.size());
  parallelFor(inputs.size(), refine.jobs, [&](std::size_t j) {
    const HydraulicModel own_model(model);  // one per thread (FreeRunError says why)
    std::vector<double> plus(n), minus(n);
    freeRunResiduals(perturbed(fitted, n, inputs[j], 1.0), n, own_model, fit.theta, min_pressure,
                     refine.tolerance, plus.data());
    freeRunResiduals(perturbed(fitted, n, inputs[j], -1.0), n, own_model, fit.theta, min_pressure,
                     refine.tolerance, minus.data());
    Eigen::VectorXd change(static_cast<Eigen::Index>(n));
    for (std::size_t s = 0; s < n; ++s) change(static_cast<Eigen::Index>(s)) = 0.5 * (plus[s] - minus[s]);
    shifts[j] = projection * change;
  });
  for (std::size_t j = 0; j < inputs.size(); ++j) {
    if (!shifts[j].allFinite()) continue;
    ParameterVector& part =
        fit.input_std.try_emplace(inputs[j].input, ParameterVector::Zero(fit.theta.size())).first->second;
    for (Eigen::Index i = 0; i < part.size(); ++i) part(i) = std::hypot(part(i), shifts[j](i));
  }
}

struct Sandwich {
  Eigen::MatrixXd bread, covariance;
  double small_sample = 1.0;  // t_0.975(G - 1) / z_0.975 for G blocks
};

// (J'J)^-1 S (J'J)^-1 with S from the scores J_t r_t summed over kBlocks blocks of the n samples.
Sandwich clusterRobustSandwich(const Eigen::MatrixXd& jacobian, const std::vector<double>& r, std::size_t n) {
  const Eigen::Index k = jacobian.cols();
  const Eigen::MatrixXd information = jacobian.transpose() * jacobian;
  const std::size_t block = std::max<std::size_t>(n / kBlocks, 1);
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(k, k);
  int blocks = 0;
  for (std::size_t first = 0; first + block <= n; first += block, ++blocks) {
    Eigen::VectorXd g = Eigen::VectorXd::Zero(k);
    for (std::size_t s = first; s < first + block; ++s) g += jacobian.row(s).transpose() * r[s];
    meat += g * g.transpose();
  }
  if (blocks > 1) meat *= static_cast<double>(blocks) / (blocks - 1);
  Sandwich sandwich;
  const Eigen::LDLT<Eigen::MatrixXd> solver(information);
  sandwich.bread = solver.solve(Eigen::MatrixXd::Identity(k, k));
  sandwich.covariance = sandwich.bread * meat * sandwich.bread;
  // With G blocks the sandwich has G - 1 degrees of freedom (Cameron & Miller 2015): the std scaled by
  // t_0.975(G - 1) / z_0.975 (1.21 for 8 blocks), so that 1.96 of it is the t interval.
  if (blocks > 1)
    sandwich.small_sample =
        boost::math::quantile(boost::math::students_t(blocks - 1), 0.975) / 1.959963984540054;
  return sandwich;
}

// [s] A 10 us step of the position's shift: its free-run change is far above the integrator's tolerance and
// still linear (the position's cubic moves by a few thousandths of a 2 ms sample).
constexpr double kShiftStep = 1e-5;

// The shifts' stds where they were unknowns: the sandwich over the parameters' columns and the shifts' (the
// free run's change as the position, or the pressure, is read kShiftStep later and earlier), so that the
// parameters' share of the residuals is not counted as the shifts'.
void setShiftStds(const std::vector<GridSample>& fitted, std::size_t n, const HydraulicModel& model,
                  const Eigen::MatrixXd& parameter_jacobian, const std::vector<double>& r,
                  double min_pressure, const OutputErrorOptions& refine, OutputErrorFit& fit) {
  const Eigen::Index k = parameter_jacobian.cols();
  const Eigen::Index shifts = refine.pressure_shift_scale > 0.0 ? 2 : 1;
  Eigen::MatrixXd jacobian(static_cast<Eigen::Index>(n), k + shifts);
  jacobian.leftCols(k) = parameter_jacobian;
  std::vector<double> plus(n), minus(n);
  for (Eigen::Index column = 0; column < shifts; ++column) {
    const double step = kShiftStep;
    const auto shiftedBy = [&](double sign) {
      return column == 0 ? timingShifted(fitted, n, sign * step, 0.0)
                         : timingShifted(fitted, n, 0.0, sign * step);
    };
    freeRunResiduals(shiftedBy(1.0), n, model, fit.theta, min_pressure, refine.tolerance, plus.data());
    freeRunResiduals(shiftedBy(-1.0), n, model, fit.theta, min_pressure, refine.tolerance, minus.data());
    for (std::size_t s = 0; s < n; ++s)
      jacobian(static_cast<Eigen::Index>(s), k + column) = -(plus[s] - minus[s]) / (2.0 * step);
  }
  if (!jacobian.allFinite()) return;
  const Sandwich sandwich = clusterRobustSandwich(jacobian, r, n);
  const auto stdOf = [&](Eigen::Index i) {
    const double variance = sandwich.covariance(i, i);
    return variance > 0.0 && std::isfinite(variance) ? sandwich.small_sample * std::sqrt(variance)
                                                     : std::numeric_limits<double>::quiet_NaN();
  };
  fit.position_shift_std = stdOf(k);
  if (shifts > 1) fit.pressure_shift_std = stdOf(k + 1);
}

// The relative step of the parameters' central differences. The free run is integrated to a tolerance
// (OutputErrorOptions::tolerance, 1 Pa), so its change must stand well above it: at 1e-4 a small stiff
// press with a tank pressure, whose flow sqrt(p - p_T) makes the integrator's steps vary near p_T, had a
// Jacobian of that error, J'J too large and its dead volume's std 0.026 % and 0.092 % on two runs of the same
// recording to the same estimate (error 0.49-0.54 %, z -5 to -21); at 1e-3 both came to 0.51 %, the
// scatter of the estimate over 12 noise seeds of that press (0.53 %). Still linear: a 0.1 % change of any
// parameter moves the free run by far less than its curvature matters.
constexpr double kJacobianStep = 1e-3;

// The stds: the sandwich (J'J)^-1 S (J'J)^-1 with S from the scores g_t = J_t r_t summed over blocks of
// the recording treated as independent (cluster-robust): a free run's residuals stay correlated over a
// whole press cycle (a shut valve carries an error through the hold), and Bartlett weights over 300 ms
// left the stds a third of the errors on fast presses. J by central differences at the solution.
// Where the position's shift was an unknown, the stds are those with the shift held at its optimum.
void setClusterRobustStds(const std::vector<GridSample>& fitted, std::size_t n, const HydraulicModel& model,
                          const ParameterVector& scale, const std::vector<double>& r, double min_pressure,
                          const OutputErrorOptions& refine, const ParameterVector& start_std,
                          OutputErrorFit& fit) {
  const ParameterVector& theta = fit.theta;
  const Eigen::Index k = theta.size();
  Eigen::MatrixXd jacobian(n, k);
  parallelFor(static_cast<std::size_t>(k), refine.jobs, [&](std::size_t column) {
    const auto i = static_cast<Eigen::Index>(column);
    const HydraulicModel own_model(model);  // one per thread (FreeRunError says why)
    std::vector<double> plus(n), minus(n);
    const double h = kJacobianStep * std::max(std::abs(theta(i)), scale(i) * 1e-3);
    ParameterVector t = theta;
    t(i) += h;
    freeRunResiduals(fitted, n, own_model, t, min_pressure, refine.tolerance, plus.data());
    t(i) = theta(i) - h;
    freeRunResiduals(fitted, n, own_model, t, min_pressure, refine.tolerance, minus.data());
    // r = p - p_hat: d p_hat / d theta = -(dr / d theta)
    for (std::size_t s = 0; s < n; ++s) jacobian(s, i) = -(plus[s] - minus[s]) / (2.0 * h);
  });
  const Sandwich sandwich = clusterRobustSandwich(jacobian, r, n);
  for (Eigen::Index i = 0; i < k; ++i) {
    const double variance = sandwich.covariance(i, i);
    fit.std(i) = variance > 0.0 && std::isfinite(variance) ? sandwich.small_sample * std::sqrt(variance)
                                                           : start_std(i);
  }
  setInputStds(fitted, n, model, sandwich.bread * jacobian.transpose(), min_pressure, refine, fit);
  if (refine.position_shift_scale > 0.0)
    setShiftStds(fitted, n, model, jacobian, r, min_pressure, refine, fit);
}

// Why the refined parameters are not kept (their free-run error `rms`); "" where they are. Kept only where
// they bring the free run to the sensor's noise: then the equation-error fit's resolution was all that was
// left. Where a structured error remains, the model lacks something; refining it would spread that error
// over the stroke (a missing leakage's hold error moved into the impact) and hide part of it from the
// held-out tests, and the equation-error estimate shows where it is made.
std::string whyNotKept(const OutputErrorFit& fit, double rms, bool finite, const OutputErrorOptions& refine) {
  if (!(rms < fit.start_rms) || !finite) {
    return formatted(
        FMT_STRING(
            "the free run's error did not fall ({:.3g} -> {:.3g} bar): the equation-error estimate kept"),
        1e-5 * fit.start_rms, 1e-5 * rms);
  }
  if (!(std::isfinite(fit.noise) && rms <= refine.kept_up_to_noise * fit.noise)) {
    return formatted(
        FMT_STRING(
            "free-run error {:.3g} -> {:.3g} bar, not kept: {:.2f} times the pressure noise ({:.3g} bar) "
            "remain, more than {:.1f}: the model lacks something, and the equation-error estimate "
            "shows where"),
        1e-5 * fit.start_rms, 1e-5 * rms, rms / fit.noise, 1e-5 * fit.noise, refine.kept_up_to_noise);
  }
  return "";
}

}  // namespace

OutputErrorFit refineByOutputError(const std::vector<GridSample>& grid, const HydraulicModel& model,
                                   const ParameterVector& start, const ParameterVector& start_std,
                                   double min_pressure, const OutputErrorOptions& refine) {
  OutputErrorFit fit;
  fit.theta = start;
  fit.std = start_std;
  const std::size_t n = std::min(grid.size(), refine.max_samples);
  if (n < 100 || start.size() == 0 || !start.allFinite()) {
    fit.message = "too little to refine";
    return fit;
  }
  std::vector<double> r(n);
  int valid = 0;
  freeRunResiduals(grid, n, model, start, min_pressure, refine.tolerance, r.data(), &valid);
  fit.start_rms = rmsOf(r, valid);
  fit.rms = fit.start_rms;
  fit.samples = valid;
  if (valid < 100) {
    fit.message = "too few samples the free run covers";
    return fit;
  }
  fit.noise = pressureNoise(grid, n, refine);
  // Far above the noise the model lacks something, and no refinement would reach it: not tried.
  if (!(std::isfinite(fit.noise) && fit.start_rms <= kWorthRefining * fit.noise)) {
    fit.message = formatted(
        FMT_STRING("not refined: the free run's error is {:.3g} bar, {:.1f} times the pressure noise: the "
                   "model lacks something, and the equation-error estimate shows where"),
        1e-5 * fit.start_rms, fit.start_rms / fit.noise);
    return fit;
  }
  const ParameterVector scale = unknownScales(start, start_std);
  const Solved solved = minimiseFreeRunError(grid, n, model, start, scale, min_pressure, refine,
                                             FreeRunMemo::Run{{}, r, valid});
  const bool shifting = refine.position_shift_scale > 0.0;
  const std::vector<GridSample> shifted =
      shifting ? timingShifted(grid, n, solved.position_shift, solved.pressure_shift)
               : std::vector<GridSample>();
  const std::vector<GridSample>& fitted = shifting ? shifted : grid;
  if (solved.run) {
    r = solved.run->residuals;
    valid = solved.run->valid;
  } else {
    freeRunResiduals(fitted, n, model, solved.theta, min_pressure, refine.tolerance, r.data(), &valid);
  }
  const double rms = rmsOf(r, valid);
  fit.message = whyNotKept(fit, rms, solved.theta.allFinite(), refine);
  if (!fit.message.empty()) return fit;
  fit.improved = true;
  fit.theta = solved.theta;
  fit.position_shift = solved.position_shift;
  fit.pressure_shift = solved.pressure_shift;
  fit.rms = rms;
  fit.samples = valid;
  fit.message =
      formatted(FMT_STRING("free-run error {:.3g} -> {:.3g} bar over {} samples ({} Ceres iterations)"),
                1e-5 * fit.start_rms, 1e-5 * rms, valid, solved.iterations);
  if (refine.with_stds)
    setClusterRobustStds(fitted, n, model, scale, r, min_pressure, refine, start_std, fit);
  return fit;
}

}  // namespace die_cushion_ident
