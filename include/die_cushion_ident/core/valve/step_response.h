#pragma once

#include <vector>

#include "die_cushion_ident/core/signal/uniform_resampler.h"

namespace die_cushion_ident {

/// The chamber pressure's answer to a step of the valve command with the cushion at rest (paper, §5.2):
/// t63, the time from the step until the pressure has covered 63.2 % of its way to the final value, sets
/// the sampling time of the identification (at most 0.1 t63; the paper's press had t63 about 90 ms, servo
/// presses about 3 ms).
struct StepResponse {
  double start = 0.0;             ///< [s] stamp of the command step
  double step_voltage = 0.0;      ///< [V] the command's change
  double initial_pressure = 0.0;  ///< [Pa] before the step
  double final_pressure = 0.0;    ///< [Pa] settled after it
  double t63 = 0.0;               ///< [s]
  double recommendedMaxSamplingTime() const { return 0.1 * t63; }
};

struct StepResponseOptions {
  double min_step = 0.1;            ///< [V] smaller command changes are no step test
  double max_rest_velocity = 0.005;  ///< [m/s] the cushion counts as at rest below ...
  /// [s] ... in its velocity averaged over this window around each sample: a velocity derived from a noisy
  /// position over two fine grid periods scatters beyond max_rest_velocity at rest (a 1 ms grid, 4 um
  /// of position noise: ~3 mm/s), and one such sample broke the hold on the grid the survey chose.
  double rest_window = 0.02;
  double before = 0.1;              ///< [s] of steady command and pressure before the step
  double min_hold = 0.3;            ///< [s] the new command must hold at least this long
  double min_change = 2e5;          ///< [Pa] smaller pressure changes cannot be timed
  double settled_fraction = 0.2;    ///< the last part of the hold averaged for the final pressure
};

/// Finds command steps at rest in a recording's grid (the voltage jumps by at least min_step and holds,
/// the cushion does not move: its velocity averaged over rest_window within max_rest_velocity) and times the
/// pressure's answer, interpolating between grid samples. A response that has not settled by the end of the
/// hold (the last two tenths differ by more than 5 % of the change) is left out.
std::vector<StepResponse> findStepResponses(const std::vector<GridSample>& grid,
                                            const StepResponseOptions& options = {});

/// t63 [s] of a pressure trace (t, p) after a step at `start`, with the final value the mean of the last
/// `settled_fraction` of the trace; NaN when the trace never gets there.
double timeTo63Percent(const std::vector<double>& t, const std::vector<double>& p, double start,
                       double initial_pressure, double settled_fraction);

}  // namespace die_cushion_ident
