#pragma once

#include "die_cushion_ident/core/signal/uniform_resampler.h"
#include "die_cushion_ident/core/simulation/press_cycle.h"

namespace die_cushion_ident {

/// Names the phase of the stroke from the measured signals alone (no press controller signals needed):
///   return       the cushion moves up (v < -v_min);
///   impact       it moves down and is still accelerating near the top (the ram has just hit);
///   drawing      it moves down steadily;
///   bottom_hold  it stands in the lower part of the stroke with steady pressure;
///   release      it stands in the lower part while the pressure falls fast (relative to itself);
///   rest         it stands in the upper part.
/// "Upper" and "lower" are relative to the deepest position seen so far. Accelerations and pressure
/// rates come from differences over a few samples smoothed by first-order filters.
class StrokePhaseClassifier {
 public:
  struct Config {
    double min_velocity = 0.005;       ///< [m/s] slower counts as standing
    double impact_acceleration = 0.5;  ///< [m/s^2] faster speed-up counts as impact
    double release_rate = 5.0;         ///< [1/s] a pressure falling faster than this share of itself per
                                       ///< second while standing is release
    double smoothing_time = 0.01;      ///< [s] of the velocity and pressure-rate filters
    double min_stroke = 0.01;          ///< [m] shorter strokes are not strokes (position sensor noise)
  };

  StrokePhaseClassifier() : StrokePhaseClassifier(Config()) {}
  explicit StrokePhaseClassifier(const Config& config);
  StrokePhase classify(const GridSample& s);
  void reset();

 private:
  Config config_;
  bool started_ = false;
  double t_ = 0.0, p_ = 0.0, v_filtered_ = 0.0, a_filtered_ = 0.0, dp_filtered_ = 0.0;
  double deepest_ = 0.0;
  StrokePhase phase_ = StrokePhase::kRest;
};

}  // namespace die_cushion_ident
