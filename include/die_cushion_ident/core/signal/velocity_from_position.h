#pragma once

#include <cstdint>
#include <deque>
#include <vector>

#include "die_cushion_ident/core/signal/uniform_resampler.h"

namespace die_cushion_ident {

/// Fills in the cushion velocity v = dx/dt on the uniform grid where the position topic carries none (a
/// linear encoder gives position only), so that the stroke phases, the cycles and the equation-error fit see
/// the same signal as with a measured velocity, and marks the sample (GridSample::velocity_derived): the free
/// run takes the position's own slope there instead (FreeRunPressure).
///
/// v_k is the least-squares slope of x over the centred window of 2K+1 grid samples (t_{k-K} ... t_{k+K}):
///   v_k = sum_j (t_j - tbar)(x_j - xbar) / sum_j (t_j - tbar)^2,
/// a symmetric FIR differentiator with no phase lag at the window's centre; its output is a parabolically
/// weighted mean of the true velocity over the window, so its integral over a stroke equals the stroke.
/// Position noise sigma_x gives sigma_v = sigma_x * sqrt(12 / (n (n^2 - 1))) / dt, n = 2K+1.
/// The whole sample (all channels) leaves the stage K samples (K * sample_period) later, so the derived
/// velocity lines up with pressure and valve; live this is the only latency it adds. Samples with a
/// measured velocity pass unchanged and, while nothing waits, undelayed. At a discontinuity, a gap or the
/// end of the data the window is one-sided (fewer samples).
class VelocityFromPosition {
 public:
  /// half_width K >= 1 [samples].
  explicit VelocityFromPosition(int half_width);

  /// Adds one grid sample; appends the samples that became ready (in order, K behind) to `out`.
  void push(const GridSample& sample, std::vector<GridSample>* out);
  /// Emits every sample still waiting (end of the data).
  void flush(std::vector<GridSample>* out);
  void reset();

  int delaySamples() const { return half_width_; }
  /// Samples whose velocity was derived here (since construction or reset).
  std::uint64_t derived() const { return derived_; }

 private:
  void emit(std::size_t index, std::vector<GridSample>* out);

  int half_width_;
  std::deque<GridSample> buffer_;  // up to K samples already emitted (left context), then those waiting
  std::size_t next_ = 0;           // index in buffer_ of the next sample to emit
  std::uint64_t derived_ = 0;
};

/// Causal velocity of raw position messages for safety checks that cannot wait for the grid (the valve
/// sweep's "cushion at rest"): the least-squares slope of the messages in the last `window` seconds.
/// Unlike a difference of two messages, position noise does not look like motion (2 um of noise at 1 kHz
/// gives 3 mm/s as a difference, 0.08 mm/s over 20 ms). Its delay is window / 2.
class CausalVelocity {
 public:
  explicit CausalVelocity(double window = 0.02);
  /// Adds a message (t [s], x [m]); non-finite or out-of-order messages are ignored, a gap longer than the
  /// window starts again.
  void push(double t, double x);
  /// [m/s]; NaN until the window holds at least three messages spanning a quarter of it.
  double velocity() const;
  void reset() { samples_.clear(); }

 private:
  double window_;
  std::deque<std::pair<double, double>> samples_;
};

}  // namespace die_cushion_ident
