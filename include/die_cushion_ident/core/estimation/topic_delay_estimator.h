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
  /// [s] standard uncertainty of each offset (pressure 0): its statistical part from the cost's curvature
  /// with the rows' correlation, the method's (how far the offset moves with windows half as long) and an
  /// eighth of a sample period, the interpolation's floor.
  std::array<double, kInputStreamCount> resolution = {0.0, 0.0, 0.0};
  /// [s] the part of resolution[valve] that is the valve model's own timing (addValveModelTiming); 0 where
  /// the spool is measured or the model is the user's.
  double valve_model_timing = 0.0;
  /// [s] the standard uncertainty of the topics' common offset against the pressure where the survey's free
  /// run judged it (IdentificationConfig::common_delay_std); 0 where it did not.
  double common_std = 0.0;
  bool valid = false;  ///< enough excited samples to judge
  int samples = 0;     ///< samples the estimate rests on
  std::string message;  ///< why not valid, in words
  /// Whether any offset is large enough to be worth correcting (beyond a quarter of the sample period).
  bool significant(double sample_period) const;
  /// Whether any offset differs from 0 by more than `sigmas` standard uncertainties.
  bool distinguishable(double sigmas = 2.0) const;
};

/// Estimates constant clock offsets between the pressure, position and valve topics from the physics: the
/// volume balance integrated over windows of 25 ms (the identification's integral form, with free
/// coefficients, so no identified model is needed)
///   A (x(t+W) - x(t)) = c_1 int A (s - x) dp + c_2 int dp + c_3 int air(p) dp + int f(y) sqrt(dp_port) dt
///                       + c_t int y / sqrt(p) dt + c_L int p dt + c_0 W,
/// f a piecewise-linear opening with kinks at 1, 2, 4 and 7 % of the spool (a dead band fits),
/// holds for every window only when the signals line up in time. For each candidate offset of a topic (its
/// channels read at t + tau) the balance is fitted by linear least squares, the pressure noise's share of
/// the capacitive columns removed (errors in variables), and the residual's RMS is the cost; the offsets are
/// its minimum: a coarse map over both offsets on smoothed signals, its three best basins refined in whole,
/// quarter samples and by a parabola, the lowest kept. Only windows where the model holds (pressure above
/// min_pressure, valve not saturated) and the cushion moves or the pressure changes count. The map and the
/// basins' refinement run on up to `jobs` threads (the same result on any number).
TopicDelayEstimate estimateTopicDelays(const std::vector<GridSample>& grid,
                                       const IdentificationConfig& config, int jobs = 1);

/// Without a measured spool the balance's valve channel is the valve model's spool, so the valve topic's
/// offset found is the clock offset plus what the model's timing lacks: a valve slower than the model reads
/// as early stamps (a large soft chamber's 41 Hz, 3.75 ms valve against the default 80 Hz, 2 ms: -4.72 ms
/// where the clocks agree; doc/resolution.md). Corrected, the offset still lines the model's spool up with
/// the pressure; as a clock offset it is known only to the model's timing. Where that model is the default
/// (no sweep, nothing configured), the valve's true low-frequency delay is taken as anywhere between 0 and
/// twice the default's, uniformly: std = delay / sqrt(3), added to resolution[valve] in quadrature.
void addValveModelTiming(const ServoValveParameters& assumed, TopicDelayEstimate* delays);

/// The words for a large valve offset that may be the default valve model's timing as much as the clocks
/// (valve_model_timing > 0), `corrected` or not: the same for analyze_bag's warning and the node's
/// diagnostic.
std::string valveTimingWarning(double valve_offset, bool corrected);

}  // namespace die_cushion_ident
