#pragma once

// The offsets' cost (private to estimateTopicDelays, topic_delay_estimator.cpp): the volume balance over
// short windows with free coefficients, fitted with the position and the valve shifted against the pressure.

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <utility>
#include <vector>

#include "die_cushion_ident/core/estimation/identification_config.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"
#include "die_cushion_ident/core/util/parallel_for.h"

namespace die_cushion_ident::topic_delay_detail {

// The balance integrated over windows of kWindow seconds (the identification's integral form, here with free
// coefficients): A (x(t+W) - x(t)) = sum_j c_j r_j, each r_j the window's integral of one term. Pressure
// enters only through its increments (a derivative of a noisy pressure put its noise into the regressors and
// pulled the offset by 0.5 ms on a large soft chamber), and the valve's opening is a piecewise-linear
// function of the spool with kinks at kKnots, so that a dead band (overlap) fits too: its first-order
// form left the offset 0.5 ms off. The kinks are 1 % of the spool apart up to 7 %: with them at 1, 2, 4 and
// 7 % an overlap of 4.7 % fell between two, and a fast press's offsets came out -43 and -40 ms where the
// clocks agreed (and its fit implausible).
constexpr double kWindow = 0.025;  // [s]
constexpr double kKnots[] = {0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07};
constexpr int kKnotCount = static_cast<int>(std::size(kKnots));
// 1/K', V_dead/K', air, opening y, the knots' hinges, tank (y / sqrt(p)), leakage (p), a constant flow.
constexpr int kRegressors = 3 + 1 + kKnotCount + 3;
// Lags of the rows' residual autocorrelation taken into the uncertainty: a model's misfit repeats over a
// press cycle (some 100 windows of a slow press's drawing and return), not only between neighbours.
constexpr std::size_t kCorrelationLags = 100;
// The fit uses at most this many excited samples (two minutes, some 60 strokes): the offset is constant,
// and more samples only cost time.
constexpr std::size_t kMaxSamples = 60000;
// Windows the coarse map evaluates at most (its 625 points cost more than the refinement otherwise).
constexpr std::size_t kCoarseWindows = 400;
// [s] spacing of the coarse map over both offsets; the cost's basin is wider (impact and valve transients
// last tens of milliseconds).
constexpr double kCoarseStep = 0.004;

using Vector = Eigen::Matrix<double, kRegressors, 1>;
using Matrix = Eigen::Matrix<double, kRegressors, kRegressors>;

// The grid's channels as plain arrays; NaN where a sample is unusable. Single precision like the grid
// itself: these arrays are built while an hour's grid is in memory.
struct Signals {
  std::vector<float> p, x, y;
};

Signals prepare(const std::vector<GridSample>& grid, std::size_t n, const IdentificationConfig& config);

// The channels averaged over `width` samples centred on each (NaN spreads): the coarse map's view, whose
// basins are as wide as its step (a fast press's impact and valve make them narrower than 4 ms otherwise).
Signals smoothedSignals(const Signals& s, std::size_t width);

// Channel value at sample i + shift (shift in samples, fractional: linear interpolation).
inline double at(const std::vector<float>& c, std::size_t i, double shift) {
  const double position = static_cast<double>(i) + shift;
  const double lower = std::floor(position);
  if (lower < 0.0 || lower + 1.0 >= static_cast<double>(c.size())) return NAN;
  const std::size_t k = static_cast<std::size_t>(lower);
  const double w = position - lower;
  return (1.0 - w) * c[k] + w * c[k + 1];
}

// A sample's port roots: the shifts move the spool, never the pressure, so each sample's roots are taken
// once and not in every evaluation (their square roots were most of the offsets' search).
struct PortRoots {
  double p = 0.0;       // [Pa] the port pressure
  double tank = 0.0;    // sqrt(max(p, 0)): the port to tank, open for y >= 0
  double supply = 0.0;  // sqrt(max(p_S - p, 0)): the port from supply, open for y < 0
  PortRoots() = default;
  PortRoots(double p_, double supply_pressure)
      : p(p_), tank(std::sqrt(std::max(p_, 0.0))), supply(std::sqrt(std::max(supply_pressure - p_, 0.0))) {}
};

// The valve-opening basis times the port's root, for spool y at a sample's port pressure.
inline void valveTerms(double y, const PortRoots& port, double* r) {
  const double root = y >= 0.0 ? port.tank : port.supply;
  const double sign = y > 0.0 ? 1.0 : y < 0.0 ? -1.0 : 0.0;
  r[0] = y * root;
  for (int k = 0; k < kKnotCount; ++k) r[1 + k] = sign * std::min(std::abs(y), kKnots[k]) * root;
  r[1 + kKnotCount] = y > 0.0 && port.p > 0.0 ? y / port.tank : 0.0;  // a tank pressure, to first order
}

class BalanceCost {
 public:
  /// `stride`: samples per integration step (the coarse map on smoothed signals takes every step-th).
  BalanceCost(const Signals& s, const IdentificationConfig& config, double dt,
              std::vector<std::size_t> starts, double pressure_noise, double window_seconds = kWindow,
              std::size_t stride = 1)
      : s_(s),
        config_(config),
        dt_(dt),
        stride_(std::max<std::size_t>(stride, 1)),
        window_(std::max<std::size_t>(2, std::lround(window_seconds / dt / stride_)) * stride_),
        starts_(std::move(starts)),
        noise_variance_(std::isfinite(pressure_noise) ? pressure_noise * pressure_noise : 0.0) {
    pressure_columns_.reserve(starts_.size());
    for (std::size_t start : starts_) pressure_columns_.push_back(pressureColumns(start));
    pressure_block_ = pressureBlock();
    const std::size_t steps = window_ / stride_ + 1;
    port_roots_.reserve(starts_.size() * steps);
    for (std::size_t start : starts_) {
      for (std::size_t k = start; k <= start + window_; k += stride_)
        port_roots_.emplace_back(s_.p[k], config_.geometry.supply_pressure);
    }
  }

