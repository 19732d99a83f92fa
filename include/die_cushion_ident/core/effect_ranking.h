#pragma once

#include <string>
#include <vector>

#include "die_cushion_ident/core/held_out_test.h"
#include "die_cushion_ident/core/hydraulic_identifier.h"
#include "die_cushion_ident/core/identification_config.h"
#include "die_cushion_ident/core/model_assessment.h"

namespace die_cushion_ident {

/// How much one inactive effect of the library explains of the remaining error, judged on held-out cycles.
struct CandidateEffect {
  std::string effect;
  /// 1 - (held-out free-run error with the effect) / (without): 0.62 = 62 % less error. Negative when the
  /// extended model does worse on cycles it was not fitted to.
  double error_reduction = 0.0;
  std::string verdict;                          ///< "missing", "not_needed" or "inconclusive"
  std::string explanation;                      ///< one line: the physics, and why the verdict
  std::vector<IdentifiedParameter> parameters;  ///< the effect's parameters, fitted on all the data
  int held_out_cycles = 0;
  double t_statistic = 0.0;  ///< paired t of log(per-cycle error ratio) across held-out cycles (< 0: better)
};

/// One verified addition of the staircase: the effect and the held-out error of the model with it.
struct EffectStep {
  std::string add;
  double held_out_error_rms = 0.0;  ///< [Pa]
  /// Set when the effect is missing only together with this earlier one (the two mask each other alone):
  /// the previous entry's error is then that effect's alone, and only this entry's error is verified.
  std::string together_with;
};

struct EffectRankingResult {
  double base_error_rms = 0.0;  ///< [Pa] held-out free-run error of the model as configured
  double best_error_rms = 0.0;  ///< [Pa] ... of the recommended model (the configured one plus `steps`)
  double noise_rms = 0.0;       ///< [Pa] pressure sensor noise estimated from the data
  /// Library effects added one at a time, each `missing` against the model with the ones before it; the
  /// last entry is the recommended model. Empty when nothing is missing.
  std::vector<EffectStep> steps;
  /// The effects of `steps` first, in their order (error_reduction: what each removed at its step); then
  /// every other library effect judged against the recommended model, most explanatory first.
  std::vector<CandidateEffect> candidates;
  /// The error left by the best model is well above the noise: something the library does not describe.
  bool residual_unexplained = false;
  std::string conclusion;  ///< what to do, in one or two sentences
};

struct EffectRankingOptions {
  double missing_reduction = 0.2;      ///< at least this error reduction ...
  double significance = 0.05;          ///< ... consistent over held-out cycles at this one-sided level
  double not_needed_reduction = 0.05;  ///< below this the effect is not needed
  int min_held_out_cycles = 3;         ///< fewer: every verdict is inconclusive
  /// The best model's held-out error above this multiple of the noise (and above 1 bar) is "unexplained".
  double unexplained_noise_factor = 6.0;
  /// Cycles [0, split) and [split, cycles) are the two folds.
  int split(int cycles) const { return cycles / 2; }
};

/// Tries every library effect that `config` does not use as an extension of the model, and adds the
/// missing ones one at a time (EffectRankingResult::steps).
///
/// Verdicts rest on held-out cycles, not on the fit's own residual (a stroke holds thousands of strongly
/// correlated samples, so a per-sample test would call every effect significant): the recording is split
/// into its first and second half of press cycles; each model is fitted without forgetting on one half and
/// run free on the other, both ways. Per held-out cycle the free-run error of the extended model is
/// compared with the configured model's; cycles are the independent units of a paired one-sided t test on
/// the log error ratio.
EffectRankingResult rankEffects(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                const IdentificationConfig& config, const EffectRankingOptions& options = {});

}  // namespace die_cushion_ident
