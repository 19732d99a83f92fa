#pragma once

#include <limits>
#include <map>
#include <string>
#include <vector>

#include "die_cushion_ident/core/fits/input_perturbation.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"

namespace die_cushion_ident {

/// The identified parameters refined so that the model's free run, not its one-step equation, fits the
/// measured pressure.
struct OutputErrorFit {
  bool improved = false;       ///< the refinement lowered the free-run error (else `theta` is the start)
  ParameterVector theta;       ///< physical parameters, model order
  ParameterVector std;         ///< their standard deviations (sandwich, cluster-robust over 8 blocks)
  double start_rms = 0.0;      ///< [Pa] free-run error of the start
  double rms = 0.0;            ///< [Pa] free-run error of `theta`
  double noise = 0.0;          ///< [Pa] the pressure's white noise on the fitted samples
  int samples = 0;             ///< grid samples fitted
  /// [s] how much later the position is read where its shift was an unknown (position_shift_scale > 0):
  /// add it to the position topic's delay.
  double position_shift = 0.0;
  /// [s] its standard uncertainty, with the parameters (and the pressure's shift) as the other unknowns (the
  /// cluster-robust sandwich over all); NaN where the shift was no unknown or the stds were not computed.
  double position_shift_std = std::numeric_limits<double>::quiet_NaN();
  /// [s] how much later the pressure is read where its shift was an unknown too (pressure_shift_scale > 0):
  /// every other topic's delay less it. Its std likewise.
  double pressure_shift = 0.0;
  double pressure_shift_std = std::numeric_limits<double>::quiet_NaN();
  /// Per reconstructed input (OutputErrorOptions::inputs, by InputPerturbation::input), the parameters'
  /// standard uncertainty from that input's: the root sum of squares of (J'J)^-1 J' dr over its
  /// perturbations, dr the free run's change at `theta` (the refit's change to first order). Computed with
  /// the stds.
  std::map<std::string, ParameterVector> input_std;
  std::string message;
};

/// The first n samples of the grid with the position and velocity read `shift` [s] later (Catmull-Rom
/// between the grid samples, the free run's own interpolation): the position topic's stamps corrected by
/// `shift` more, for shifts within a few samples.
std::vector<GridSample> positionShifted(const std::vector<GridSample>& grid, std::size_t n, double shift);

/// The first n samples with the position read `position_shift` [s] later and the pressure `pressure_shift`
/// later (the same interpolation): the pressure's shift is the other topics' delays' less it.
std::vector<GridSample> timingShifted(const std::vector<GridSample>& grid, std::size_t n,
                                      double position_shift, double pressure_shift);

/// How refineByOutputError searches and what it keeps.
struct OutputErrorOptions {
  bool with_stds = true;             ///< compute the refined stds (a Jacobian more)
  std::size_t max_samples = 20000;   ///< grid samples fitted, from the first
  /// The refinement is kept only where its free run is within this multiple of the pressure noise: a larger
  /// error is the model's, not the fit's.
  double kept_up_to_noise = 2.5;
  /// [s] > 0: the position's time shift is an unknown too, searched within three of this unit. On a fast
  /// press the free run resolves a clock offset ten times finer than the integral-form delay estimate, whose
  /// 0.08 ms left 6 times the noise (doc/resolution.md).
  double position_shift_scale = 0.0;
  /// [s] > 0 (with position_shift_scale): the pressure's time shift against all the other topics is an
  /// unknown too, searched within three of this unit. Where the clock offsets were estimated and applied,
  /// their common part against the pressure was 30-460 us off on simulated presses (the position's and the
  /// valve's relative offset within 15 us), which the position's shift alone cannot take up.
  double pressure_shift_scale = 0.0;
  /// Threads for the Jacobian's columns (0: one per core). 1 where the caller runs fits side by side.
  int jobs = 1;
  /// [Pa] the pressure noise the free run is judged by (IdentificationConfig::grid_pressure_noise); 0: estimated
  /// on the grid.
  double pressure_noise = 0.0;
  /// [Pa] the free runs' error tolerance. The step-size control's decisions change discontinuously with the
  /// parameters; a tight tolerance keeps that roughness far below the differences the numeric derivatives
  /// take.
  double tolerance = 1.0;
  /// Ceres' relative tolerance on the cost: an iteration that lowers it by less ends the fit. 0: 0.1 / n over
  /// n fitted samples, i.e. a step that gains less than a twentieth of the noise's variance (the cost is
  /// about n sigma^2 / 2 near the optimum). The fixed thousandth used before ended fits up to 24 of their
  /// stds from their optimum where the cost is the noise's (a large soft press, 11 648 samples: Ceres stopped
  /// after 2 iterations, the bulk modulus 0.73 % off with a std of 0.03 %). The held-out folds keep the
  /// thousandth: far below what a held-out test resolves, and a sixth of the analysis.
  double function_tolerance = 0.0;
  /// The reconstructed inputs' uncertainties (the valve model's spool, a derived velocity) to carry into the
  /// parameters (OutputErrorFit::input_std); read only with the stds.
  std::vector<InputPerturbation> inputs;
};

/// Minimises the free run's error over the parameters (Ceres, from the equation-error estimate `start`),
/// on the first `max_samples` of the grid. Why: the equation-error fit sees the volume balance through
/// filter windows of tens of ms; a release or an impact shorter than them contributes little to it, and
/// the dead volume, which sets how fast a small chamber decompresses, is then pinned only to +-20-40 % on a
/// fast press, leaving twice the noise in its free run. `start_std` (the equation-error stds) scales the
/// search.
OutputErrorFit refineByOutputError(const std::vector<GridSample>& grid, const HydraulicModel& model,
                                   const ParameterVector& start, const ParameterVector& start_std,
                                   double min_pressure, const OutputErrorOptions& options = OutputErrorOptions());

}  // namespace die_cushion_ident