  struct Fit {
    double rms = std::numeric_limits<double>::infinity();  // [m^3/s] per row, as a flow over the window
    int rows = 0;
    double correlation_factor = 1.0;  // 1 + 2 sum of the residuals' autocorrelations (rows in time order)
  };

  // The normal equations' sums over the windows (rows in time order where the correlation is wanted).
  // The capacitive columns are sums of a_k (p_k+1 - p_k): a white pressure noise n enters them as
  // a_last n_end - a_first n_start (the inner terms cancel to first order), and adds sigma^2 (f f' + l l') to
  // their normal equations, f and l the columns' a at the window's ends: noise_gram, subtracted in solve()
  // (errors in variables: unremoved, it flattened the soft chamber's capacitance and pulled its offset by
  // 0.2-0.5 ms).
  struct Sums {
    Matrix gram = Matrix::Zero();
    Eigen::Matrix3d noise_gram = Eigen::Matrix3d::Zero();
    Vector cross = Vector::Zero();
    double zz = 0.0;
    std::vector<std::pair<double, Vector>> rows;
    // One window's row r with its left side z and the capacitive columns' a at its two ends.
    void add(const Vector& r, double z, const Eigen::Vector3d& a_begin, const Eigen::Vector3d& a_end,
             bool keep_row) {
      noise_gram.noalias() += a_begin * a_begin.transpose();
      noise_gram.noalias() += a_end * a_end.transpose();
      gram.selfadjointView<Eigen::Lower>().rankUpdate(r);
      cross.noalias() += r * z;
      zz += z * z;
      if (keep_row) rows.emplace_back(z, r);
    }
  };

  // The fit's residual with position and valve channels shifted [samples]. The windows' parts at the last
  // position shift and at the last valve shift are kept with their blocks of the normal equations: a
  // curvature probe along one offset moves only its own part. Not for several threads at once.
  Fit operator()(double position_shift, double valve_shift, bool with_correlation = false) const {
    const PartsAt<PositionPart>& x_at = cachedParts(position_cache_, position_shift,
                                                    &BalanceCost::positionPart, &BalanceCost::positionBlocks);
    const PartsAt<ValvePart>& y_at =
        cachedParts(valve_cache_, valve_shift, &BalanceCost::valvePart, &BalanceCost::valveBlocks);
    if (!with_correlation) {
      Sums sums = pairSums(x_at.parts, y_at.parts, x_at.blocks, y_at.blocks, pressure_block_);
      return solve(sums, false);
    }
    Sums sums = wholeSums(x_at.parts, y_at.parts, true);
    return solve(sums, with_correlation);
  }

