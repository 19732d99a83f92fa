#include "die_cushion_ident/core/adequacy/effect_onset.h"

#include <algorithm>
#include <boost/math/distributions/students_t.hpp>
#include <climits>
#include <cmath>
#include <limits>

#include "die_cushion_ident/core/adequacy/cycle_group_fits.h"
#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/model/effect_library.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "die_cushion_ident/core/util/least_squares_line.h"

namespace die_cushion_ident {

namespace {

constexpr int kMinimumSide = 2;  // groups on each side of a split

struct Step {
  int split = 0;  // the first group after it
  double before = 0.0, after = 0.0, before_std = 0.0, after_std = 0.0, t = 0.0;
  double step_squares = 0.0;  // residual sum of squares of the two means
};

double mean(const std::vector<double>& v, std::size_t begin, std::size_t end) {
  double sum = 0.0;
  for (std::size_t i = begin; i < end; ++i) sum += v[i];
  return sum / static_cast<double>(end - begin);
}

double squaresAbout(const std::vector<double>& v, std::size_t begin, std::size_t end, double m) {
  double sum = 0.0;
  for (std::size_t i = begin; i < end; ++i) sum += (v[i] - m) * (v[i] - m);
  return sum;
}

// The split of `v` whose two means differ most in units of the pooled scatter within the two sides.
Step largestStep(const std::vector<double>& v) {
  Step best;
  const std::size_t g = v.size();
  for (std::size_t k = kMinimumSide; k + kMinimumSide <= g; ++k) {
    const double before = mean(v, 0, k), after = mean(v, k, g);
    const double squares = squaresAbout(v, 0, k, before) + squaresAbout(v, k, g, after);
    const double scatter = std::sqrt(squares / static_cast<double>(g - 2));
    const double nb = static_cast<double>(k), na = static_cast<double>(g - k);
    const double t = scatter > 0.0 ? (after - before) / (scatter * std::sqrt(1.0 / nb + 1.0 / na)) : 0.0;
    if (std::abs(t) > std::abs(best.t)) {
      best = {static_cast<int>(k),     before, after,  scatter / std::sqrt(nb),
              scatter / std::sqrt(na), t,      squares};
    }
  }
  return best;
}

// Residual sum of squares of the least-squares line through v over its index.
double lineSquares(const std::vector<double>& v) {
  const LeastSquaresLine line = fitLeastSquaresLine([&](const auto& visit) {
    for (std::size_t i = 0; i < v.size(); ++i) visit(static_cast<double>(i), v[i]);
  });
  double squares = 0.0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const double e = v[i] - line.at(static_cast<double>(i));
    squares += e * e;
  }
  return squares;
}

// [Pa] the free-run error over cycles `first_cycle` ... of `config`'s model fitted to them alone.
double freeRunErrorFrom(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                        const IdentificationConfig& config, int first_cycle) {
  const auto [begin, end] = strokes.range(first_cycle, INT_MAX);
  const std::vector<GridSample> after(
      grid.begin() + static_cast<std::ptrdiff_t>(std::min(begin, grid.size())),
      grid.begin() + static_cast<std::ptrdiff_t>(std::min(end, grid.size())));
  const StrokeSegmentation segments = segmentStrokes(after);
  const HydraulicEstimate fit = fitOnCycles(after, segments, config, INT_MIN, INT_MAX);
  if (fit.updates == 0 || !fit.values().allFinite()) return std::numeric_limits<double>::infinity();
  const HydraulicModel model =
      HydraulicModel::fromNames(config.geometry, config.effects, config.custom_effects, config.oil);
  const double error =
      assessModel(after, segments, model, fit.values(), config.min_pressure).simulation_error_rms;
  return std::isfinite(error) && error > 0.0 ? error : std::numeric_limits<double>::infinity();
}

}  // namespace

