#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "die_cushion_ident/core/model/stroke_phase.h"

namespace die_cushion_ident {


/// How the ram moves the cushion while drawing.
enum class RamMotion : std::uint8_t {
  /// A hydraulic press: constant drawing speed between cosine ramps (impact, deceleration).
  kRamped,
  /// A mechanical (or servo) press: after the impact the cushion follows the slider-crank to bottom dead
  /// centre, its speed falling with the crank angle (no separate deceleration phase).
  kCrank,
};
const char* ramMotionName(RamMotion motion);

/// A press cycle as the cushion sees it: rest at pre-pressure, impact of the ram, drawing at ram speed with a
/// rising pressure set-point, bottom hold, pressure release, return stroke. Times [s], speeds [m/s],
/// pressures [Pa].
struct PressCycleConfig {
  RamMotion motion = RamMotion::kRamped;
  /// kCrank: crank radius r [m] (2 r >= drawing_depth) and r / l, l the connecting rod's length.
  double crank_radius = 0.15;
  double conrod_ratio = 0.25;
  double rest_time = 0.5;
  double impact_time = 0.02;  ///< cushion accelerates to ram speed
  double drawing_speed = 0.2;  ///< kCrank: the ram's speed when it meets the cushion
  double drawing_depth = 0.2;  ///< [m], must be below stroke_length
  double deceleration_time = 0.1;  ///< kRamped only
  double bottom_hold_time = 0.15;
  double release_time = 0.06;
  double return_speed = 0.25;
  double return_ramp_time = 0.05;
  double pre_pressure = 30e5;
  double drawing_start_pressure = 100e5;
  double drawing_end_pressure = 160e5;
  double release_pressure = 5e5;
  double return_pressure = 15e5;
};

/// The cushion's kinematics and pressure set-point as a function of time, repeating every cycle.
class PressCycleProgram {
 public:
  struct Point {
    double x = 0.0;                  ///< [m]
    double v = 0.0;                  ///< [m/s]
    double pressure_setpoint = 0.0;  ///< [Pa]
    StrokePhase phase = StrokePhase::kRest;
    int cycle = 0;
  };

  explicit PressCycleProgram(const PressCycleConfig& config);
  Point at(double t) const;
  double cycleDuration() const { return duration_; }
  const PressCycleConfig& config() const { return config_; }

 private:
  struct Segment {
    StrokePhase phase;
    double start, duration;
    double v0, v1;  // cosine velocity ramp from v0 to v1
    double p0, p1;  // linear set-point ramp
    double x0;      // position at the start
    bool crank = false;  // the slider-crank from angle crank_angle_ down to bottom dead centre instead
    double displacement = 0.0;
  };
  void add(StrokePhase phase, double duration, double v0, double v1, double p0, double p1, bool crank = false);
  /// The ram's height above bottom dead centre [m] at crank angle theta [rad] (0 at BDC), and its slope.
  double ramHeight(double theta) const;
  double ramHeightSlope(double theta) const;

  PressCycleConfig config_;
  std::vector<Segment> segments_;
  double duration_ = 0.0;
  double crank_angle_ = 0.0;  // [rad] where the crank segment starts
  double crank_speed_ = 0.0;  // [rad/s]
};

}  // namespace die_cushion_ident