  // The cost at every pair of the two lists of shifts [samples], position major. The regressors separate:
  // the position's shift moves only the first column and the left side, the valve's only the opening's
  // columns. Each window is integrated once per position shift and once per valve shift, and the normal
  // equations assembled from blocks: the pressure's own (fixed), the position's and the valve's (one per
  // shift) and their products (one per pair: 12 products a window where the whole rank-one update took 80;
  // the 625 pairs integrated whole were half of the offsets' time). On up to `jobs` threads (no cache kept).
  std::vector<double> costMap(const std::vector<double>& position_shifts,
                              const std::vector<double>& valve_shifts, int jobs) const {
    std::vector<std::pair<double, double>> pairs;
    pairs.reserve(position_shifts.size() * valve_shifts.size());
    for (double x : position_shifts) {
      for (double v : valve_shifts) pairs.emplace_back(x, v);
    }
    return costsAt(pairs, jobs);
  }
  // The cost at each pair of shifts [samples] (position, valve): each distinct shift's parts once and each
  // pair from blocks, on up to `jobs` threads (no cache kept: the line searches' points of one stage, the
  // squares and the map side by side).
  std::vector<double> costsAt(const std::vector<std::pair<double, double>>& pairs, int jobs) const {
    std::vector<double> position_shifts, valve_shifts;
    std::vector<std::size_t> x_of(pairs.size()), y_of(pairs.size());
    const auto indexOf = [](std::vector<double>& shifts, double shift) {
      const auto it = std::find(shifts.begin(), shifts.end(), shift);
      if (it != shifts.end()) return static_cast<std::size_t>(it - shifts.begin());
      shifts.push_back(shift);
      return shifts.size() - 1;
    };
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      x_of[k] = indexOf(position_shifts, pairs[k].first);
      y_of[k] = indexOf(valve_shifts, pairs[k].second);
    }
    std::vector<std::vector<PositionPart>> x(position_shifts.size());
    std::vector<std::vector<ValvePart>> y(valve_shifts.size());
    std::vector<Sums> x_sums(position_shifts.size()), y_sums(valve_shifts.size());
    partsAndBlocks(position_shifts, valve_shifts, jobs, &x, &y, &x_sums, &y_sums);
    std::vector<double> costs(pairs.size());
    parallelFor(pairs.size(), jobs, [&](std::size_t k) {
      Sums sums = pairSums(x[x_of[k]], y[y_of[k]], x_sums[x_of[k]], y_sums[y_of[k]], pressure_block_);
      costs[k] = solve(sums, false).rms;
    });
    return costs;
  }
  double cost(double position_shift, double valve_shift) const {
    return (*this)(position_shift, valve_shift).rms;
  }

 private:
  // Every window's parts and their blocks at each position shift and each valve shift, on up to `jobs`
  // threads.
  template <typename PositionParts, typename ValveParts>
  void partsAndBlocks(const std::vector<double>& position_shifts, const std::vector<double>& valve_shifts,
                      int jobs, PositionParts* x, ValveParts* y, std::vector<Sums>* x_sums,
                      std::vector<Sums>* y_sums) const {
    parallelFor(position_shifts.size() + valve_shifts.size(), jobs, [&](std::size_t k) {
      if (k < position_shifts.size()) {
        partsAt(position_shifts[k], &BalanceCost::positionPart, &(*x)[k]);
        (*x_sums)[k] = positionBlocks((*x)[k]);
      } else {
        const std::size_t j = k - position_shifts.size();
        partsAt(valve_shifts[j], &BalanceCost::valvePart, &(*y)[j]);
        (*y_sums)[j] = valveBlocks((*y)[j]);
      }
    });
  }

  // A window's columns that the position's shift moves: r(0), the left side z and the capacitive columns'
  // a at its ends; and those the valve's shift moves: the opening's terms r(3..8). The pressure's own
  // columns (r(1), r(2), leakage, constant) move with neither.
  struct PositionPart {
    bool usable = false;
    double r0 = 0.0, z = 0.0;
    Eigen::Vector3d a_begin, a_end;
  };
  struct ValvePart {
    bool usable = false;
    double terms[2 + kKnotCount] = {};
  };

