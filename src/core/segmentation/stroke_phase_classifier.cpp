#include "die_cushion_ident/core/segmentation/stroke_phase_classifier.h"

#include <algorithm>
#include <cmath>

namespace die_cushion_ident {

StrokePhaseClassifier::StrokePhaseClassifier(const Config& config) : config_(config) {}

void StrokePhaseClassifier::reset() {
  started_ = false;
  v_filtered_ = a_filtered_ = dp_filtered_ = deepest_ = 0.0;
  phase_ = StrokePhase::kRest;
}

StrokePhase StrokePhaseClassifier::classify(const GridSample& s) {
  if (!std::isfinite(s.x) || !std::isfinite(s.v) || !std::isfinite(s.p) || !std::isfinite(s.t)) return phase_;
  if (!started_ || s.discontinuity || !(s.t > t_)) {
    started_ = true;
    t_ = s.t;
    p_ = s.p;
    v_filtered_ = s.v;
    a_filtered_ = dp_filtered_ = 0.0;
    return phase_;
  }
  const double dt = s.t - t_;
  const double k = std::min(1.0, dt / config_.smoothing_time);
  const double v_previous = v_filtered_;
  v_filtered_ += k * (s.v - v_filtered_);
  a_filtered_ += k * ((v_filtered_ - v_previous) / dt - a_filtered_);
  dp_filtered_ += k * ((s.p - p_) / dt - dp_filtered_);
  t_ = s.t;
  p_ = s.p;
  deepest_ = std::max(deepest_, static_cast<double>(s.x));

  const double v = v_filtered_;
  const bool lower_part = deepest_ > config_.min_stroke && s.x > 0.5 * deepest_;
  if (v < -config_.min_velocity) {
    phase_ = StrokePhase::kReturn;
  } else if (v > config_.min_velocity) {
    const bool starting = phase_ == StrokePhase::kRest || phase_ == StrokePhase::kImpact;
    phase_ =
        starting && a_filtered_ > config_.impact_acceleration ? StrokePhase::kImpact : StrokePhase::kDrawing;
  } else if (lower_part) {
    // Releasing: the pressure falls by a large fraction of itself per second (the pressure controller
    // holds it steady at the bottom otherwise); once releasing, until it stops falling.
    const double fall_rate = -dp_filtered_ / std::max(static_cast<double>(s.p), 10e5);
    const bool falling =
        fall_rate > config_.release_rate || (phase_ == StrokePhase::kRelease && fall_rate > 0.0);
    phase_ = falling ? StrokePhase::kRelease : StrokePhase::kBottomHold;
  } else {
    phase_ = StrokePhase::kRest;
  }
  return phase_;
}

}  // namespace die_cushion_ident
