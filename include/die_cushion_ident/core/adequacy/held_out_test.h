#pragma once

#include <array>
#include <memory>
#include <vector>

#include "die_cushion_ident/core/adequacy/model_assessment.h"
#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"
#include "die_cushion_ident/core/estimation/identification_config.h"

namespace die_cushion_ident {

/// Free-run pressure error of one model on press cycles it was not fitted to: fitted without forgetting
/// on cycles [0, split), run free on [split, cycles), and the other way round. The free run starts from
/// the measurement at each cycle.
struct HeldOutErrors {
  std::vector<double> cycle_rms;  ///< [Pa] per cycle id; NaN where a cycle has no held-out sample
  double rms = 0.0;               ///< [Pa] over all held-out samples
  /// The model each fold ran free on its held-out cycles (to run it again: heldOutPredictions).
  struct Fold {
    IdentificationConfig config;
    ParameterVector theta;
    int test_first = 0, test_last = -1;  ///< the held-out cycles
  };
  std::shared_ptr<const std::array<Fold, 2>> folds;
  /// [Pa] the held-out free runs at every grid sample (NaN where none runs), kept where these errors are the
  /// base that extensions are compared with (keepPredictions); null otherwise (an hour's grid is 7 MB).
  std::shared_ptr<const std::vector<float>> predictions;
  /// [Pa^2] per cycle id, the mean square difference between this model's held-out free run and the one in
  /// `adjusted_against`, accumulated while this model ran (Clark and West's adjustment, compareHeldOut).
  std::vector<double> cycle_adjustment;
  const std::vector<float>* adjusted_against = nullptr;
};

/// The squared free-run errors over grid samples [begin, end), the model run free from `begin` (anchored
/// there: the stretch's error is its own, not carried over from before it).
/// `reference` (indexed by grid sample, may be null): another model's free run, whose square differences from
/// this one are summed where both run. `predictions` (by grid sample, may be null): receives this run.
struct SquaredErrors {
  double sum = 0.0;  ///< [Pa^2]
  std::size_t samples = 0;
  double difference_sum = 0.0;  ///< [Pa^2] to `reference`
  std::size_t differences = 0;
};
SquaredErrors freeRunSquaredErrors(const std::vector<GridSample>& grid, std::size_t begin, std::size_t end,
                                   const HydraulicModel& model, const ParameterVector& theta,
                                   double min_pressure, const std::vector<float>* reference = nullptr,
                                   std::vector<float>* predictions = nullptr);

/// `side_by_side`: the two folds on two threads (the ranking's candidates are fewer than the cores' work
/// items otherwise); the result is the same. `fitted_on_both`, when given, receives the fit on both folds'
/// cycles combined from the two folds' fits (HydraulicIdentifier::combinedEstimate) rather than fitted again.
/// `base`, when given with its predictions kept: the base these errors will be compared with, whose free
/// runs the adjustment is accumulated against.
HeldOutErrors heldOutErrors(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                            const IdentificationConfig& config, int split, bool side_by_side = false,
                            HydraulicEstimate* fitted_on_both = nullptr, const HeldOutErrors* base = nullptr);

/// The same, base of the comparisons to come, with its free runs kept (`predictions`) from the same pass: the
/// ranking's base ran them a second time for keepPredictions (a whole free run of the recording).
HeldOutErrors heldOutErrorsKept(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                const IdentificationConfig& config, int split, bool side_by_side = false);

/// The same with a model of each fold's own: `fold_configs[0]` fitted on cycles [0, split) and run free on
/// the rest, `fold_configs[1]` the other way round. For an extension chosen on each fold's training cycles
/// only (a formula's breakpoint), so that the cycles it is tested on never took part in choosing it.
HeldOutErrors heldOutErrors(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                            const std::array<IdentificationConfig, 2>& fold_configs, int split,
                            bool side_by_side = false, const HeldOutErrors* base = nullptr);

/// The held-out free runs of `errors`' folds again, at every grid sample (NaN where none runs).
std::vector<float> heldOutPredictions(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                      const HeldOutErrors& errors);
/// Keeps `errors`' predictions (once), for the extensions compared with it.
void keepPredictions(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                     HeldOutErrors* errors);

/// A model against its base on the same held-out cycles: the cycles are the units of a paired
/// one-sided t test (a stroke holds thousands of strongly correlated samples, so a per-sample test would call
/// every extension significant) on Clark and West's adjusted difference of the nested models' mean square
/// errors, relative to the base's in each cycle:
///   d_c = (MSE_base - MSE_with + mean (p_base - p_with)^2) / MSE_base = 2 mean(e_base (p_with - p_base)) /
///   MSE_base,
/// whether the extension's correction points along the base's error. An extension whose parameter is in
/// truth zero still moves the prediction by its fitting noise and so raises the held-out error: the plain
/// comparison's size was 1 % at a nominal 5 %; the adjustment takes that noise out. The t statistic's
/// variance counts the fit a fold's held-out cycles share as much as the two folds show it (a one-way
/// random-effects model: the larger of the within- and between-fold variance for equal folds; Nadeau and
/// Bengio's bound where one fold alone is held out). Size over 1600 clean tests, 400 per press class: 4.0
/// and 4.4 % at 5 %, every class within Bin(200, 0.05)'s 4-16 (doc/model_adequacy.md).
struct HeldOutComparison {
  double error_reduction = 0.0;  ///< 1 - rms(with) / rms(base)
  double base_rms = 0.0;         ///< [Pa] the base model's held-out error
  double with_rms = 0.0;         ///< [Pa] the extended model's
  double t_statistic = 0.0;      ///< < 0: the extended model is better
  int cycles = 0;                ///< cycles paired (by cycle id)
  /// t below the exact one-sided Student quantile at `significance` (and at least two cycles).
  bool significant = false;
  double p_value = 1.0;  ///< one-sided, P(T <= t) with cycles - 1 degrees of freedom
};

/// Holm's step-down correction: which of m one-sided tests are significant at family-wise level
/// `significance` (the i-th smallest p-value against significance / (m - i)).
std::vector<bool> holmRejected(const std::vector<double>& p_values, double significance);

/// `grid` and `strokes`: those both were run on; the adjustment is `with`'s own where it was accumulated
/// against `base`'s kept predictions, else both models are run again for it.
HeldOutComparison compareHeldOut(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                 const HeldOutErrors& base, const HeldOutErrors& with, double significance);

/// Fits `config`'s model to the grid samples of cycles [first_cycle, last_cycle] (all: INT_MIN, INT_MAX)
/// without forgetting and returns the estimate. Models with valve-shape effects take a second pass,
/// linearised at the first pass's estimate.
HydraulicEstimate fitOnCycles(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                              const IdentificationConfig& config, int first_cycle, int last_cycle);

/// Replaces the standard deviations of `estimate` (a fit on the whole recording) by a delete-a-group
/// jackknife over press cycles: the cycles split into `groups` contiguous groups (at most one per cycle),
/// the model refitted without each, se^2 = (G-1)/G sum_g (theta_(g) - mean)^2. Cycles are the independent
/// units, so the correlation of the errors within a stroke and the error of the model itself are in it.
/// It is one part of the reported stds (combineUncertainty). False, and nothing changed, with fewer than 4
/// cycles or a refit that fails. The refits on up to `jobs` threads (0: one per core).
bool applyCycleJackknife(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                         const IdentificationConfig& config, HydraulicEstimate* estimate, int groups = 10,
                         int jobs = 1);

}  // namespace die_cushion_ident