  PositionPart positionPart(std::size_t window, double shift) const {
    PositionPart part;
    const std::size_t start = starts_[window];
    const CylinderGeometry& g = config_.geometry;
    // The window is a whole number of steps: the last step's end is the window's end.
    const double x_begin = at(s_.x, start, shift);
    double x0 = x_begin;
    for (std::size_t k = start; k < start + window_; k += stride_) {
      const double p0 = s_.p[k], p1 = s_.p[k + stride_];
      const double x1 = at(s_.x, k + stride_, shift);
      if (!std::isfinite(p0 + p1 + x0 + x1)) return part;
      part.r0 += g.piston_area * (g.stroke_length - 0.5 * (x0 + x1)) * (p1 - p0);
      x0 = x1;
    }
    const double x_end = x0;
    const auto a = [&](double x, double p) {
      return Eigen::Vector3d(
          g.piston_area * (g.stroke_length - x), 1.0,
          kAtmosphericPressure / ((p + kAtmosphericPressure) * (p + kAtmosphericPressure)));
    };
    part.a_begin = a(x_begin, s_.p[start]);
    part.a_end = a(x_end, s_.p[start + window_]);
    part.z = g.piston_area * (x_end - x_begin);
    part.usable = true;
    return part;
  }

  ValvePart valvePart(std::size_t window, double shift) const {
    ValvePart part;
    const std::size_t start = starts_[window];
    const double h = stride_ * dt_;
    const PortRoots* port = &port_roots_[window * (window_ / stride_ + 1)];
    // Each step's end is the next step's start: its valve terms are carried over, not computed twice.
    double p0 = s_.p[start], y0 = at(s_.y, start, shift);
    double terms0[2 + kKnotCount], terms1[2 + kKnotCount];
    valveTerms(y0, *port, terms0);
    for (std::size_t k = start; k < start + window_; k += stride_) {
      const double p1 = s_.p[k + stride_];
      const double y1 = at(s_.y, k + stride_, shift);
      if (!std::isfinite(p0 + p1 + y0 + y1)) return part;
      valveTerms(y1, *++port, terms1);
      for (int j = 0; j < 2 + kKnotCount; ++j) part.terms[j] += 0.5 * h * (terms0[j] + terms1[j]);
      p0 = p1;
      y0 = y1;
      std::copy(terms1, terms1 + 2 + kKnotCount, terms0);
    }
    part.usable = true;
    return part;
  }

  // Every window's part at `shift`, made by `part` (positionPart or valvePart).
  template <typename Part>
  void partsAt(double shift, Part (BalanceCost::*part)(std::size_t, double) const,
               std::vector<Part>* parts) const {
    parts->clear();
    parts->reserve(starts_.size());
    for (std::size_t w = 0; w < starts_.size(); ++w) parts->push_back((this->*part)(w, shift));
  }
  template <typename Part>
  struct PartsAt {
    double shift = std::numeric_limits<double>::quiet_NaN();  // [samples] NaN: none kept
    std::vector<Part> parts;                                  // per window
    Sums blocks;                                              // their own blocks of the normal equations
  };
  // The same, kept for the last shift asked, with their blocks (made by positionBlocks or valveBlocks).
  template <typename Part>
  const PartsAt<Part>& cachedParts(PartsAt<Part>& cache, double shift,
                                   Part (BalanceCost::*part)(std::size_t, double) const,
                                   Sums (BalanceCost::*blocks)(const std::vector<Part>&) const) const {
    if (!(cache.shift == shift)) {
      partsAt(shift, part, &cache.parts);
      cache.blocks = (this->*blocks)(cache.parts);
      cache.shift = shift;
    }
    return cache;
  }

