#pragma once

#include <limits>
#include <vector>

#include "die_cushion_ident/core/valve/frequency_response.h"
#include "die_cushion_ident/core/valve/servo_valve_fit.h"

namespace die_cushion_ident {

/// One message of the valve topic: the voltage in force from `t` on and the measured spool position.
struct ValveSample {
  double t = 0.0;
  double voltage = 0.0;
  double spool = 0.0;
};

/// A stretch of recorded data in which the command is a sine of constant frequency.
struct SweepSegment {
  double begin = 0.0, end = 0.0;  ///< [s] first and last rising zero crossing of the command
  double frequency = 0.0;         ///< [Hz] from the crossings
  double amplitude = 0.0;         ///< [V]
  double offset = 0.0;            ///< [V]
};

struct RecordedSweepOptions {
  double min_frequency = 2.0;            ///< [Hz] lowest sweep frequency looked for
  int min_periods = 8;                   ///< shortest run of equal periods that counts as a segment
  double period_tolerance = 0.03;        ///< relative spread of the periods inside a segment
  double min_amplitude = 0.01;           ///< [V]
  double max_command_distortion = 0.05;  ///< a segment's command must be this close to a pure sine
  double settle_periods = 3.0;           ///< left out after the segment's start (valve transient) ...
  double settle_time = 0.05;             ///< [s] ... at least this long
  /// [s] how long each command is held (the amplifier's update period); NaN = the median sample interval.
  double command_hold = std::numeric_limits<double>::quiet_NaN();
  double max_distortion = 0.02;
};

/// Finds the sine-sweep segments in a recorded valve signal without metadata: rising zero crossings of the
/// command around its running mean (with hysteresis) whose spacing stays constant for several periods,
/// confirmed by the command being a clean sine at that frequency. Samples must be in time order.
std::vector<SweepSegment> detectSweepSegments(const std::vector<ValveSample>& samples,
                                              const RecordedSweepOptions& options = {});

/// Keeps the raw valve signal only where it can hold a sine sweep, so that an offline analysis of hours of
/// press strokes does not store every valve message: the signal is cut into blocks of `block` seconds; a
/// block is kept when its command crosses its mean upwards at least four times (with hysteresis at a third
/// of its amplitude, amplitude >= min_amplitude) and at least 70 % of successive periods agree within
/// `spread` (plus two message intervals of quantisation), together with the block before and the one after
/// it (a segment's edges). Samples go out in time order.
class SweepCandidateFilter {
 public:
  explicit SweepCandidateFilter(double block = 2.0, double min_amplitude = 0.01, double spread = 0.1);
  /// Adds one valve message; appends kept samples to `kept`. Messages not later than the previous are dropped.
  void push(const ValveSample& sample, std::vector<ValveSample>* kept);
  void flush(std::vector<ValveSample>* kept);

 private:
  bool periodic(const std::vector<ValveSample>& block) const;
  void closeBlock(std::vector<ValveSample>* kept);

  double block_, min_amplitude_, spread_;
  std::vector<ValveSample> previous_, current_;
  bool before_periodic_ = false, previous_periodic_ = false;  // the blocks before the current one
  double block_start_ = 0.0;
};

struct RecordedSweep {
  std::vector<SweepSegment> segments;
  std::vector<FrequencyResponsePoint> points;  ///< one per segment with enough settled periods
  ServoValveFit fit;
  double message_interval = 0.0;  ///< [s] the valve messages' median interval
};

/// Detects the segments, measures a point over the settled whole periods of each and fits the valve model.
RecordedSweep analyzeRecordedSweep(const std::vector<ValveSample>& samples,
                                   const RecordedSweepOptions& options = {});

}  // namespace die_cushion_ident
