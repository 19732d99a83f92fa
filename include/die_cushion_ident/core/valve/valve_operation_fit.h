#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "die_cushion_ident/core/valve/recorded_sweep.h"
#include "die_cushion_ident/core/valve/servo_valve.h"

namespace die_cushion_ident {

/// The servo valve's model (2nd order with dead time, shared/CONTRACT.md) fitted to the commands and the
/// measured spool of ordinary operation: the press's own controller moves the spool through impacts,
/// drawing and release, which excites it well enough to pin the model down without a sweep.
struct ValveOperationFit {
  bool success = false;
  std::string message;              ///< a summary, or why it failed
  ServoValveParameters parameters;  ///< natural_frequency [Hz], damping [-], gain [1/V], dead_time [s]
  double residual_rms = 0.0;        ///< [-] measured minus modelled spool
  double noise_sigma = 0.0;         ///< [-] the spool sensor's white noise (second differences)
  double start_residual_rms = 0.0;  ///< [-] the same with the starting (configured) model
  int samples = 0;
  /// The fitted parameters' covariance, in the order natural_frequency [Hz], damping [-], gain [1/V],
  /// dead_time [s]: s^2 (J'J)^-1 with J the spool's sensitivity to them at the fit (central differences)
  /// and s the spool's residual rms; zero where the fit did not succeed. What the valve model's error does
  /// to the hydraulic parameters through the free run it drives (OutputErrorOptions::inputs).
  Eigen::Matrix4d covariance = Eigen::Matrix4d::Zero();
};

/// Output-error fit (Ceres, bounded: 5-2000 Hz, damping 0.1-3, dead time 0-20 ms) of the model's spool,
/// run message by message on the held commands as ValveMessageSpool runs it, to the measured spool, from
/// `start` and from starts at half and twice its natural frequency. `samples` in time order; stretches
/// split at gaps longer than `max_gap`; the starts are searched on the first 3000 samples and the best
/// refined on all, at most `max_samples` of them (the first ones). Succeeds when the spool moved (its range
/// beyond 20 noise stds) and the fitted model explains it to within 3 times the sensor's noise. A sample
/// whose spool is NaN is a command the amplifier applied without a spool reading: it drives the model and
/// has no residual (the survey tries commands between the valve topic's messages this way). The
/// refinement on all samples evaluates its Jacobian on up to `jobs` threads (0: one per core); the result is
/// the same on any number.
constexpr std::size_t kValveOperationSamples = 15000;  ///< fitValveToOperation's default max_samples
ValveOperationFit fitValveToOperation(const std::vector<ValveSample>& samples,
                                      const ServoValveParameters& start, double max_gap = 0.02,
                                      std::size_t max_samples = kValveOperationSamples, int jobs = 1);

}  // namespace die_cushion_ident
