#include "die_cushion_ident/core/signal/topic_delay_estimator.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace die_cushion_ident {

namespace {

constexpr int kRegressors = 8;
// Samples on each side of the zero-phase smoothing (moving average) and of the central difference. Light:
// the balance is nonlinear (sqrt(p) y, (s - x) dp/dt), so smoothing the signals before forming the products
// biases the offset near the impact (measured: +-4/2 samples gave up to 0.4 ms, +-2/1 within 0.07 ms).
// The timing matters that much: 0.1 ms of position timing is 20 um of stroke at 0.2 m/s, 0.8 bar.
constexpr std::size_t kSmoothing = 2;
constexpr std::size_t kDifference = 1;
// The fit uses at most this many excited samples (two minutes, some 60 strokes): the offset is constant,
// and more samples only cost time.
constexpr std::size_t kMaxSamples = 60000;
// [s] spacing of the coarse map over both offsets; the cost's basin is wider (impact and valve transients
// last tens of milliseconds).
constexpr double kCoarseStep = 0.004;

// The grid's signals as plain arrays, smoothed alike; NaN where a sample is unusable. Single precision
// like the grid itself: these arrays are built while an hour's grid is in memory.
struct Signals {
  std::vector<float> p, dp, x, v, y;
};

template <typename Channel>
std::vector<float> smoothed(const std::vector<GridSample>& grid, std::size_t n, Channel channel) {
  std::vector<float> out(n, std::numeric_limits<float>::quiet_NaN());
  for (std::size_t i = kSmoothing; i + kSmoothing < n; ++i) {
    double sum = 0.0;
    for (std::size_t j = i - kSmoothing; j <= i + kSmoothing; ++j) {
      // A restart of the time base is a gap for the smoothing and the shifts; NaN spreads: a gap stays one.
      const GridSample& g = grid[j];
      sum += g.complete && !g.discontinuity ? static_cast<double>(channel(g)) : NAN;
    }
    out[i] = static_cast<float>(sum / (2 * kSmoothing + 1));
  }
  return out;
}

Signals prepare(const std::vector<GridSample>& grid, std::size_t n, double dt) {
  Signals s{smoothed(grid, n, [](const GridSample& g) { return g.p; }), {},
            smoothed(grid, n, [](const GridSample& g) { return g.x; }),
            smoothed(grid, n, [](const GridSample& g) { return g.v; }),
            smoothed(grid, n, [](const GridSample& g) { return g.y; })};
  s.dp.assign(n, std::numeric_limits<float>::quiet_NaN());
  for (std::size_t i = kDifference; i + kDifference < n; ++i)
    s.dp[i] = static_cast<float>((static_cast<double>(s.p[i + kDifference]) - s.p[i - kDifference]) /
                                 (2 * kDifference * dt));
  return s;
}

// Channel value at sample i + shift (shift in samples, fractional: linear interpolation).
double at(const std::vector<float>& c, std::size_t i, double shift) {
  const double position = static_cast<double>(i) + shift;
  const double lower = std::floor(position);
  if (lower < 0.0 || lower + 1.0 >= static_cast<double>(c.size())) return NAN;
  const std::size_t k = static_cast<std::size_t>(lower);
  const double w = position - lower;
  return (1.0 - w) * c[k] + w * c[k + 1];
}

class BalanceCost {
 public:
  BalanceCost(const Signals& s, const IdentificationConfig& config, std::vector<std::size_t> rows)
      : s_(s), config_(config), rows_(std::move(rows)) {}

