#include "die_cushion_ident/core/signal/message_phase.h"

#include <cmath>
#include <limits>

namespace die_cushion_ident {

MessagePhase messagePhase(const std::vector<double>& stamps, double period) {
  MessagePhase result;
  if (!(period > 0.0) || !std::isfinite(period)) return result;
  // Relative to the first stamp, whose own remainder is added back once (fmod is exact): a Unix stamp's 1e9 s
  // would cost each remainder its last digits.
  double origin = std::numeric_limits<double>::quiet_NaN();
  double cosines = 0.0, sines = 0.0;
  int count = 0;
  for (double stamp : stamps) {
    if (!std::isfinite(stamp)) continue;
    if (std::isnan(origin)) origin = stamp;
    const double angle = 2.0 * M_PI * std::fmod(stamp - origin, period) / period;
    cosines += std::cos(angle);
    sines += std::sin(angle);
    ++count;
  }
  if (count < 3) return result;
  result.coherence = std::hypot(cosines, sines) / count;
  double phase = std::fmod(origin, period) + std::atan2(sines, cosines) / (2.0 * M_PI) * period;
  phase = std::fmod(phase, period);
  result.phase = phase < 0.0 ? phase + period : phase;
  if (!(result.phase < period)) result.phase = 0.0;  // a remainder just below 0, rounded up to the period
  return result;
}

}  // namespace die_cushion_ident
