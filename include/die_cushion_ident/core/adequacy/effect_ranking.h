#pragma once

#include <limits>
#include <string>
#include <vector>

#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/adequacy/model_assessment.h"
#include "die_cushion_ident/core/adequacy/verdict.h"
#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"
#include "die_cushion_ident/core/estimation/identification_config.h"

namespace die_cushion_ident {

/// How much one inactive effect of the library explains of the remaining error, judged on held-out cycles.
struct CandidateEffect {
  std::string effect;
  /// 1 - (held-out free-run error with the effect) / (without): 0.62 = 62 % less error. Negative when the
  /// extended model does worse on cycles it was not fitted to.
  double error_reduction = 0.0;
  Verdict verdict = Verdict::kInconclusive;
  std::string explanation;                      ///< one line: the physics, and why the verdict
  std::vector<IdentifiedParameter> parameters;  ///< the effect's parameters, fitted on all the data
  int held_out_cycles = 0;
  double t_statistic = 0.0;  ///< paired t of log(per-cycle error ratio) across held-out cycles (< 0: better)
  double p_value = 1.0;      ///< its one-sided p; `missing` needs it significant after Holm's correction
};

/// A formula for error that no library effect explains, proven on held-out cycles like a library candidate.
struct FormulaProposal {
  std::string name;        ///< custom effect name, e.g. "relief"
  std::string expression;  ///< e.g. "max(p-1.21e7,0)"; name=expression is ready for --custom-effect
  std::string spec() const { return name + "=" + expression; }
  char signal = 'p';       ///< the signal whose threshold or shape the term describes
  bool compliance = false;  ///< a compliance (dp * c) rather than a flow
  double breakpoint = std::numeric_limits<double>::quiet_NaN();  ///< in the signal's SI unit; NaN: none
  double error_reduction = 0.0;  ///< held-out free-run error, relative to the model it extends
  double held_out_error_rms = 0.0;  ///< [Pa] with the term
  Verdict verdict = Verdict::kInconclusive;
  int held_out_cycles = 0;
  double t_statistic = 0.0;
  double p_value = 1.0;
  std::vector<IdentifiedParameter> parameters;  ///< NAME_theta in physical units, fitted on all the data
  std::string explanation;
  std::string together_with;  ///< a second term: the proposal it extends (proposed only with it)
  /// The residual against the chosen signal, for the report: bin centres [signal unit], the model's
  /// equation error [m^3/s] and the fitted term [m^3/s], each averaged over the bin.
  std::vector<double> bin_signal, bin_residual, bin_term;
  HeldOutErrors held_out;  ///< per held-out cycle, for the tests built on this proposal
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
  /// Formulas for the error the library leaves (proposeFormulas), most explanatory first; empty when
  /// nothing structured is left or the search did not run.
  std::vector<FormulaProposal> proposals;
  /// Held-out errors of the recommended model (the base of the formula search).
  HeldOutErrors recommended_held_out;
  std::vector<std::string> recommended_effects;  ///< the configured effects plus `steps`
  /// The error left by the best model is well above the noise: something the library does not describe.
  bool residual_unexplained = false;
  /// The error left is above the noise but within the analysis's own resolution error: no effect is named,
  /// the remedy is (EffectRankingOptions::resolution_remedy).
  bool resolution_limited = false;
  std::string conclusion;  ///< what to do, in one or two sentences
};

struct EffectRankingOptions {
  double missing_reduction = 0.2;      ///< at least this error reduction ...
  double significance = 0.05;          ///< ... consistent over held-out cycles at this one-sided level
  double not_needed_reduction = 0.05;  ///< below this the effect is not needed
  int min_held_out_cycles = 3;         ///< fewer: every verdict is inconclusive
  /// The best model's held-out error above this multiple of the noise (in quadrature with twice the
  /// resolution error, structuredErrorFloor) is "unexplained": a model's own free-run floor with the true
  /// law is 2-4 x the noise on simulated plants, the staircase's stop below.
  double unexplained_noise_factor = 4.0;
  /// At most this multiple of the noise, the model explains the measurement "to within the noise" (clean
  /// presses run free at 1.0-1.6 x it, doc/offline_analysis.md).
  double within_noise_factor = 2.0;
  /// After the first step, the staircase stops once the held-out error is below this multiple of the noise.
  double staircase_noise_factor = 4.0;
  /// Threads for the candidates' fits and free runs, which are independent (0: one per core).
  int jobs = 0;
  /// [Pa] the analysis's own error at its sample period (SettingsFromRecording: how far the free run moves
  /// when the period halves): an extension whose gain in mean square error is within twice it, or a
  /// structured residual of that size, is the product's resolution, not physics. 0: not known.
  double resolution_error = 0.0;
  /// What to do about it, in words ("record pressure, position and valve at 4 kHz or more").
  std::string resolution_remedy;
  /// Cycles [0, split) and [split, cycles) are the two folds.
  int split(int cycles) const { return cycles / 2; }
};

/// A verdict on an extension of a model and its reason, to follow the extension's physics ("; ...").
struct HeldOutVerdict {
  Verdict verdict = Verdict::kInconclusive;
  std::string reason;
};

/// The rule every extension (library effect, pair, formula) is judged by: a fit outside the physical range
/// (`implausible`: its reason, or empty) is not_needed; too few held-out cycles inconclusive; at least
/// missing_reduction less held-out error and significant missing, unless its gain in mean square error is
/// within twice the analysis's resolution error (then inconclusive, "resolution-limited"); below
/// not_needed_reduction not_needed; else inconclusive. `removes` words the missing reason ("it removes", "together they remove").
HeldOutVerdict judgeHeldOut(const HeldOutComparison& test, const std::string& implausible,
                            const EffectRankingOptions& options, const std::string& removes = "it removes");

/// Holm's correction over one round of `tried` extensions: empty when the missing verdict stands, else
/// the reason it becomes inconclusive.
std::string holmDemotion(double error_reduction, double p_value, bool rejected, std::size_t tried,
                         const std::string& what);

/// [Pa] The held-out error above which the error left is "structured": unexplained_noise_factor x the noise
/// in quadrature with twice the recording's resolution error (where known); no absolute bar.
double structuredErrorFloor(double noise_rms, const EffectRankingOptions& options);
/// The held-out error left [Pa] in words: its size against the noise, and whether it is within the noise,
/// within structuredErrorFloor (too little to search a formula for) or above it.
std::string errorLeftInWords(double error_rms, double noise_rms, const EffectRankingOptions& options);
/// Whether an error of `error_rms` [Pa] left above the noise is within twice the analysis's resolution error.
bool withinResolution(double error_rms, double noise_rms, const EffectRankingOptions& options);

/// Tries every library effect that `config` does not use as an extension of the model, and adds the
/// missing ones one at a time (EffectRankingResult::steps).
///
/// Verdicts rest on held-out cycles, not on the fit's own residual (a stroke holds thousands of strongly
/// correlated samples, so a per-sample test would call every effect significant): the recording is split
/// into its first and second half of press cycles; each model is fitted without forgetting on one half and
/// run free on the other, both ways. Per held-out cycle the free-run error of the extended model is
/// compared with the configured model's; cycles are the units of a paired one-sided t test on Clark and
/// West's adjusted error gain, its variance corrected for the fits a fold's cycles share (compareHeldOut).
EffectRankingResult rankEffects(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                const IdentificationConfig& config, const EffectRankingOptions& options = {});

}  // namespace die_cushion_ident
