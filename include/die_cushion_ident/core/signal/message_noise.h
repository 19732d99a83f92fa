#pragma once

#include <limits>

#include "die_cushion_ident/core/signal/white_noise_estimator.h"

namespace die_cushion_ident {

/// Whether a grid of `sample_period` lies between messages that come every `message_interval` (its samples
/// then interpolate them): a period below 0.9 of the interval.
inline bool gridBetweenMessages(double sample_period, double message_interval) {
  return sample_period < 0.9 * message_interval;
}

/// A sensor's white noise read from its own messages, before any resampling, and how often they come.
/// A grid finer than the messages holds interpolations between them, whose second differences are far
/// smaller than the sensor's (0.5 ms from 1 kHz pressure: the grid's estimate was 7 times too small, and a
/// clean press's error read 7.6 times "the noise"). Constant memory.
class MessageNoise {
 public:
  /// A message; non-finite values and stamps that do not advance are skipped (a bag that loops starts the
  /// second differences over).
  void add(double stamp, double value);
  /// The noise's standard deviation [the value's unit]; +infinity until enough messages.
  double sigma() const { return noise_.sigma(); }
  /// The mean interval between consecutive messages [s]; NaN until two.
  double meanInterval() const;
  /// Follows the grid t_k = k * period + phase from the next message on: how far each grid point lies between
  /// the two messages it is interpolated from (forGrid). `stamp_offset` [s] is what the pipeline subtracts
  /// from the messages' stamps before resampling (the topic's delay), so that the grid is met on its own time
  /// base. A new grid starts the count over.
  void followGrid(double period, double stamp_offset, double phase = 0.0);
  /// The noise a grid of this period is to be compared with, where neighbouring grid samples share messages
  /// (a period below 3.8 message intervals: the resampler's cubic reads four): their second differences then
  /// read the noise low (7 times at 0.5 ms from 1 kHz). It is the noise each grid sample holds: a sample a
  /// fraction w of the way from one message to the next holds sigma^2 times the sum of the cubic's squared
  /// weights (1 at w = 0, 0.64 at w = 0.5), so the sensor's sigma times the root mean of that over the
  /// followed grid (the sensor's sigma where the grid is not followed). 0 where the samples do not share
  /// messages: the grid's own estimate is then unbiased.
  double forGrid(double sample_period) const;
  /// The root mean of the cubic's squared weights over the followed grid's points so far (1 before any).
  double gridShare() const;

 private:
  void addGridShares(double from, double to);

  WhiteNoiseEstimator noise_{4};
  double values_[3] = {0.0, 0.0, 0.0};
  int run_ = 0;  // consecutive messages in values_ (up to 3)
  double last_stamp_ = std::numeric_limits<double>::quiet_NaN();
  double interval_sum_ = 0.0;
  long intervals_ = 0;
  double grid_period_ = 0.0;  // 0: no grid followed
  double grid_offset_ = 0.0;  // [s] subtracted from the stamps for the grid
  double share_sum_ = 0.0;
  long shares_ = 0;
};

}  // namespace die_cushion_ident
