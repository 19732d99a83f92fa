#include "die_cushion_ident/core/simulation/pressure_controller.h"

#include <algorithm>
#include <cmath>

namespace die_cushion_ident {

PressureController::PressureController(const PressureControllerConfig& config, double piston_area,
                                       double supply_pressure)
    : config_(config), piston_area_(piston_area), supply_pressure_(supply_pressure) {}

double PressureController::update(double dt, double p_measured, double p_setpoint, double v,
                                  double added_voltage) {
  const double displaced_flow = piston_area_ * v;
  const double port_drop = displaced_flow >= 0.0 ? p_setpoint : supply_pressure_ - p_setpoint;
  const double feed_forward =
      config_.velocity_feed_forward
          ? displaced_flow / (config_.nominal_flow_gain * std::sqrt(std::max(port_drop, 1e5)))
          : 0.0;
  const double error = std::isfinite(p_measured) ? p_measured - p_setpoint : 0.0;
  const double added = std::isfinite(added_voltage) ? added_voltage * config_.nominal_valve_gain : 0.0;
  double y = feed_forward + added + config_.proportional_gain * error + config_.integral_gain * integral_;
  const double y_limit = config_.max_voltage * config_.nominal_valve_gain;
  // Conditional integration: stop integrating while the command is saturated in the error's direction.
  if (!(std::abs(y) >= y_limit && y * error > 0.0)) integral_ += error * dt;
  y = std::clamp(y, -y_limit, y_limit);
  return y / config_.nominal_valve_gain;
}

}  // namespace die_cushion_ident
