#include "die_cushion_ident/core/simulation/press_cycle.h"

#include <cmath>
#include <stdexcept>

namespace die_cushion_ident {


PressCycleProgram::PressCycleProgram(const PressCycleConfig& c) : config_(c) {
  const double ramps = 0.5 * c.drawing_speed * (c.impact_time + c.deceleration_time);
  const double constant_drawing = (c.drawing_depth - ramps) / c.drawing_speed;
  const double constant_return = (c.drawing_depth - c.return_speed * c.return_ramp_time) / c.return_speed;
  if (!(c.drawing_speed > 0.0 && c.return_speed > 0.0 && c.drawing_depth > 0.0)) {
    throw std::invalid_argument("press cycle: speeds and drawing depth must be > 0");
  }
  if (!(constant_drawing > 0.0 && constant_return > 0.0)) {
    throw std::invalid_argument("press cycle: drawing depth too short for the acceleration ramps");
  }
  if (!(c.rest_time >= 0.0 && c.impact_time > 0.0 && c.deceleration_time > 0.0 && c.bottom_hold_time >= 0.0 &&
        c.release_time > 0.0 && c.return_ramp_time > 0.0)) {
    throw std::invalid_argument("press cycle: phase durations must be positive");
  }
  const double v = c.drawing_speed, r = -c.return_speed;
  add(StrokePhase::kRest, c.rest_time, 0, 0, c.return_pressure, c.pre_pressure);
  add(StrokePhase::kImpact, c.impact_time, 0, v, c.pre_pressure, c.drawing_start_pressure);
  add(StrokePhase::kDrawing, constant_drawing, v, v, c.drawing_start_pressure, c.drawing_end_pressure);
  add(StrokePhase::kDrawing, c.deceleration_time, v, 0, c.drawing_end_pressure, c.drawing_end_pressure);
  add(StrokePhase::kBottomHold, c.bottom_hold_time, 0, 0, c.drawing_end_pressure, c.drawing_end_pressure);
  add(StrokePhase::kRelease, c.release_time, 0, 0, c.drawing_end_pressure, c.release_pressure);
  add(StrokePhase::kReturn, c.return_ramp_time, 0, r, c.return_pressure, c.return_pressure);
  add(StrokePhase::kReturn, constant_return, r, r, c.return_pressure, c.return_pressure);
  add(StrokePhase::kReturn, c.return_ramp_time, r, 0, c.return_pressure, c.return_pressure);
}

void PressCycleProgram::add(StrokePhase phase, double duration, double v0, double v1, double p0, double p1) {
  const double x0 = segments_.empty()
                        ? 0.0
                        : segments_.back().x0 +
                              0.5 * (segments_.back().v0 + segments_.back().v1) * segments_.back().duration;
  segments_.push_back({phase, duration_, duration, v0, v1, p0, p1, x0});
  duration_ += duration;
}

PressCycleProgram::Point PressCycleProgram::at(double t) const {
  Point point;
  point.cycle = static_cast<int>(std::floor(t / duration_));
  double tau = t - point.cycle * duration_;
  const Segment* seg = &segments_.back();
  for (const auto& s : segments_) {
    if (tau < s.start + s.duration) {
      seg = &s;
      break;
    }
  }
  tau = std::min(std::max(tau - seg->start, 0.0), seg->duration);
  const double f = (seg->duration > 0.0) ? tau / seg->duration : 1.0;
  // Cosine velocity ramp: v = v0 + (v1 - v0) (1 - cos(pi f)) / 2, integrated in closed form.
  point.v = seg->v0 + (seg->v1 - seg->v0) * 0.5 * (1.0 - std::cos(M_PI * f));
  point.x =
      seg->x0 + seg->v0 * tau + 0.5 * (seg->v1 - seg->v0) * (tau - seg->duration / M_PI * std::sin(M_PI * f));
  point.x = std::max(point.x, 0.0);
  point.pressure_setpoint = seg->p0 + (seg->p1 - seg->p0) * f;
  point.phase = seg->phase;
  return point;
}

}  // namespace die_cushion_ident
