#pragma once

namespace die_cushion_ident {

/// Gains of the cushion's pressure controller (as found on a press, not identified).
struct PressureControllerConfig {
  double proportional_gain = 6e-8;  ///< spool opening per Pa of pressure error [1/Pa]
  double integral_gain = 6e-7;      ///< [1/(Pa s)]
  double nominal_flow_gain = 6e-6;  ///< the controller's K_v for velocity feed-forward [m^3/(s Pa^0.5)]
  double nominal_valve_gain = 0.1;  ///< the controller's valve gain [1/V]
  double max_voltage = 10.0;        ///< command limit [V]
  bool velocity_feed_forward = true;  ///< the nominal y_ff below; false: PI alone
};

/// PI pressure control with velocity feed-forward, as on a die cushion: the drain edge passes the oil the
/// ram displaces (y_ff = A v / (K_v sqrt(p_ref))), the PI part corrects the pressure error; opening the
/// drain (y > 0) lowers pressure, so y = y_ff + kp (p - p_ref) + ki int (p - p_ref).
class PressureController {
 public:
  PressureController(const PressureControllerConfig& config, double piston_area, double supply_pressure);
  /// Returns the command voltage for measured pressure p [Pa], set-point [Pa] and cushion speed v [m/s];
  /// `added_voltage` (a model's feed-forward, PressureFeedForward) is added before the limit.
  double update(double dt, double p_measured, double p_setpoint, double v, double added_voltage = 0.0);
  void reset() { integral_ = 0.0; }

 private:
  PressureControllerConfig config_;
  double piston_area_;
  double supply_pressure_;
  double integral_ = 0.0;
};

}  // namespace die_cushion_ident
