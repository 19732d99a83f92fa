#pragma once

#include <cstdint>
#include <deque>
#include <limits>
#include <utility>
#include <vector>

#include "die_cushion_ident/core/signal/uniform_resampler.h"

namespace die_cushion_ident {

/// The checks of the oil temperature topic (OilTemperatureInput::Config).
struct OilTemperatureInputConfig {
  double min_plausible = -30.0;  ///< [degC]
  double max_plausible = 150.0;  ///< [degC]
  double max_rate = 2.0;         ///< [K/s]
  double max_age = 10.0;         ///< [s]
  double gap = 5.0;              ///< [s] message intervals longer than this count as gaps
};

/// The optional oil temperature topic (sensor_msgs/Temperature, degC as REP 103 has it, typically 1-10 Hz):
/// checked like the other inputs and held for the grid, which it does not pace.
///
/// A message is rejected (and counted in its StreamHealth, as the resampler counts the others) when its stamp
/// or value is not finite, its stamp repeats or runs back, its value lies outside [min_plausible,
/// max_plausible], it jumps from the last accepted one faster than an oil in a tank can change (max_rate
/// K/s, plus 1 K for the sensor's noise and resolution) unless the next two messages confirm the new level (a
/// sensor replugged, a first value that was wrong), or its stamp lies more than max_age away from the other
/// topics' newest stamp (a wild stamp, or another clock far off; within max_age a clock offset is harmless:
/// the oil changes by hundredths of a kelvin a second). The grid's temperature at t is the line between the
/// accepted messages around it, the last one held up to max_age after it, none (NaN) beyond: a silent topic
/// loses nothing but the temperature.
class OilTemperatureInput {
 public:
  using Config = OilTemperatureInputConfig;
  using PushResult = UniformResampler::PushResult;

  explicit OilTemperatureInput(const Config& config = Config()) : config_(config) {}

  /// One message: its stamp [s] and temperature [degC]; `time_base` [s] is the other topics' newest stamp
  /// (NaN before any), against which a wild stamp is judged. kHeld: a wild stamp, rejected and counted (the
  /// other topics set the time base; this topic never moves it).
  PushResult push(double stamp, double celsius, double time_base);
  /// [degC] at grid time t (NaN where none holds). Messages more than max_age before t are dropped: t must
  /// not run back by more than that (a restarted time base calls restart()).
  double at(double t);
  /// The same without dropping anything.
  double peek(double t) const;
  /// The temperature at t [degC] from accepted messages (stamp, degC) in time order, as at() has it: the line
  /// between the two around t, either held up to `max_age` from it, NaN beyond.
  static double heldAt(const std::vector<std::pair<double, double>>& messages, double t, double max_age);
  /// A new time base (the stamps jumped back): the messages held so far are forgotten, the counts kept.
  void restart();

  const StreamHealth& health() const { return health_; }
  bool any() const { return health_.accepted > 0; }
  /// Over every accepted message: mean, lowest and highest [degC].
  double mean() const { return health_.accepted > 0 ? sum_ / static_cast<double>(health_.accepted) : kNaN; }
  double lowest() const { return lowest_; }
  double highest() const { return highest_; }
  /// [s] the accepted stamps' mean offset from the other topics' newest stamp when they arrived (< 0: the
  /// temperature's stamps lag; informative only, within max_age it does not matter).
  double meanStampOffset() const { return offsets_ > 0 ? offset_sum_ / offsets_ : kNaN; }
  /// Messages rejected because they jumped faster than max_rate, of health().implausible.
  std::uint64_t jumps() const { return jumps_; }
  const Config& config() const { return config_; }

 private:
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  void accept(double stamp, double celsius, double time_base);

  Config config_;
  StreamHealth health_;
  std::deque<std::pair<double, double>> messages_;  // accepted (stamp, degC), oldest first
  std::vector<std::pair<double, double>> jump_;     // consecutive messages that jumped, consistent among them
  double sum_ = 0.0, lowest_ = kNaN, highest_ = kNaN;
  double offset_sum_ = 0.0;
  std::uint64_t offsets_ = 0, jumps_ = 0;
  double last_stamp_ = kNaN, last_value_ = kNaN;  // the newest accepted message
};

}  // namespace die_cushion_ident
