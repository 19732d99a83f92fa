#include "die_cushion_ident/core/adequacy/held_out_test.h"

#include <algorithm>
#include <boost/math/distributions/students_t.hpp>
#include <climits>
#include <cmath>
#include <future>
#include <limits>
#include <memory>
#include <tuple>
#include <utility>

#include "die_cushion_ident/core/fits/free_run_pressure.h"
#include "die_cushion_ident/core/fits/output_error_refinement.h"
#include "die_cushion_ident/core/util/parallel_for.h"

namespace die_cushion_ident {

namespace {
using Stretch = std::pair<std::size_t, std::size_t>;  // [begin, end) of the grid

// A batch fit without forgetting over stretches of the grid, each starting afresh (a discontinuity); the
// identifier that holds it.
std::unique_ptr<HydraulicIdentifier> fitIdentifierOnStretches(const std::vector<GridSample>& grid,
                                                              const IdentificationConfig& config,
                                                              const std::vector<Stretch>& stretches) {
  IdentificationConfig batch = config;
  batch.forgetting_factor = 1.0;  // constant parameters over the whole recording: least squares
  const auto pass = [&](const ParameterVector* frozen_point) {
    auto identifier = std::make_unique<HydraulicIdentifier>(batch);
    if (frozen_point) identifier->freezeLinearisationPoint(*frozen_point);
    for (const Stretch& stretch : stretches) {
      for (std::size_t i = stretch.first; i < stretch.second && i < grid.size(); ++i) {
        GridSample g = grid[i];
        if (i == stretch.first) g.discontinuity = true;
        identifier->push(g);
      }
    }
    return identifier;
  };
  auto identifier = pass(nullptr);
  bool relinearised = false;
  for (int i = 0; i < identifier->model().effectCount(); ++i) {
    relinearised |= identifier->model().effect(i).coupling() != Effect::Coupling::kAdditive;
  }
  // Valve-shape and oil-state effects are linearised at the running estimate; without forgetting, rows
  // linearised at an early, wrong overlap, tank pressure or temperature coefficient would weigh as much as
  // the rest for good. A second pass with every row linearised at the first pass's estimate removes that
  // (issue 16).
  const ParameterVector physical = identifier->physicalParameters();
  if (relinearised && identifier->updates() > 0 && physical.allFinite()) identifier = pass(&physical);
  return identifier;
}

HydraulicEstimate fitOnStretches(const std::vector<GridSample>& grid, const IdentificationConfig& config,
                                 const std::vector<Stretch>& stretches) {
  return fitIdentifierOnStretches(grid, config, stretches)->estimate();
}
}  // namespace

namespace {

// The training cycles' fit refined by their free run where that reaches the noise, as the reported model is:
// a clean fast press whose equation-error fit left twice the noise (its release shorter than the filter
// windows) was otherwise "missing" a tank pressure, an extra parameter that absorbed the fit's error.
ParameterVector refinedOnTraining(const std::vector<GridSample>& grid,
                                  std::pair<std::size_t, std::size_t> range, const HydraulicModel& model,
                                  const HydraulicEstimate& estimate, const IdentificationConfig& config) {
  OutputErrorOptions without_stds;
  without_stds.with_stds = false;
  without_stds.pressure_noise = config.grid_pressure_noise;
  // Stopped at a thousandth of the cost: far below what a held-out test resolves.
  without_stds.function_tolerance = 1e-3;
  // Only the samples the refinement reads (its first max_samples): on an hour's recording a copy of the
  // whole half per candidate and fold, on both cores, took 130 MB more than the analysis itself.
  const std::size_t first = std::min(range.first, grid.size());
  const std::size_t last = std::min({range.second, grid.size(), first + without_stds.max_samples});
  const std::vector<GridSample> training(grid.begin() + static_cast<std::ptrdiff_t>(first),
                                         grid.begin() + static_cast<std::ptrdiff_t>(last));
  const OutputErrorFit refined = refineByOutputError(
      training, model, estimate.values(), estimate.standardDeviations(), config.min_pressure, without_stds);
  return refined.improved ? refined.theta : estimate.values();
}

// Each held-out cycle's free-run sum of squared errors and its samples, the model run free from each
// cycle's start: a cycle's error is its own, not carried over from the one before.
// With `reference`, each cycle's mean square difference from it goes to `adjustment`.
// With `predictions`, the free runs are kept there too (each fold writes only its own held-out cycles).
void addHeldOutSquares(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                       const HydraulicModel& model, const ParameterVector& theta, double min_pressure,
                       int test_first, int test_last, std::vector<double>& sum, std::vector<int>& count,
                       const std::vector<float>* reference, std::vector<double>& adjustment,
                       std::vector<float>* predictions) {
  for (int c = test_first; c <= test_last; ++c) {
    const auto [begin, end] = strokes.range(c, c);
    const SquaredErrors cycle =
        freeRunSquaredErrors(grid, begin, end, model, theta, min_pressure, reference, predictions);
    sum[c] += cycle.sum;
    count[c] += static_cast<int>(cycle.samples);
    if (reference && cycle.differences > 0)
      adjustment[c] = cycle.difference_sum / static_cast<double>(cycle.differences);
  }
}

HeldOutErrors heldOutErrorsOfFolds(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                   const std::array<const IdentificationConfig*, 2>& fold_configs, int split,
                                   bool side_by_side, std::unique_ptr<HydraulicIdentifier> (&fits)[2],
                                   const HeldOutErrors* base, bool keep_predictions = false) {
  HeldOutErrors result;
  std::vector<float> predictions;
  if (keep_predictions) predictions.assign(grid.size(), std::numeric_limits<float>::quiet_NaN());
  result.cycle_rms.assign(strokes.cycles, std::numeric_limits<double>::quiet_NaN());
  // Each fold fills only its own held-out cycles' sums.
  std::vector<double> sum(strokes.cycles, 0.0);
  std::vector<int> count(strokes.cycles, 0);
  const std::vector<float>* reference = base && base->predictions ? base->predictions.get() : nullptr;
  if (reference) {
    result.cycle_adjustment.assign(strokes.cycles, std::numeric_limits<double>::quiet_NaN());
    result.adjusted_against = reference;
  }
  auto folds = std::make_shared<std::array<HeldOutErrors::Fold, 2>>();
  const auto fold = [&](int which) {
    const IdentificationConfig& config = *fold_configs[which];
    const HydraulicModel model =
        HydraulicModel::fromNames(config.geometry, config.effects, config.custom_effects, config.oil);
    const int fit_first = which == 0 ? 0 : split, fit_last = which == 0 ? split - 1 : strokes.cycles - 1;
    const int test_first = which == 0 ? split : 0, test_last = which == 0 ? strokes.cycles - 1 : split - 1;
    fits[which] = fitIdentifierOnStretches(grid, config, {strokes.range(fit_first, fit_last)});
    const ParameterVector theta = config.refine_held_out_fits
                                      ? refinedOnTraining(grid, strokes.range(fit_first, fit_last), model,
                                                          fits[which]->estimate(), config)
                                      : fits[which]->estimate().values();
    addHeldOutSquares(grid, strokes, model, theta, config.min_pressure, test_first, test_last, sum, count,
                      reference, result.cycle_adjustment, keep_predictions ? &predictions : nullptr);
    (*folds)[which] = {config, theta, test_first, test_last};
  };
  std::future<void> second = std::async(side_by_side ? std::launch::async : std::launch::deferred, fold, 1);
  fold(0);
  second.get();
  double total = 0.0;
  int total_n = 0;
  for (int c = 0; c < strokes.cycles; ++c) {
    if (count[c] == 0) continue;
    result.cycle_rms[c] = std::sqrt(sum[c] / count[c]);
    total += sum[c];
    total_n += count[c];
  }
  result.rms = total_n > 0 ? std::sqrt(total / total_n) : 0.0;
  result.folds = std::move(folds);
  if (keep_predictions)
    result.predictions = std::make_shared<const std::vector<float>>(std::move(predictions));
  return result;
}

// Per cycle, the mean square difference of two free runs (NaN where they never run together).
std::vector<double> meanSquareDifferences(const StrokeSegmentation& strokes, const std::vector<float>& a,
                                          const std::vector<float>& b) {
  std::vector<double> differences(strokes.cycles, std::numeric_limits<double>::quiet_NaN());
  for (int c = 0; c < strokes.cycles; ++c) {
    const auto [begin, end] = strokes.range(c, c);
    double sum = 0.0;
    std::size_t n = 0;
    for (std::size_t i = begin; i < end && i < a.size() && i < b.size(); ++i) {
      if (!std::isfinite(a[i]) || !std::isfinite(b[i])) continue;
      sum += (static_cast<double>(a[i]) - b[i]) * (static_cast<double>(a[i]) - b[i]);
      ++n;
    }
    if (n > 0) differences[c] = sum / static_cast<double>(n);
  }
  return differences;
}

// The adjustment of `with` against `base`: accumulated while `with` ran, or from both models run again.
std::vector<double> adjustmentOf(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                 const HeldOutErrors& base, const HeldOutErrors& with) {
  if (with.adjusted_against && with.adjusted_against == base.predictions.get()) return with.cycle_adjustment;
  if (!base.folds || !with.folds) return {};
  // Each side's kept free runs where it has them.
  const auto runsOf = [&](const HeldOutErrors& errors, std::vector<float>* own) -> const std::vector<float>& {
    if (errors.predictions) return *errors.predictions;
    *own = heldOutPredictions(grid, strokes, errors);
    return *own;
  };
  std::vector<float> base_own, with_own;
  return meanSquareDifferences(strokes, runsOf(base, &base_own), runsOf(with, &with_own));
}

// Which of the two held-out groups a cycle is in (the cycles before `split`, the rest), and on how many
// cycles each group's fit was trained.
struct FoldSizes {
  int split = 0;
  std::array<int, 2> trained = {0, 0};
  int foldOf(int cycle) const { return cycle < split ? 0 : 1; }
};

FoldSizes foldSizes(const HeldOutErrors& base, const HeldOutErrors& with) {
  FoldSizes sizes;
  const HeldOutErrors& known = with.folds ? with : base;
  if (known.folds) {
    const auto& f = *known.folds;
    // The fold that tests the first cycles trained on the others, and the other way round.
    const int first = f[0].test_first <= f[1].test_first ? 0 : 1;
    sizes.split = f[first].test_last + 1;
    sizes.trained = {f[1 - first].test_last - f[1 - first].test_first + 1,
                     f[first].test_last - f[first].test_first + 1};
  } else {
    const int cycles = static_cast<int>(std::min(base.cycle_rms.size(), with.cycle_rms.size()));
    sizes.split = cycles / 2;
    sizes.trained = {cycles - sizes.split, sizes.split};
  }
  return sizes;
}

// Nadeau and Bengio's correction for held-out units that share a fit: every cycle a fold tests is judged
// with the same fitted extension, so their gains share that fit's noise, of variance about 1/n_train of
// one cycle's. The mean's variance is then s^2/n (1 + sum_f n_test,f^2 / (n n_train,f)). Used only where
// the held-out cycles are all in one fold, so the shared part cannot be measured.
double sharedFitInflation(const std::array<int, 2>& tested, const FoldSizes& folds) {
  const int n = tested[0] + tested[1];
  double inflation = 1.0;
  for (int f = 0; f < 2; ++f) {
    if (tested[f] > 0 && folds.trained[f] > 0) {
      inflation += static_cast<double>(tested[f]) * tested[f] / (static_cast<double>(n) * folds.trained[f]);
    }
  }
  return inflation;
}

// The variance of the gains' mean under a one-way random-effects model of the folds: gain = mean + the
// fold's shared fit noise u_f + the cycle's own e_c. Within the folds, MSW estimates var(e); between them,
// MSB estimates var(e) + n0 var(u) (n0 = (n - sum n_f^2 / n), one degree of freedom for two folds). The
// shared part cannot be negative, so var(u) is (MSB - MSW) / n0 where that is positive and 0 otherwise;
// var(mean) = var(e) / n + var(u) sum (n_f / n)^2, which is max(MSW, MSB) / n for two equal folds. The
// constant Nadeau-Bengio factor (2 for two halves) assumed the largest shared part whatever the folds
// showed: on clean presses, whose folds agree, the test's size was 1-2 % at 5 % (doc/model_adequacy.md).
double varianceOfMeanGain(const std::vector<double>& gains, const std::vector<int>& fold_of,
                          const FoldSizes& folds) {
  const int n = static_cast<int>(gains.size());
  std::array<int, 2> count = {0, 0};
  std::array<double, 2> fold_mean = {0.0, 0.0};
  double mean = 0.0;
  for (int c = 0; c < n; ++c) {
    ++count[fold_of[c]];
    fold_mean[fold_of[c]] += gains[c];
    mean += gains[c] / n;
  }
  double within = 0.0, total = 0.0;
  for (int f = 0; f < 2; ++f)
    if (count[f] > 0) fold_mean[f] /= count[f];
  for (int c = 0; c < n; ++c) {
    within += (gains[c] - fold_mean[fold_of[c]]) * (gains[c] - fold_mean[fold_of[c]]);
    total += (gains[c] - mean) * (gains[c] - mean);
  }
  if (count[0] == 0 || count[1] == 0 || n < 3)
    return n > 1 ? total / (n - 1) / n * sharedFitInflation(count, folds) : 0.0;
  const double msw = within / (n - 2);
  double between = 0.0, share = 0.0;
  for (int f = 0; f < 2; ++f) {
    between += count[f] * (fold_mean[f] - mean) * (fold_mean[f] - mean);
    share += static_cast<double>(count[f]) * count[f] / (static_cast<double>(n) * n);
  }
  const double n0 = n - share * n;
  const double shared = std::max(between - msw, 0.0) / n0;
  return msw / n + shared * share;
}

}  // namespace

SquaredErrors freeRunSquaredErrors(const std::vector<GridSample>& grid, std::size_t begin, std::size_t end,
                                   const HydraulicModel& model, const ParameterVector& theta,
                                   double min_pressure, const std::vector<float>* reference,
                                   std::vector<float>* predictions) {
  SquaredErrors errors;
  FreeRunPressure free_run(model, min_pressure);
  for (std::size_t i = begin; i < end && i < grid.size(); ++i) {
    GridSample g = grid[i];
    if (i == begin) g.discontinuity = true;
    const GridSample* next = i + 1 < end && i + 1 < grid.size() ? &grid[i + 1] : nullptr;
    const double p = free_run.step(g, theta, next);
    if (!std::isfinite(p) || free_run.anchoredThisStep()) continue;
    if (predictions && i < predictions->size()) (*predictions)[i] = static_cast<float>(p);
    if (reference && i < reference->size() && std::isfinite((*reference)[i])) {
      errors.difference_sum += (p - (*reference)[i]) * (p - (*reference)[i]);
      ++errors.differences;
    }
    if (!std::isfinite(g.p)) continue;
    errors.sum += (g.p - p) * (g.p - p);
    ++errors.samples;
  }
  return errors;
}

std::vector<float> heldOutPredictions(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                      const HeldOutErrors& errors) {
  std::vector<float> predictions(grid.size(), std::numeric_limits<float>::quiet_NaN());
  if (!errors.folds) return predictions;
  for (const HeldOutErrors::Fold& f : *errors.folds) {
    const HydraulicModel model =
        HydraulicModel::fromNames(f.config.geometry, f.config.effects, f.config.custom_effects, f.config.oil);
    for (int c = f.test_first; c <= f.test_last; ++c) {
      const auto [begin, end] = strokes.range(c, c);
      freeRunSquaredErrors(grid, begin, end, model, f.theta, f.config.min_pressure, nullptr, &predictions);
    }
  }
  return predictions;
}

void keepPredictions(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                     HeldOutErrors* errors) {
  if (errors->predictions || !errors->folds) return;
  errors->predictions =
      std::make_shared<const std::vector<float>>(heldOutPredictions(grid, strokes, *errors));
}

HeldOutErrors heldOutErrors(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                            const IdentificationConfig& config, int split, bool side_by_side,
                            HydraulicEstimate* fitted_on_both, const HeldOutErrors* base) {
  std::unique_ptr<HydraulicIdentifier> fits[2];
  HeldOutErrors result =
      heldOutErrorsOfFolds(grid, strokes, {&config, &config}, split, side_by_side, fits, base);
  if (fitted_on_both) *fitted_on_both = fits[0]->combinedEstimate(*fits[1]);
  return result;
}

HeldOutErrors heldOutErrorsKept(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                const IdentificationConfig& config, int split, bool side_by_side) {
  std::unique_ptr<HydraulicIdentifier> fits[2];
  return heldOutErrorsOfFolds(grid, strokes, {&config, &config}, split, side_by_side, fits, nullptr, true);
}

HeldOutErrors heldOutErrors(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                            const std::array<IdentificationConfig, 2>& fold_configs, int split,
                            bool side_by_side, const HeldOutErrors* base) {
  std::unique_ptr<HydraulicIdentifier> fits[2];
  return heldOutErrorsOfFolds(grid, strokes, {&fold_configs[0], &fold_configs[1]}, split, side_by_side, fits,
                              base);
}

HeldOutComparison compareHeldOut(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                 const HeldOutErrors& base, const HeldOutErrors& with, double significance) {
  HeldOutComparison result;
  result.error_reduction = base.rms > 0.0 ? 1.0 - with.rms / base.rms : 0.0;
  result.base_rms = base.rms;
  result.with_rms = with.rms;
  const std::vector<double> adjustment = adjustmentOf(grid, strokes, base, with);
  const FoldSizes folds = foldSizes(base, with);
  // Paired by cycle id: a cycle that one model could not run does not shift the others.
  std::vector<double> gains;
  std::vector<int> fold_of;
  for (std::size_t c = 0; c < base.cycle_rms.size() && c < with.cycle_rms.size(); ++c) {
    const double base_square = base.cycle_rms[c] * base.cycle_rms[c];
    const double with_square = with.cycle_rms[c] * with.cycle_rms[c];
    if (!std::isfinite(base_square) || !std::isfinite(with_square) || !(base_square > 0.0)) continue;
    const double adjust = c < adjustment.size() && std::isfinite(adjustment[c]) ? adjustment[c] : 0.0;
    gains.push_back((base_square - with_square + adjust) / base_square);
    fold_of.push_back(folds.foldOf(static_cast<int>(c)));
  }
  const int n = static_cast<int>(gains.size());
  result.cycles = n;
  if (n == 0) return result;
  double mean = 0.0;
  for (double d : gains) mean += d / n;
  const double standard_error = std::sqrt(varianceOfMeanGain(gains, fold_of, folds));
  // Negative where the extension predicts better, as the verdicts read it.
  result.t_statistic = standard_error > 0.0 ? -mean / standard_error : (mean > 0 ? -1e9 : 1e9);
  if (n > 1) {
    // Exact Student quantile (the Cornish-Fisher expansion used before was 1.8 % low at 3 degrees of
    // freedom).
    const boost::math::students_t_distribution<double> student(n - 1);
    const double critical = boost::math::quantile(student, 1.0 - significance);
    result.significant = result.t_statistic < -critical;
    result.p_value = std::isfinite(result.t_statistic) && std::abs(result.t_statistic) < 1e8
                         ? boost::math::cdf(student, result.t_statistic)
                         : (result.t_statistic < 0 ? 0.0 : 1.0);
  }
  return result;
}

std::vector<bool> holmRejected(const std::vector<double>& p_values, double significance) {
  std::vector<std::size_t> order(p_values.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  // A p-value that could not be computed (NaN) is never a rejection and goes last: sorted among the others
  // it broke the ordering (std::sort needs a strict weak order) and, put first, stopped every rejection.
  const auto key = [&](std::size_t i) {
    return std::isnan(p_values[i]) ? std::numeric_limits<double>::infinity() : p_values[i];
  };
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return key(a) < key(b); });
  std::vector<bool> rejected(p_values.size(), false);
  const std::size_t m = p_values.size();
  for (std::size_t k = 0; k < m; ++k) {
    if (!(p_values[order[k]] <= significance / static_cast<double>(m - k))) break;
    rejected[order[k]] = true;
  }
  return rejected;
}