  // The pressure's own columns of the window starting at `start` (no shift moves them).
  Vector pressureColumns(std::size_t start) const {
    Vector r = Vector::Zero();
    const double h = stride_ * dt_;
    for (std::size_t k = start; k < start + window_; k += stride_) {
      const double p0 = s_.p[k], p1 = s_.p[k + stride_];
      const double dp = p1 - p0, pm = 0.5 * (p0 + p1);
      r(1) += dp;
      r(2) += kAtmosphericPressure / ((pm + kAtmosphericPressure) * (pm + kAtmosphericPressure)) * dp;
      r(kRegressors - 2) += pm * h;
      r(kRegressors - 1) += h;
    }
    return r;
  }

  // The normal equations' blocks (costMap's, and operator()'s where the rows are not kept), in the lower
  // triangle like Sums::add's (columns: 0 position; 1, 2, kRegressors - 2, kRegressors - 1 the pressure's
  // own; 3 .. 8 the valve's). An unusable window leaves the blocks unusable (NaN), and the pair is then
  // summed whole.
  static constexpr int kPressureColumns[] = {1, 2, kRegressors - 2, kRegressors - 1};
  static constexpr int kValveTerms = 2 + kKnotCount;
  Sums pressureBlock() const {
    Sums sums;
    for (const Vector& r : pressure_columns_) sums.gram.selfadjointView<Eigen::Lower>().rankUpdate(r);
    return sums;
  }
  Sums positionBlocks(const std::vector<PositionPart>& x) const {
    Sums sums;
    for (std::size_t w = 0; w < starts_.size(); ++w) {
      if (!x[w].usable) {
        sums.zz = NAN;
        return sums;
      }
      const Vector& pc = pressure_columns_[w];
      sums.gram(0, 0) += x[w].r0 * x[w].r0;
      for (int c : kPressureColumns) {
        sums.gram(c, 0) += pc(c) * x[w].r0;
        sums.cross(c) += pc(c) * x[w].z;
      }
      sums.cross(0) += x[w].r0 * x[w].z;
      sums.zz += x[w].z * x[w].z;
      sums.noise_gram.noalias() += x[w].a_begin * x[w].a_begin.transpose();
      sums.noise_gram.noalias() += x[w].a_end * x[w].a_end.transpose();
    }
    return sums;
  }
  Sums valveBlocks(const std::vector<ValvePart>& y) const {
    Sums sums;
    for (std::size_t w = 0; w < starts_.size(); ++w) {
      if (!y[w].usable) {
        sums.zz = NAN;
        return sums;
      }
      const Vector& pc = pressure_columns_[w];
      for (int a = 0; a < kValveTerms; ++a) {
        for (int b = 0; b <= a; ++b) sums.gram(3 + a, 3 + b) += y[w].terms[a] * y[w].terms[b];
        for (int c : kPressureColumns) {
          // Lower triangle: the valve's columns lie between the pressure's 1, 2 and its last two.
          if (c < 3)
            sums.gram(3 + a, c) += y[w].terms[a] * pc(c);
          else
            sums.gram(c, 3 + a) += y[w].terms[a] * pc(c);
        }
      }
    }
    return sums;
  }
  // The normal equations summed window by window (the rows kept, in time order, where asked).
  Sums wholeSums(const std::vector<PositionPart>& x, const std::vector<ValvePart>& y, bool keep_rows) const {
    Sums sums;
    if (keep_rows) sums.rows.reserve(starts_.size());
    for (std::size_t w = 0; w < starts_.size(); ++w) {
      if (x[w].usable && y[w].usable)
        sums.add(row(w, x[w], y[w]), x[w].z, x[w].a_begin, x[w].a_end, keep_rows);
    }
    return sums;
  }
  // One pair's normal equations from the blocks, or summed whole where a window is unusable.
  Sums pairSums(const std::vector<PositionPart>& x, const std::vector<ValvePart>& y, const Sums& x_sums,
                const Sums& y_sums, const Sums& pressure) const {
    if (!std::isfinite(x_sums.zz) || !std::isfinite(y_sums.zz)) return wholeSums(x, y, false);
    Sums sums;
    double position_valve[kValveTerms] = {}, valve_cross[kValveTerms] = {};
    for (std::size_t w = 0; w < starts_.size(); ++w) {
      const double r0 = x[w].r0, z = x[w].z;
      for (int a = 0; a < kValveTerms; ++a) {
        position_valve[a] += r0 * y[w].terms[a];
        valve_cross[a] += z * y[w].terms[a];
      }
    }
    sums.gram = pressure.gram + x_sums.gram + y_sums.gram;
    sums.cross = x_sums.cross;
    for (int a = 0; a < kValveTerms; ++a) {
      sums.gram(3 + a, 0) = position_valve[a];
      sums.cross(3 + a) = valve_cross[a];
    }
    sums.zz = x_sums.zz;
    sums.noise_gram = x_sums.noise_gram;
    return sums;
  }

