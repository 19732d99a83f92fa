#pragma once

#include <string>
#include <vector>

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
  std::string message;
};

/// Minimises the free run's error over the parameters (Ceres, from the equation-error estimate `start`),
/// on the first `max_samples` of the grid. Why: the equation-error fit sees the volume balance through
/// filter windows of tens of ms; a release or an impact shorter than them contributes little to it, and
/// the dead volume, which sets how fast a small chamber decompresses, is then pinned only to +-20-40 % on a
/// fast press, leaving twice the noise in its free run. Kept (`improved`) only where the refined free run
/// is within 2.5 times the pressure noise: a larger error is the model's, not the fit's. `start_std` (the
/// equation-error stds) scales the search; `with_stds` computes the refined stds (a Jacobian more).
OutputErrorFit refineByOutputError(const std::vector<GridSample>& grid, const HydraulicModel& model,
                                   const ParameterVector& start, const ParameterVector& start_std,
                                   double min_pressure, bool with_stds = true, std::size_t max_samples = 20000);

}  // namespace die_cushion_ident