namespace {

// The step in `name`'s parameter over the cycle groups' fits with the effect in the model, where there is
// one that is a step (not a drift) and plausible; `tests` counts the splits tried.
std::optional<EffectOnset> effectStep(const std::string& name, const IdentificationConfig& with,
                                      const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                      int max_groups, int jobs, int* tests) {
  const ParameterInfo info = makeLibraryEffect(name, with.oil)->parameterFor(with.geometry);
  const CycleGroupFits groups(grid, strokes, with, max_groups, jobs);
  if (!groups.valid()) return std::nullopt;
  std::vector<double> series;
  for (int g = 0; g < groups.size(); ++g) {
    for (const IdentifiedParameter& p : groups.estimate(g).parameters) {
      if (p.name == info.name) series.push_back(p.value);
    }
  }
  if (static_cast<int>(series.size()) != groups.size() || series.size() < 2 * kMinimumSide + 1)
    return std::nullopt;
  if (!std::all_of(series.begin(), series.end(), [](double x) { return std::isfinite(x); }))
    return std::nullopt;
  *tests += static_cast<int>(series.size()) - 2 * kMinimumSide + 1;
  const Step step = largestStep(series);
  // A step, not a drift: two means fit the series better than a line through it.
  if (!(step.step_squares < lineSquares(series))) return std::nullopt;
  // Within the effect's physical range (three stds of slack) on the side where it acts, the larger: another
  // effect that starts pulls this one's parameter too, often out of it (an overlap that starts made the
  // leakage negative). The other side may lie outside: one cycle's fit of an effect that is not there
  // scatters about 0 (a valve overlap -1.3 % before one started).
  const auto plausible = [&](double value, double std) {
    return value >= info.lower_bound - 3.0 * std && value <= info.upper_bound + 3.0 * std;
  };
  const bool grows = std::abs(step.after) >= std::abs(step.before);
  if (grows ? !plausible(step.after, step.after_std) : !plausible(step.before, step.before_std))
    return std::nullopt;
  EffectOnset onset;
  onset.effect = name;
  onset.parameter = info.name;
  onset.unit = info.unit;
  onset.cycle = groups.firstCycle(step.split);
  onset.before = step.before;
  onset.after = step.after;
  onset.before_std = step.before_std;
  onset.after_std = step.after_std;
  onset.t_statistic = step.t;
  const boost::math::students_t t_distribution(static_cast<double>(series.size()) - 2.0);
  onset.p_value = 2.0 * boost::math::cdf(boost::math::complement(t_distribution, std::abs(step.t)));
  return onset;
}

// When the onset happened, the press's cycle period, and the onset in words; in the recording's cycles where
// the grid holds every cycle_stride-th.
void describeOnset(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes, int cycle_stride,
                   double recording_start, int first_cycle, EffectOnset& o) {
  const std::size_t begin = strokes.range(o.cycle, o.cycle).first;
  const double start = std::isfinite(recording_start) ? recording_start : grid.front().t;
  o.time = begin < grid.size() ? grid[begin].t - start : 0.0;
  o.cycle = o.cycle * cycle_stride + first_cycle;
  std::vector<double> periods;
  for (std::size_t c = 1; c < strokes.cycle_start.size(); ++c) {
    periods.push_back(grid[strokes.cycle_start[c]].t - grid[strokes.cycle_start[c - 1]].t);
  }
  std::nth_element(periods.begin(), periods.begin() + periods.size() / 2, periods.end());
  o.cycle_period = periods.empty() ? 0.0 : periods[periods.size() / 2] / cycle_stride;
  o.explanation =
      o.effect +
      formatted(FMT_STRING(" from press cycle {} on (its impact {:.2f} s into the recording): "), o.cycle,
                o.time) +
      o.parameter +
      formatted(FMT_STRING(" {:.3g} +- {:.2g} over the cycles before, {:.3g} +- {:.2g} from it on ("),
                o.before, o.before_std, o.after, o.after_std) +
      o.unit +
      formatted(
          FMT_STRING("; each cycle fitted alone, step t = {:.1f}, p = {:.2g} over every cycle and effect "
                     "tried): the plant changed while it was recorded"),
          o.t_statistic, o.p_value);
}

}  // namespace

std::optional<EffectOnset> findEffectOnset(const std::vector<GridSample>& grid,
                                           const StrokeSegmentation& strokes,
                                           const IdentificationConfig& config, double significance, int jobs,
                                           int max_groups, int cycle_stride, double recording_start,
                                           int first_cycle) {
  if (strokes.cycles < kOnsetMinimumCycles) return std::nullopt;
  int tests = 0;
  std::vector<std::pair<EffectOnset, IdentificationConfig>> steps;  // each effect's step, its model
  for (const std::string& name : libraryEffectNames()) {
    // The oil's temperature changes gradually and is measured: no onset to look for (a drift, not a step).
    if (makeLibraryEffect(name, config.oil)->needsOilTemperature()) continue;
    IdentificationConfig with = config;
    if (std::find(with.effects.begin(), with.effects.end(), name) == with.effects.end())
      with.effects.push_back(name);
    if (auto onset = effectStep(name, with, grid, strokes, max_groups, jobs, &tests))
      steps.emplace_back(*onset, with);
  }
  // Where several effects step (one that starts pulls the others' parameters too: an overlap that starts
  // moves a tank pressure, a leak an air volume), one that appears or grows (its parameter moves away from
  // 0) before one that shrinks (an overlap that started pulled a tank pressure down), and of those the one
  // whose model, fitted to the cycles from its step on, runs free closest to them.
  std::optional<EffectOnset> found;
  std::pair<bool, double> best = {true, std::numeric_limits<double>::infinity()};  // shrinks, error
  for (auto& [onset, with] : steps) {
    onset.p_value = std::min(1.0, onset.p_value * std::max(tests, 1));
    if (!(onset.p_value < significance)) continue;
    const bool shrinks = std::abs(onset.after) < std::abs(onset.before);
    if (shrinks && !best.first) continue;
    const double error = freeRunErrorFrom(grid, strokes, with, onset.cycle);
    const std::pair<bool, double> key = {shrinks, error};
    if (!(key < best)) continue;
    best = key;
    found = onset;
  }
  if (found) describeOnset(grid, strokes, cycle_stride, recording_start, first_cycle, *found);
  return found;
}

}  // namespace die_cushion_ident