  // The window's row from its parts and the pressure's own columns (computed once, in the constructor).
  Vector row(std::size_t window, const PositionPart& x, const ValvePart& y) const {
    Vector r = pressure_columns_[window];
    r(0) = x.r0;
    for (int j = 0; j < 2 + kKnotCount; ++j) r(3 + j) = y.terms[j];
    return r;
  }

  Fit solve(Sums& sums, bool with_correlation) const {
    Matrix& gram = sums.gram;
    const Eigen::Matrix3d& noise_gram = sums.noise_gram;
    const Vector& cross = sums.cross;
    const double zz = sums.zz;
    const std::vector<std::pair<double, Vector>>& rows = sums.rows;
    Fit fit;
    fit.rows = static_cast<int>(starts_.size());
    if (gram(kRegressors - 1, kRegressors - 1) <= 0.0) return fit;
    const double rows_used = gram(kRegressors - 1, kRegressors - 1) / (window_ * dt_ * window_ * dt_);
    if (rows_used < kRegressors * 10) return fit;
    gram.template triangularView<Eigen::StrictlyUpper>() = gram.transpose();
    const Matrix measured = gram;
    gram.topLeftCorner<3, 3>() -= noise_variance_ * noise_gram;
    // Columns differ by many orders of magnitude: solve the equilibrated normal equations.
    Vector scale;
    for (int j = 0; j < kRegressors; ++j) scale(j) = gram(j, j) > 0.0 ? 1.0 / std::sqrt(gram(j, j)) : 1.0;
    const Matrix normalised = scale.asDiagonal() * gram * scale.asDiagonal();
    const Vector b = scale.cwiseProduct(cross);
    const Vector c = normalised.ldlt().solve(b);
    // The corrected fit's residual on the rows as measured (zz - c'b alone would take the removed noise as
    // explained, and could reach 0).
    const Vector coefficients_scaled = scale.cwiseProduct(c);
    const double squares =
        zz - 2.0 * coefficients_scaled.dot(cross) + coefficients_scaled.dot(measured * coefficients_scaled);
    fit.rms = std::sqrt(std::max(squares, 0.0) / rows_used);
    fit.rows = static_cast<int>(std::lround(rows_used));
    if (with_correlation && rows.size() > 2) {
      const Vector coefficients = scale.cwiseProduct(c);
      std::vector<double> e(rows.size());
      for (std::size_t i = 0; i < rows.size(); ++i) e[i] = rows[i].first - rows[i].second.dot(coefficients);
      double c0 = 0.0;
      for (double v : e) c0 += v * v;
      double factor = 1.0;
      for (std::size_t lag = 1; lag <= kCorrelationLags && lag < e.size(); ++lag) {
        double ck = 0.0;
        for (std::size_t i = lag; i < e.size(); ++i) ck += e[i] * e[i - lag];
        factor +=
            2.0 * (1.0 - static_cast<double>(lag) / (kCorrelationLags + 1)) * ck / c0;  // Bartlett weights
      }
      fit.correlation_factor = std::max(factor, 1.0);
    }
    return fit;
  }
  const Signals& s_;
  const IdentificationConfig& config_;
  double dt_;
  std::size_t stride_;
  std::size_t window_;
  std::vector<std::size_t> starts_;
  double noise_variance_;  // [Pa^2] the grid pressure's white noise
  std::vector<Vector, Eigen::aligned_allocator<Vector>> pressure_columns_;  // per window
  Sums pressure_block_;                // the pressure's own columns' block of the normal equations
  std::vector<PortRoots> port_roots_;  // each window's samples' (window_ / stride_ + 1 a window)
  mutable PartsAt<PositionPart> position_cache_;
  mutable PartsAt<ValvePart> valve_cache_;
};

}  // namespace die_cushion_ident::topic_delay_detail
