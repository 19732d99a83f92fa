#pragma once

#include <limits>
#include <vector>

#include "die_cushion_ident/core/frequency_response.h"
#include "die_cushion_ident/core/servo_valve_fit.h"

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

struct RecordedSweep {
  std::vector<SweepSegment> segments;
  std::vector<FrequencyResponsePoint> points;  ///< one per segment with enough settled periods
  ServoValveFit fit;
};

/// Detects the segments, measures a point over the settled whole periods of each and fits the valve model.
RecordedSweep analyzeRecordedSweep(const std::vector<ValveSample>& samples,
                                   const RecordedSweepOptions& options = {});

}  // namespace die_cushion_ident
