#pragma once

#include <array>
#include <string>
#include <vector>

#include "die_cushion_ident/core/estimation/identification_config.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"

namespace die_cushion_ident {

/// [s] a clock offset between topics beyond this deserves a look at the recording setup (a warning).
constexpr double kLargeTopicDelay = 0.005;

/// Clock offsets between the input topics, found in the data.
struct TopicDelayEstimate {
  /// [s] how late each topic's stamps are against the pressure's (pressure 0 by definition).
  std::array<double, kInputStreamCount> delays = {0.0, 0.0, 0.0};
  /// [s] half-width of the interval in which the cost stays within its noise of the minimum, per topic
  /// (pressure 0): how sharply the data pin the offset down.
  std::array<double, kInputStreamCount> resolution = {0.0, 0.0, 0.0};
  bool valid = false;  ///< enough excited samples to judge
  int samples = 0;     ///< samples the estimate rests on
  std::string message;  ///< why not valid, in words
  /// Whether any offset is large enough to be worth correcting (beyond a quarter of the sample period).
  bool significant(double sample_period) const;
};

/// Estimates constant clock offsets between the pressure, position and valve topics from the physics: the
/// volume balance
///   A v = (A (s - x) / K') dp/dt + (V_dead / K') dp/dt + c_air dp/dt p_atm/(p + p_atm)^2 + K_v f(y, p)
///         + c_overlap sign(y) sqrt(dp_valve) + c_tank y / sqrt(p) + G_L p + q_0
/// (every library effect to first order)
/// holds at every instant only when the signals line up in time. For each candidate offset tau of one topic
/// (its channels read at t + tau) the balance is fitted by linear least squares (the coefficients are free,
/// so no identified model is needed) and the equation-error RMS is the cost; the offset is the minimum,
/// searched on the grid over +-search, refined in quarter-samples and by a parabola through the best three.
/// Position and valve are searched in turn (coordinate descent, twice). All signals pass the same
/// zero-phase smoothing, so the smoothing cannot shift the minimum. Only samples where the model holds
/// (pressure above min_pressure, valve not saturated) and the cushion moves or the pressure changes count.
TopicDelayEstimate estimateTopicDelays(const std::vector<GridSample>& grid, const IdentificationConfig& config);

}  // namespace die_cushion_ident
