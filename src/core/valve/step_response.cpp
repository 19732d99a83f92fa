#include "die_cushion_ident/core/valve/step_response.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace die_cushion_ident {

namespace {
constexpr double kFraction = 1.0 - 0.36787944117144233;  // 1 - 1/e

// The cushion's velocity averaged over a window of fixed duration around a grid sample (NaN where a sample
// in it has none): at rest whatever the grid's period and the derived velocity's noise. Computed where a
// step is judged only (no copy of an hour's grid).
class RestVelocity {
 public:
  RestVelocity(const std::vector<GridSample>& grid, double window) : grid_(grid) {
    // The grid's period from its first intervals (a long recording's grid may hold only some of its cycles).
    std::vector<double> intervals;
    for (std::size_t k = 1; k < grid.size() && intervals.size() < 100; ++k) {
      if (grid[k].t > grid[k - 1].t) intervals.push_back(grid[k].t - grid[k - 1].t);
    }
    double period = 0.0;
    if (!intervals.empty()) {
      std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
      period = intervals[intervals.size() / 2];
    }
    half_ = period > 0.0 ? static_cast<std::size_t>(std::lround(0.5 * window / period)) : 0;
  }
  double at(std::size_t k) const {
    const std::size_t begin = k >= half_ ? k - half_ : 0, end = std::min(k + half_ + 1, grid_.size());
    double sum = 0.0;
    for (std::size_t j = begin; j < end; ++j) sum += grid_[j].v;  // NaN stays NaN
    return sum / static_cast<double>(end - begin);
  }

 private:
  const std::vector<GridSample>& grid_;
  std::size_t half_ = 0;
};

bool steady(const std::vector<GridSample>& grid, const RestVelocity& rest, std::size_t k, double u,
            double tolerance, double max_velocity) {
  const GridSample& g = grid[k];
  return g.complete && !g.discontinuity && std::isfinite(g.p) && std::isfinite(g.u) &&
         std::abs(g.u - u) <= tolerance && std::abs(rest.at(k)) <= max_velocity;
}

double meanPressure(const std::vector<double>& p, std::size_t begin, std::size_t end) {
  double sum = 0.0;
  for (std::size_t k = begin; k < end; ++k) sum += p[k];
  return end > begin ? sum / (end - begin) : std::numeric_limits<double>::quiet_NaN();
}
}  // namespace

double timeTo63Percent(const std::vector<double>& t, const std::vector<double>& p, double start,
                       double initial_pressure, double settled_fraction) {
  const std::size_t n = p.size();
  if (n < 5) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t tail = std::max<std::size_t>(1, static_cast<std::size_t>(settled_fraction * n));
  const double final_pressure = meanPressure(p, n - tail, n);
  const double target = initial_pressure + kFraction * (final_pressure - initial_pressure);
  const double direction = final_pressure >= initial_pressure ? 1.0 : -1.0;
  for (std::size_t k = 1; k < n; ++k) {
    if (direction * (p[k] - target) < 0.0) continue;
    const double below = direction * (target - p[k - 1]);
    const double above = direction * (p[k] - target);
    const double w = below + above > 0.0 ? below / (below + above) : 1.0;
    return t[k - 1] + w * (t[k] - t[k - 1]) - start;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

std::vector<StepResponse> findStepResponses(const std::vector<GridSample>& grid,
                                            const StepResponseOptions& options) {
  std::vector<StepResponse> found;
  const RestVelocity rest(grid, options.rest_window);
  for (std::size_t i = 1; i < grid.size(); ++i) {
    const double jump = grid[i].u - grid[i - 1].u;
    if (!(std::abs(jump) >= options.min_step) || !std::isfinite(jump)) continue;
    const double tolerance = 0.02 * std::abs(jump);
    // A steady command and a cushion at rest before the step ...
    std::size_t first = i;
    while (first > 0 && grid[i].t - grid[first - 1].t <= options.before &&
           steady(grid, rest, first - 1, grid[i - 1].u, tolerance, options.max_rest_velocity)) {
      --first;
    }
    if (grid[i].t - grid[first].t < 0.9 * options.before) continue;
    // ... and the new command held, still at rest.
    std::size_t last = i;
    while (last + 1 < grid.size() &&
           steady(grid, rest, last + 1, grid[i].u, tolerance, options.max_rest_velocity)) {
      ++last;
    }
    if (!steady(grid, rest, i, grid[i].u, tolerance, options.max_rest_velocity) ||
        grid[last].t - grid[i].t < options.min_hold) {
      continue;
    }
    std::vector<double> t, p;
    for (std::size_t k = i; k <= last; ++k) {
      t.push_back(grid[k].t);
      p.push_back(grid[k].p);
    }
    std::vector<double> before;
    for (std::size_t k = first; k < i; ++k) before.push_back(grid[k].p);
    StepResponse r;
    // The command changed between the two samples: the step is taken at their middle.
    r.start = 0.5 * (grid[i - 1].t + grid[i].t);
    r.step_voltage = jump;
    r.initial_pressure = meanPressure(before, 0, before.size());
    const std::size_t n = p.size();
    const std::size_t tail = std::max<std::size_t>(1, static_cast<std::size_t>(options.settled_fraction * n));
    r.final_pressure = meanPressure(p, n - tail, n);
    const double change = r.final_pressure - r.initial_pressure;
    const double earlier = meanPressure(p, n - 2 * tail, n - tail);
    i = last;
    if (!(std::abs(change) >= options.min_change) ||
        std::abs(earlier - r.final_pressure) > 0.05 * std::abs(change)) {
      continue;  // nothing to time, or not settled
    }
    r.t63 = timeTo63Percent(t, p, r.start, r.initial_pressure, options.settled_fraction);
    if (std::isfinite(r.t63) && r.t63 > 0.0) found.push_back(r);
  }
  return found;
}

}  // namespace die_cushion_ident
