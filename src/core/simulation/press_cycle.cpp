#include "die_cushion_ident/core/simulation/press_cycle.h"

#include <cmath>
#include <stdexcept>

namespace die_cushion_ident {

const char* ramMotionName(RamMotion motion) { return motion == RamMotion::kCrank ? "crank" : "ramped"; }

double PressCycleProgram::ramHeight(double theta) const {
  const double r = config_.crank_radius, lambda = config_.conrod_ratio;
  const double s = std::sin(theta);
  return r * (1.0 - std::cos(theta)) + r / lambda * (1.0 - std::sqrt(1.0 - lambda * lambda * s * s));
}

double PressCycleProgram::ramHeightSlope(double theta) const {
  const double r = config_.crank_radius, lambda = config_.conrod_ratio;
  const double s = std::sin(theta), c = std::cos(theta);
  return r * s * (1.0 + lambda * c / std::sqrt(1.0 - lambda * lambda * s * s));
}

PressCycleProgram::PressCycleProgram(const PressCycleConfig& c) : config_(c) {
  if (!(c.drawing_speed > 0.0 && c.return_speed > 0.0 && c.drawing_depth > 0.0)) {
    throw std::invalid_argument("press cycle: speeds and drawing depth must be > 0");
  }
  const bool crank = c.motion == RamMotion::kCrank;
  const double impact_travel = 0.5 * c.drawing_speed * c.impact_time;
  const double ramps = crank ? impact_travel : 0.5 * c.drawing_speed * (c.impact_time + c.deceleration_time);
  const double constant_drawing = (c.drawing_depth - ramps) / c.drawing_speed;
  const double constant_return = (c.drawing_depth - c.return_speed * c.return_ramp_time) / c.return_speed;
  if (!(constant_drawing > 0.0 && constant_return > 0.0)) {
    throw std::invalid_argument("press cycle: drawing depth too short for the acceleration ramps");
  }
  if (!(c.rest_time >= 0.0 && c.impact_time > 0.0 && c.deceleration_time > 0.0 && c.bottom_hold_time >= 0.0 &&
        c.release_time > 0.0 && c.return_ramp_time > 0.0)) {
    throw std::invalid_argument("press cycle: phase durations must be positive");
  }
  double crank_duration = 0.0;
  if (crank) {
    if (!(c.conrod_ratio > 0.0 && c.conrod_ratio < 1.0 && c.crank_radius > 0.0)) {
      throw std::invalid_argument("press cycle: the crank needs a radius > 0 and a rod ratio in (0, 1)");
    }
    // The crank angle at which the ram, still drawing_depth - impact_travel above bottom dead centre, meets
    // the cushion: h(theta) is increasing on [0, pi], so bisection.
    const double height = c.drawing_depth - impact_travel;
    if (!(ramHeight(M_PI) > height)) {
      throw std::invalid_argument("press cycle: a crank of radius " + std::to_string(c.crank_radius) +
                                  " m cannot draw " + std::to_string(c.drawing_depth) + " m");
    }
    double low = 0.0, high = M_PI;
    for (int i = 0; i < 200; ++i) {
      const double mid = 0.5 * (low + high);
      (ramHeight(mid) < height ? low : high) = mid;
    }
    crank_angle_ = 0.5 * (low + high);
    crank_speed_ = c.drawing_speed / ramHeightSlope(crank_angle_);
    crank_duration = crank_angle_ / crank_speed_;
  }
  const double v = c.drawing_speed, r = -c.return_speed;
  add(StrokePhase::kRest, c.rest_time, 0, 0, c.return_pressure, c.pre_pressure);
  add(StrokePhase::kImpact, c.impact_time, 0, v, c.pre_pressure, c.drawing_start_pressure);
  if (crank) {
    add(StrokePhase::kDrawing, crank_duration, v, 0, c.drawing_start_pressure, c.drawing_end_pressure, true);
  } else {
    add(StrokePhase::kDrawing, constant_drawing, v, v, c.drawing_start_pressure, c.drawing_end_pressure);
    add(StrokePhase::kDrawing, c.deceleration_time, v, 0, c.drawing_end_pressure, c.drawing_end_pressure);
  }
  add(StrokePhase::kBottomHold, c.bottom_hold_time, 0, 0, c.drawing_end_pressure, c.drawing_end_pressure);
  add(StrokePhase::kRelease, c.release_time, 0, 0, c.drawing_end_pressure, c.release_pressure);
  add(StrokePhase::kReturn, c.return_ramp_time, 0, r, c.return_pressure, c.return_pressure);
  add(StrokePhase::kReturn, constant_return, r, r, c.return_pressure, c.return_pressure);
  add(StrokePhase::kReturn, c.return_ramp_time, r, 0, c.return_pressure, c.return_pressure);
}

void PressCycleProgram::add(StrokePhase phase, double duration, double v0, double v1, double p0, double p1,
                            bool crank) {
  const double x0 = segments_.empty() ? 0.0 : segments_.back().x0 + segments_.back().displacement;
  const double displacement = crank ? ramHeight(crank_angle_) : 0.5 * (v0 + v1) * duration;
  segments_.push_back({phase, duration_, duration, v0, v1, p0, p1, x0, crank, displacement});
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
  if (seg->crank) {
    const double theta = std::max(crank_angle_ - crank_speed_ * tau, 0.0);
    point.v = crank_speed_ * ramHeightSlope(theta);
    point.x = seg->x0 + ramHeight(crank_angle_) - ramHeight(theta);
  } else {
    // Cosine velocity ramp: v = v0 + (v1 - v0) (1 - cos(pi f)) / 2, integrated in closed form.
    point.v = seg->v0 + (seg->v1 - seg->v0) * 0.5 * (1.0 - std::cos(M_PI * f));
    point.x = seg->x0 + seg->v0 * tau +
              0.5 * (seg->v1 - seg->v0) * (tau - seg->duration / M_PI * std::sin(M_PI * f));
  }
  point.x = std::max(point.x, 0.0);
  point.pressure_setpoint = seg->p0 + (seg->p1 - seg->p0) * f;
  point.phase = seg->phase;
  return point;
}

}  // namespace die_cushion_ident