HydraulicEstimate fitOnCycles(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                              const IdentificationConfig& config, int first_cycle, int last_cycle) {
  return fitOnStretches(grid, config, {strokes.range(first_cycle, last_cycle)});
}

bool applyCycleJackknife(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                         const IdentificationConfig& config, HydraulicEstimate* estimate, int groups, int jobs) {
  const int cycles = strokes.cycles;
  const int g_count = std::min(groups, cycles);
  if (g_count < 4 || estimate->parameters.empty()) return false;
  const std::size_t n = estimate->parameters.size();
  const auto all = strokes.range(INT_MIN, INT_MAX);
  std::vector<std::vector<double>> replicates(static_cast<std::size_t>(g_count));
  parallelFor(replicates.size(), jobs, [&](std::size_t group) {
    const int g = static_cast<int>(group);
    // Group g: cycles [g * cycles / G, (g + 1) * cycles / G), contiguous; the rest of the recording
    // (with whatever precedes the first and follows the last cycle) is refitted without it.
    const int first = g * cycles / g_count, last = (g + 1) * cycles / g_count - 1;
    const auto left_out = strokes.range(first, last);
    std::vector<Stretch> kept;
    if (left_out.first > all.first) kept.emplace_back(all.first, left_out.first);
    if (all.second > left_out.second) kept.emplace_back(left_out.second, all.second);
    const HydraulicEstimate e = fitOnStretches(grid, config, kept);
    if (e.updates == 0 || e.parameters.size() != n) return;
    std::vector<double> values(n);
    for (std::size_t k = 0; k < n; ++k) values[k] = e.parameters[k].value;
    replicates[group] = std::move(values);
  });
  for (const auto& r : replicates) {
    if (r.size() != n) return false;
  }
  for (std::size_t k = 0; k < n; ++k) {
    double mean = 0.0;
    for (const auto& r : replicates) mean += r[k] / g_count;
    double squares = 0.0;
    for (const auto& r : replicates) squares += (r[k] - mean) * (r[k] - mean);
    const double se = std::sqrt((g_count - 1.0) / g_count * squares);
    if (!std::isfinite(se)) return false;
    estimate->parameters[k].std = se;
  }
  return true;
}

}  // namespace die_cushion_ident
