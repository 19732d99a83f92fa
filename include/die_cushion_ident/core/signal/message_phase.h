#pragma once

#include <vector>

namespace die_cushion_ident {

/// Where within a period a stream's messages fall: the circular mean of (stamp mod period), and how tightly
/// they keep to it.
struct MessagePhase {
  double phase = 0.0;      ///< [s] in [0, period)
  double coherence = 0.0;  ///< length of the mean phasor, 0 (no common phase) to 1 (every stamp on it)
};

/// The phase of `stamps` [s] modulo `period` [s] (measured from time 0, as the grid's points are);
/// coherence 0 for fewer than three finite stamps or a period that is not positive. Jitter of standard
/// deviation s lowers the coherence to about exp(-(2 pi s / period)^2 / 2); messages whose rate is off the
/// period turn their phase over the stamps and lower it further (1e-4 of the period: a whole turn in 10 000
/// messages).
MessagePhase messagePhase(const std::vector<double>& stamps, double period);

}  // namespace die_cushion_ident
