#pragma once

#include <complex>
#include <string>
#include <vector>

#include "die_cushion_ident/core/frequency_response.h"
#include "die_cushion_ident/core/servo_valve.h"

namespace die_cushion_ident {

/// The servo valve's 2nd-order model with dead time fitted to a measured frequency response.
struct ServoValveFit {
  bool success = false;
  std::string message;              ///< why the fit failed, or a summary
  ServoValveParameters parameters;  ///< natural_frequency [Hz], damping [-], gain [1/V], dead_time [s]
  double natural_frequency_std = 0.0, damping_std = 0.0, gain_std = 0.0, dead_time_std = 0.0;
  double magnitude_residual_rms = 0.0;  ///< [1/V]
  double phase_residual_rms = 0.0;      ///< [rad]
  /// Weighted squared magnitude residuals per degree of freedom; ~1 when the model explains the points
  /// to within their measured noise, >> 1 when it does not (the stds are scaled up by its root then).
  double reduced_chi_square = 0.0;
  int points_used = 0;
  int points_rejected = 0;  ///< distorted points left out
};

/// G(jw) = K exp(-jw T_dead) / (1 - (f/f0)^2 + 2jD f/f0) at frequency [Hz].
std::complex<double> servoValveResponse(const ServoValveParameters& parameters, double frequency);

/// Fits natural frequency, damping and gain to the magnitudes by weighted nonlinear least squares (Ceres,
/// bounded, started from a grid search), then the dead time to the phase left after the 2nd-order phase.
/// Uncertainties come from the fit's covariance, scaled by the residual when it exceeds the noise, and for
/// the dead time include the propagated uncertainty of natural frequency and damping.
ServoValveFit fitServoValve(std::vector<FrequencyResponsePoint> points);

}  // namespace die_cushion_ident