  // Equation-error RMS of the free least-squares fit with position and valve channels shifted [samples].
  double operator()(double position_shift, double valve_shift) const {
    Eigen::Matrix<double, kRegressors, kRegressors> gram = Eigen::Matrix<double, kRegressors, kRegressors>::Zero();
    Eigen::Matrix<double, kRegressors, 1> cross = Eigen::Matrix<double, kRegressors, 1>::Zero();
    double zz = 0.0;
    int n = 0;
    const CylinderGeometry& geometry = config_.geometry;
    Eigen::Matrix<double, kRegressors, 1> phi;
    for (std::size_t i : rows_) {
      const double p = s_.p[i], dp = s_.dp[i];
      const double x = at(s_.x, i, position_shift), v = at(s_.v, i, position_shift);
      const double y = at(s_.y, i, valve_shift);
      if (!std::isfinite(x) || !std::isfinite(v) || !std::isfinite(y)) continue;
      const double drop = y > 0.0 ? std::max(p, 0.0) : std::max(geometry.supply_pressure - p, 0.0);
      const double air = kAtmosphericPressure / ((p + kAtmosphericPressure) * (p + kAtmosphericPressure));
      // First-order forms of the library's valve effects, so that their absence cannot pull the offset:
      // an overlap y0 subtracts K_v y0 sign(y) sqrt(dp); a tank pressure p_T subtracts K_v y p_T / (2 sqrt(p)).
      const double root = std::sqrt(drop);
      const double sign = y > 0.0 ? 1.0 : y < 0.0 ? -1.0 : 0.0;
      phi << geometry.piston_area * (geometry.stroke_length - x) * dp, dp, dp * air, y * root, sign * root,
          y > 0.0 && p > 0.0 ? y / std::sqrt(p) : 0.0, p, 1.0;
      const double z = geometry.piston_area * v;
      gram.selfadjointView<Eigen::Lower>().rankUpdate(phi);
      cross.noalias() += phi * z;
      zz += z * z;
      ++n;
    }
    if (n < kRegressors * 10) return std::numeric_limits<double>::infinity();
    gram.template triangularView<Eigen::StrictlyUpper>() = gram.transpose();
    // Columns differ by many orders of magnitude: solve the equilibrated normal equations.
    Eigen::Matrix<double, kRegressors, 1> scale;
    for (int j = 0; j < kRegressors; ++j) scale(j) = gram(j, j) > 0.0 ? 1.0 / std::sqrt(gram(j, j)) : 1.0;
    const Eigen::Matrix<double, kRegressors, kRegressors> normalised =
        scale.asDiagonal() * gram * scale.asDiagonal();
    const Eigen::Matrix<double, kRegressors, 1> b = scale.cwiseProduct(cross);
    const Eigen::Matrix<double, kRegressors, 1> c = normalised.ldlt().solve(b);
    const double residual = zz - c.dot(b);
    return std::sqrt(std::max(residual, 0.0) / n);
  }
  int rows() const { return static_cast<int>(rows_.size()); }

 private:
  const Signals& s_;
  const IdentificationConfig& config_;
  std::vector<std::size_t> rows_;
};

struct LineSearch {
  double best = 0.0;        // [samples]
  double resolution = 0.0;  // [samples]
};

// Minimum of cost(shift) over [-range, range] samples: whole samples, then quarter samples around the best,
// then a parabola through the best three.
template <typename Cost>
LineSearch searchShift(const Cost& cost, double range) {
  double best = 0.0, best_cost = cost(0.0);
  for (double shift = -std::floor(range); shift <= range; shift += 1.0) {
    const double c = cost(shift);
    if (c < best_cost) {
      best_cost = c;
      best = shift;
    }
  }
  const double coarse = best;
  for (double shift = coarse - 0.75; shift <= coarse + 0.75 + 1e-9; shift += 0.25) {
    const double c = cost(shift);
    if (c < best_cost) {
      best_cost = c;
      best = shift;
    }
  }
  const double f_minus = cost(best - 0.25), f_plus = cost(best + 0.25);
  const double curvature = f_minus - 2.0 * best_cost + f_plus;
  LineSearch result;
  result.best = best;
  if (curvature > 0.0 && std::isfinite(curvature)) {
    result.best = best + 0.25 * 0.5 * (f_minus - f_plus) / curvature;
    // Where the cost rises by 1 % of itself: a shift the fit can tell apart.
    const double a = curvature / (2.0 * 0.25 * 0.25);
    result.resolution = std::sqrt(0.01 * best_cost / a);
  } else {
    result.resolution = range;
  }
  return result;
}

}  // namespace

