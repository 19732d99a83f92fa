#include "resolution_study.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <limits>

#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/adequacy/implausible_parameters.h"
#include "die_cushion_ident/core/signal/message_noise.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "die_cushion_ident/core/valve/step_response.h"
#include "rate_study.h"

namespace die_cushion_ident::settings_detail {

namespace {

// The free run converges where its own numerical error is below this share of its change as the period
// halves, and that change falls by at least this ratio from one halving to the next.
constexpr double kConvergingShare = 0.2;
constexpr double kConvergingRatio = 1.3;

// The offset's refinement is kept up to this multiple of the noise: the survey's free run, over its first
// ten seconds and on the equation-error fit's start, came to 2.6 times the noise on a clean fast press whose
// offset was right. A model that lacks an effect leaves more (and the shift is bounded to three of the
// integral-form estimate's stds).
constexpr double kDelayKeptUpToNoise = 4.0;

// The free run's offset estimate is uncertain by at least this [s]: its sandwich std (1-5 us) is blind to
// the model's own timing (the valve's dead time); over the press matrix's late-stamp
// recordings with the right model it came up to 0.19 ms off (8 cycles), most within 0.06 ms.
constexpr double kFreeRunOffsetFloor = 1e-4;
// Grid samples the offset is refined on (from the survey's start): 6 s at 1 ms. 12 000 instead of 20 000
// (then without the sandwich std, which since 2026-11-28 says whether the common offset is pinned) took the
// settings from 0.42-0.76 s to 0.34-0.45 s with no offset of 24 late-stamp recordings moved by more than
// 0.007 ms; 6000 took the refinement from 0.05-0.12 s to 0.026-0.07 s, and over 60 late-stamp recordings (4
// classes x 3 plants x clean and 4 effects, position 10 ms and valve 5 ms late) no offset moved by more than
// 0.01 ms (all within 0.19 ms of the truth, as before). 4000 (tried 2026-11-26 for the settings' cost) moved
// those offsets by at most 0.013 ms, but a clean small stiff press with its position at 500 Hz, which the
// free run is most sensitive to, then ran 1.89 times the noise (1.54 with 6000): not taken.
constexpr std::size_t kDelaySamples = 6000;
// [Pa] the refinement's free-run tolerance; the analysis's own refinement keeps 1 Pa. 5 Pa took a third off
// the refinement's time and moved the refined offsets by 0.03 us at most (four classes' 8-cycle recordings).
constexpr double kDelayTolerance = 5.0;

// The position topic's clock offset refined by the free run. On a fast press the free run is so sensitive to
// it that the integral-form estimate's 0.08 ms (within its stated 0.07 ms) left 6 times the noise and a dead
// volume 54 % off; the output error, fitted jointly with the parameters, resolves it about ten times finer
// (a large soft chamber's 0.32 ms off came to 0.07 ms). Where kept it replaces the integral form's estimate,
// which bounds it (within three of its stds). Tried only where the offsets were estimated and the
// model's free run comes near the noise (refineByOutputError keeps nothing else: a model that lacks an
// effect would bend the offset to hide it). The refinement where the offset moved.
std::optional<OutputErrorFit> refinePositionDelay(const HydraulicModel& model, const HydraulicEstimate& fit,
                                                  const std::vector<GridSample>& grid, double period,
                                                  bool inputs_measured, int jobs, SettingsChoice& choice) {
  if (!choice.delays || !choice.delays->valid) return std::nullopt;
  constexpr int kPosition = static_cast<int>(InputStream::kPosition);
  constexpr int kValve = static_cast<int>(InputStream::kValve);
  const double prior = choice.delays->resolution[kPosition];
  // Where the offsets were applied, their common part against the pressure is known to the larger of the two
  // offsets' resolutions, at least 0.1 ms (the refinement's search unit): the parameters' part clock_offsets,
  // unless the free run pins it below.
  const double common = std::max({choice.delays->resolution[kValve], prior, 1e-4});
  if (choice.delays_applied) choice.config.common_delay_std = choice.delays->common_std = common;
  if (fit.updates == 0 || !fit.values().allFinite() || !(prior > 0.0)) return std::nullopt;
  OutputErrorOptions options;
  options.position_shift_scale = std::max(prior, 1e-4);
  // Where the offsets were applied, their common part against the pressure is an unknown too: the integral
  // form pins the position's and the valve's relative offset (within 15 us on simulated presses of every
  // class) but not their common one, 30-460 us off, which left a fast press's bulk modulus 0.4 % and a large
  // soft press's dead volume 0.6 % lower than with the offsets known, and no part of the stds carried it.
  // Where they were not applied (none told from 0) the topics agree, and the common part stays 0. Only where
  // the free run's inputs are measured as often as the pressure: a position slower than the pressure or a
  // spool the configured valve model predicts has a timing of its own, which the common shift would take up
  // (a fast press with its position at 500 Hz and no velocity: 190 us off, with a std of 7 us). A velocity
  // derived from the position had one too while the free run read it; it reads the position's own slope now
  // (FreeRunPressure): on fast presses without a velocity and with late stamps the shift is pinned and the
  // bulk modulus's median error fell from 0.85 to 0.31 % (120 recordings).
  if (choice.delays_applied && inputs_measured) options.pressure_shift_scale = common;
  options.kept_up_to_noise = kDelayKeptUpToNoise;
  // Its resolution as a clock offset is the floor (the model's timing moves it as much). The sandwich (a
  // Jacobian of 2 (k + 2) free runs more) is computed only where it decides whether the free run pinned the
  // common offset: every survey refines the position's, the live node's too.
  options.with_stds = options.pressure_shift_scale > 0.0;
  options.max_samples = kDelaySamples;
  options.tolerance = kDelayTolerance;
  options.jobs = jobs;
  // At a period between the pressure's messages the grid's own second differences see interpolations.
  const double pressure_interval = choice.survey.message_interval[static_cast<int>(InputStream::kPressure)];
  if (gridBetweenMessages(period, pressure_interval)) options.pressure_noise = choice.survey.pressure_noise;
  OutputErrorFit refined = refineByOutputError(grid, model, fit.values(), fit.standardDeviations(),
                                               choice.config.min_pressure, options);
  // The pressure read later is every other topic read earlier: the pressure stays the reference. The common
  // shift is taken only where the free run pins it, its std within a tenth of the prior. A fast press's
  // impact does (its std 1-9 us of a 130-420 us prior, the offsets then within 30 us, not 30-480); on the
  // slower classes the shift trades with the capacitance and went as far as its bounds, and the integral
  // form's common offset is kept: the position's shift and the parameters refined again without it, as
  // before.
  const bool tried = options.pressure_shift_scale > 0.0 && refined.improved;
  const bool pinned = tried && std::isfinite(refined.pressure_shift_std) &&
                      refined.pressure_shift_std <= 0.1 * options.pressure_shift_scale;
  choice.pressure_delay_prior = options.pressure_shift_scale;
  choice.pressure_delay_std = refined.pressure_shift_std;
  if (pinned) {
    choice.config.common_delay_std = choice.delays->common_std = refined.pressure_shift_std;
  } else if (options.pressure_shift_scale > 0.0) {
    options.pressure_shift_scale = 0.0;
    options.with_stds = false;
    refined = refineByOutputError(grid, model, fit.values(), fit.standardDeviations(),
                                  choice.config.min_pressure, options);
  }
  if (!refined.improved) return std::nullopt;
  const double shift = refined.position_shift - refined.pressure_shift;
  choice.position_delay_shift = shift;
  choice.pressure_delay_shift = refined.pressure_shift;
  choice.config.topic_delays[kPosition] += shift;
  choice.config.topic_delays[kValve] -= refined.pressure_shift;
  choice.position_delay_std = refined.position_shift_std;
  choice.delays->delays[kPosition] += shift;
  choice.delays->delays[kValve] -= refined.pressure_shift;
  choice.delays->resolution[kPosition] = kFreeRunOffsetFloor;
  choice.delays->message +=
      formatted(FMT_STRING("; the position's offset refined by the free run by {:+.3f} ms (+-{:.2f} ms)"),
                1e3 * shift, 1e3 * kFreeRunOffsetFloor);
  if (refined.pressure_shift != 0.0)
    choice.delays->message +=
        formatted(FMT_STRING(", the valve's by {:+.3f} ms (the topics' common offset against the pressure)"),
                  -1e3 * refined.pressure_shift);
  if (choice.delays->distinguishable()) choice.delays_applied = true;
  return refined;
}

}  // namespace

FinestFit identifyAndRefineOffset(const Messages& messages, double period, const HydraulicModel& model,
                                  int jobs, SettingsChoice& choice) {
  FinestFit finest;
  finest.level = levelAt(atPeriod(choice.config, period, 0.0), messages);
  finest.shortest_drawing = shortestDrawing(finest.level);
  finest.fit = fitOnCycles(finest.level.grid, finest.level.strokes,
                           atPeriod(choice.config, period, finest.shortest_drawing), INT_MIN, INT_MAX);
  const auto refining = std::chrono::steady_clock::now();
  const auto& interval = choice.survey.message_interval;
  // (A valve model the user configured to drive the free run has the user's timing, not the spool's; one
  // fitted to the operation follows the measured spool.)
  const bool user_valve_drives = choice.config.valve_model_drives_free_run && !choice.valve_from_operation;
  const bool inputs_measured = choice.survey.spool_measured && !user_valve_drives &&
                               interval[static_cast<int>(InputStream::kPosition)] <=
                                   1.01 * interval[static_cast<int>(InputStream::kPressure)];
  finest.refined =
      refinePositionDelay(model, finest.fit, finest.level.grid, period, inputs_measured, jobs, choice);
  choice.seconds_spent_on.clock_offsets += secondsSince(refining);
  return finest;
}

// Identifies the model at the finest period and refines the position's offset by the free run there. A
// configured model that lacks an effect the press has can fit to nonsense (a negative bulk modulus where the
// tank pressure is missing on a fast press); its free run then says nothing about the grid, and a resolution
// error read from it would hide the missing effect. Such a fit is not studied: the finest period the
// recording supports is taken, and no resolution error is claimed.
void ResolutionStudy::identifyAtTheFinestPeriod(StudyOutcome& outcome) {
  FinestFit finest_fit = identifyAndRefineOffset(messages_, periods_.back(), model_, jobs_, choice_);
  levels_.back() = std::move(finest_fit.level);
  shortest_drawing_ = finest_fit.shortest_drawing;
  choice_.survey.cycles = levels_.back().strokes.cycles;
  choice_.survey.shortest_drawing = shortest_drawing_;
  fit_ = std::move(finest_fit.fit);
  // Where the position's offset was refined by the free run: the finest level's grid read with it, and the
  // refined parameters (fitted with it) studied. Where the common offset moved too, the level is read again
  // with the new offsets, as every coarser level will be: shifted in place it would read the pressure
  // delta later than they do, and the change from one to the next would hold dp/dt delta.
  const std::optional<OutputErrorFit>& refined = finest_fit.refined;
  if (refined && refined->pressure_shift != 0.0) {
    levels_.back() = levelAt(atPeriod(choice_.config, periods_.back(), 0.0), messages_);
  } else if (refined) {
    Level& finest = levels_.back();
    finest.grid = positionShifted(finest.grid, finest.grid.size(), refined->position_shift);
    finest.strokes = segmentStrokes(finest.grid);
  }
  std::vector<std::string> uncertain;
  const std::vector<std::string> implausible =
      fit_.updates > 0 ? implausibleParameters(model_, fit_, 3.0, &uncertain) : std::vector<std::string>();
  if (!implausible.empty()) outcome.implausible = implausible.front();
  outcome.studied = fit_.updates > 0 && fit_.values().allFinite() && implausible.empty();
  // A step test or sweep at rest cannot tell the bulk modulus from the dead volume: its fit says nothing of
  // the model (K' = -1.4e10 on a step test), and the survey is not studied. It is said as what it is, not as
  // an implausible press; its period is chosen as before (a live node surveying an idle press keeps the
  // finest, which a fast press needs once it strokes), unless a step test sets it (chooseForTheStepTest).
  const Level& finest = levels_.back();
  outcome.no_press_stroke = !outcome.studied && holdsNoPressStroke(finest.grid, finest.strokes,
                                                                   choice_.config.geometry.stroke_length);
  theta_ = !outcome.studied ? ParameterVector() : refined ? refined->theta : fit_.values();
}

// A survey at rest that holds a valve step test: the pressure's t63, timed on the finest grid, sets the
// period (at most a tenth of it, the paper's rule, as step_response's recommended_max_sampling_time): the
// coarsest studied period within it, else the finest. A fast press's 19 ms t63 on the paper's 2 ms was
// "sampling too coarse"; a slow press's 108 ms keeps 2 ms.
void ResolutionStudy::chooseForTheStepTest(StudyOutcome& outcome) {
  const std::vector<StepResponse> steps = findStepResponses(levels_.back().grid);
  if (steps.empty()) return;
  outcome.step_t63 = steps.front().t63;
  const double most = steps.front().recommendedMaxSamplingTime();
  outcome.chosen_period = periods_.back();
  for (double period : periods_) {
    if (period <= most) {
      outcome.chosen_period = period;
      break;
    }
  }
}

// From 2 ms down, halving, until the free run stops changing or the recording's rate is reached; the
// index of the period chosen.
std::size_t ResolutionStudy::halveUntilSettled(double allowed_change, bool* resolved) {
  for (std::size_t k = 0; k + 1 < periods_.size(); ++k) {
    prepareLevels(k);
    ResolutionCandidate& c = choice_.study.emplace_back();
    c.sample_period = periods_[k];
    c.simulation_error_rms = level(k).error_rms;
    c.change_to_finer = changeBetween(level(k), level(k + 1), periods_[k + 1]);
    if (std::isfinite(c.change_to_finer) && c.change_to_finer <= allowed_change) {
      *resolved = true;
      return k;
    }
  }
  ResolutionCandidate& c = choice_.study.emplace_back();
  c.sample_period = periods_.back();
  c.simulation_error_rms = level(periods_.size() - 1).error_rms;
  return periods_.size() - 1;
}

// The finest period the recording supports still changed, or nothing finer than 2 ms was possible: its own
// error by Richardson's estimate from coarser periods, change / (2^q - 1), the order q from the last two
// halvings (4 and 8 ms run for them where the study had fewer), between 1 and 4.
void ResolutionStudy::judgeTheFinestPeriod(std::size_t chosen, double allowed_change, double noise,
                                           double finest_interval, bool* resolved) {
  std::vector<double> changes;  // coarsest first, ending with the change into the chosen period
  for (const ResolutionCandidate& c : choice_.study) {
    if (std::isfinite(c.change_to_finer)) changes.push_back(c.change_to_finer);
  }
  Level finer = level(0);
  // The coarser levels and the chosen level's numerical error side by side (the second on its own model).
  const HydraulicModel own(model_);
  Level& at_chosen = level(chosen);
  double numerical = std::numeric_limits<double>::quiet_NaN();
  parallelFor(2, jobs_, [&](std::size_t task) {
    if (task == 1) {
      numerical = numericalError(own, theta_, choice_.config.min_pressure, &at_chosen);
      return;
    }
    for (double coarse_period = 2.0 * kCoarsestPeriod; changes.size() < 2; coarse_period *= 2.0) {
      Level coarse = levelAt(atPeriod(choice_.config, coarse_period, shortest_drawing_), messages_);
      runFree(model_, theta_, choice_.config.min_pressure, &coarse);
      changes.insert(changes.begin(), changeBetween(coarse, finer, finer.period));
      finer = std::move(coarse);
    }
  });
  const double last_change = changes.back(), earlier_change = changes[changes.size() - 2];
  const Richardson estimate = richardson(last_change, earlier_change);
  choice_.resolution_error = estimate.error;
  // A free run that moves with its own tolerance as much as with the period, or whose change does not fall
  // as the period halves, does not converge: that is the configured model failing (a fast press without
  // its tank pressure ran 51 bar off, 10 bar from its own tolerance), not the grid. No resolution error is
  // claimed, or it would excuse the missing effect ("resolution-limited: record at 462600 Hz").
  const bool converging = !(numerical > kConvergingShare * last_change) &&
                          !(std::isfinite(earlier_change) && earlier_change < kConvergingRatio * last_change);
  const double chosen_period = periods_[chosen];
  if (!converging) {
    choice_.resolution_error = std::numeric_limits<double>::quiet_NaN();
    choice_.resolution_not_converging = true;
  } else if (choice_.resolution_error > allowed_change) {
    // The period at which the error would fall to the allowed share, at the same order.
    choice_.resolution_remedy =
        formatted(FMT_STRING("record pressure, position and valve at {:.0f} Hz or more"),
                  recordingRate(estimate.stepFor(allowed_change, chosen_period)));
    choice_.resolution_limit =
        formatted(FMT_STRING("resolution-limited: at the finest sample period the recording supports ({:.3g} "
                             "ms; its fastest "
                             "topic comes every {:.3g} ms) the free run's own error is about {:.2g} bar "
                             "(pressure noise {:.2g} "
                             "bar); "),
                  1e3 * chosen_period, 1e3 * finest_interval, 1e-5 * choice_.resolution_error, 1e-5 * noise) +
        choice_.resolution_remedy;
  } else {
    *resolved = true;
  }
}

StudyOutcome ResolutionStudy::run(double allowed_change, double noise, double finest_interval,
                                  double configured_period) {
  StudyOutcome outcome;
  identifyAtTheFinestPeriod(outcome);
  outcome.shortest_drawing = shortest_drawing_;
  if (!outcome.studied) {
    outcome.chosen_period = outcome.implausible.empty() ? configured_period : periods_.back();
    choice_.resolution_error = std::numeric_limits<double>::quiet_NaN();
    if (outcome.no_press_stroke) chooseForTheStepTest(outcome);
    return outcome;
  }
  const std::size_t chosen = halveUntilSettled(allowed_change, &outcome.resolved);
  for (ResolutionCandidate& c : choice_.study)
    c.bulk_modulus = fit_.parameters[HydraulicModel::kBulkModulus].value;
  outcome.chosen_period = periods_[chosen];
  if (outcome.resolved) {
    choice_.resolution_error = choice_.study[chosen].change_to_finer;
  } else {
    judgeTheFinestPeriod(chosen, allowed_change, noise, finest_interval, &outcome.resolved);
  }
  choice_.numerical_error = numericalError(model_, theta_, choice_.config.min_pressure, &level(chosen));
  outcome.grid_error = choice_.resolution_error;
  const IdentificationConfig at_chosen = atPeriod(choice_.config, outcome.chosen_period, shortest_drawing_);
  // Richardson's extrapolation of the position's rate needs a free run that converges; the valve's rate is a
  // difference of two free runs, measured, not extrapolated (a fast press with its valve at 250 Hz, whose
  // free run ran 46 times the noise, did not converge as the period halved and was told "structured").
  if (!choice_.resolution_not_converging) {
    studyPositionRate(messages_, at_chosen, model_, theta_, level(chosen), allowed_change, noise, choice_);
  }
  studyValveRate(messages_, at_chosen, model_, theta_, level(chosen), allowed_change, noise, jobs_, choice_);
  return outcome;
}

}  // namespace die_cushion_ident::settings_detail
