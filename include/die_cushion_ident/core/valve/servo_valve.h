#pragma once

#include <deque>
#include <limits>
#include <utility>

namespace die_cushion_ident {

/// Parameters of the servo valve's spool dynamics (shared/CONTRACT.md).
struct ServoValveParameters {
  double natural_frequency = 80.0;  ///< w0 / (2 pi) [Hz]
  double damping = 0.7;             ///< D [-]
  double gain = 0.1;                ///< K [1/V]: steady-state spool position per volt
  double dead_time = 0.002;         ///< T_dead [s]
  /// Largest spool speed [1/s] (pilot-flow limit); infinity = none. Large sweeps saturate it.
  double max_spool_velocity = std::numeric_limits<double>::infinity();
};

/// Spool position under onboard position control:
///   y'' / w0^2 + 2 D / w0 * y' + y = K * U(t - T_dead),   |y| <= 1 (mechanical stop), |y'| <=
///   max_spool_velocity,
/// integrated by RK4 in steps of at most max_step with the command held piecewise constant.
class ServoValve {
 public:
  explicit ServoValve(const ServoValveParameters& parameters, double max_step = 1e-4);

  /// Applies command voltage u from now on and advances by dt [s]; returns the spool position.
  double advance(double dt, double command_voltage);
  void reset(double position = 0.0);

  double position() const { return y_; }
  double velocity() const { return y_dot_; }
  double time() const { return time_; }
  const ServoValveParameters& parameters() const { return parameters_; }

 private:
  double delayedCommand(double t);
  void integrate(double h, double u);

  ServoValveParameters parameters_;
  double max_step_;
  double omega_;
  double time_ = 0.0;
  double y_ = 0.0;
  double y_dot_ = 0.0;
  std::deque<std::pair<double, double>> commands_;  // (time applied, voltage)
};

}  // namespace die_cushion_ident