bool TopicDelayEstimate::significant(double sample_period) const {
  if (!valid) return false;
  for (double d : delays) {
    if (std::abs(d) > 0.25 * sample_period) return true;
  }
  return false;
}

TopicDelayEstimate estimateTopicDelays(const std::vector<GridSample>& grid, const IdentificationConfig& config) {
  TopicDelayEstimate e;
  const double dt = config.resampler.sample_period;
  // Only the stretch that holds enough usable samples is prepared: an hour's grid is 1.8 M samples, the
  // estimate needs a few minutes of strokes.
  std::size_t end = 0, usable = 0;
  while (end < grid.size() && usable < 3 * kMaxSamples) {
    const GridSample& g = grid[end++];
    if (g.complete && g.p >= config.min_pressure && std::abs(g.y) <= config.max_spool_opening) ++usable;
  }
  const Signals s = prepare(grid, end, dt);
  std::vector<std::size_t> rows;
  for (std::size_t i = 0; i < end && rows.size() < kMaxSamples; ++i) {
    const double p = s.p[i], dp = s.dp[i], v = s.v[i], y = s.y[i];
    if (!std::isfinite(p) || !std::isfinite(dp) || !std::isfinite(v) || !std::isfinite(y)) continue;
    if (p < config.min_pressure || std::abs(y) > config.max_spool_opening) continue;
    if (std::abs(v) < config.min_velocity && std::abs(dp) < config.min_pressure_rate) continue;
    rows.push_back(i);
  }
  e.samples = static_cast<int>(rows.size());
  if (rows.size() < 2000) {
    e.message = "too few samples with the cushion moving or the pressure changing (" +
                std::to_string(rows.size()) + ") to estimate the topics' clock offsets";
    return e;
  }
  // A coarse map over both offsets on every 16th row finds the basin (the offsets interact: a late
  // pressure looks like early position and valve), then coordinate descent along position, valve and both
  // together refines it on all rows.
  std::vector<std::size_t> coarse_rows;
  for (std::size_t i = 0; i < rows.size(); i += 16) coarse_rows.push_back(rows[i]);
  const BalanceCost coarse(s, config, std::move(coarse_rows));
  const BalanceCost cost(s, config, std::move(rows));
  const double search_range = config.topic_delay_search / dt;
  const double step = std::max(1.0, std::round(kCoarseStep / dt));
  double position = 0.0, valve = 0.0, best = coarse(0.0, 0.0);
  for (double xs = -std::floor(search_range / step) * step; xs <= search_range; xs += step) {
    for (double vs = -std::floor(search_range / step) * step; vs <= search_range; vs += step) {
      const double c = coarse(xs, vs);
      if (c < best) {
        best = c;
        position = xs;
        valve = vs;
      }
    }
  }
  LineSearch position_search, valve_search;
  for (int round = 0; round < 3; ++round) {
    const double refine = round == 0 ? step + 1.0 : 1.0;  // later rounds only polish
    const LineSearch both = searchShift([&](double shift) { return cost(position + shift, valve + shift); }, refine);
    position += both.best;
    valve += both.best;
    position_search = searchShift([&](double shift) { return cost(position + shift, valve); }, refine);
    position += position_search.best;
    valve_search = searchShift([&](double shift) { return cost(position, valve + shift); }, refine);
    valve += valve_search.best;
  }
  constexpr int kX = static_cast<int>(InputStream::kPosition), kV = static_cast<int>(InputStream::kValve);
  e.delays[kX] = position * dt;
  e.delays[kV] = valve * dt;
  e.resolution[kX] = position_search.resolution * dt;
  e.resolution[kV] = valve_search.resolution * dt;
  e.valid = std::isfinite(e.delays[kX]) && std::isfinite(e.delays[kV]);
  if (!e.valid) e.message = "the balance could not be fitted at any offset";
  return e;
}

}  // namespace die_cushion_ident
