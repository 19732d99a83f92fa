#pragma once

#include <complex>
#include <string>
#include <vector>

#include "die_cushion_ident/core/valve/frequency_response.h"
#include "die_cushion_ident/core/valve/servo_valve.h"

namespace die_cushion_ident {

/// The servo valve's 2nd-order model with dead time fitted to a measured frequency response.
struct ServoValveFit {
  bool success = false;
  std::string message;              ///< why the fit failed, or a summary
  ServoValveParameters parameters;  ///< natural_frequency [Hz], damping [-], gain [1/V], dead_time [s]
  double natural_frequency_std = 0.0, damping_std = 0.0, gain_std = 0.0, dead_time_std = 0.0;
  double magnitude_residual_rms = 0.0;  ///< [1/V]
  double phase_residual_rms = 0.0;      ///< [rad]
  /// Weighted squared complex residuals per degree of freedom; ~1 when the model explains the points
  /// to within their measured noise, >> 1 when it does not (the stds are scaled up by its root then).
  double reduced_chi_square = 0.0;
  int points_used = 0;
  int points_rejected = 0;  ///< distorted points left out
};

/// G(jw) = K exp(-jw T_dead) / (1 - (f/f0)^2 + 2jD f/f0) at frequency [Hz].
std::complex<double> servoValveResponse(const ServoValveParameters& parameters, double frequency);

/// Fits natural frequency, damping, gain and dead time jointly to the complex points (Re/Im weighted by each
/// point's measured noise, Ceres, bounded), including the images of a held command (each point's
/// `command_hold`) that the sampled spool folds back. Started from a magnitude fit (grid search, then
/// Ceres) and the dead time fitted to the phase left after the 2nd-order phase. Uncertainties come from the
/// joint fit's covariance, scaled by the reduced chi-square when it exceeds 1.
ServoValveFit fitServoValve(std::vector<FrequencyResponsePoint> points);

}  // namespace die_cushion_ident
