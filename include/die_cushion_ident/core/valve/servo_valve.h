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
  /// [s] how late the spool follows a slow command: the dead time plus the second-order lag's group delay
  /// at low frequency, 2 D / w0 (non-finite or negative parts count 0).
  double lowFrequencyDelay() const;
};

/// Spool position under onboard position control:
///   y'' / w0^2 + 2 D / w0 * y' + y = K * U(t - T_dead),   |y| <= 1 (mechanical stop), |y'| <=
///   max_spool_velocity,
/// integrated by RK4 in steps of at most max_step with the command held piecewise constant; or, built by
/// exact(), by the linear model's own solution between the switches of the delayed command (no speed limit;
/// the stop applied where a stretch ends): a few exponentials per message instead of ten RK4 steps, for
/// running the model on recorded commands (ValveMessageSpool, fitValveToOperation).
class ServoValve {
 public:
  explicit ServoValve(const ServoValveParameters& parameters, double max_step = 1e-4);
  /// The exact propagation (max_spool_velocity is ignored).
  static ServoValve exact(const ServoValveParameters& parameters);

  /// Applies command voltage u from now on and advances by dt [s]; returns the spool position.
  double advance(double dt, double command_voltage);
  void reset(double position = 0.0);

  double position() const { return y_; }
  double velocity() const { return y_dot_; }
  /// [s] the spool's integral over time since reset(), exact for exact() (the closed form of each stretch),
  /// RK4's quadrature otherwise: a stretch's mean spool is the difference over its length.
  double integral() const { return integral_; }
  double time() const { return time_; }
  const ServoValveParameters& parameters() const { return parameters_; }

 private:
  double delayedCommand(double t);
  void integrate(double h, double u);
  void propagateExactly(double h, double u);
  void propagateLinear(double h, double u);

  ServoValveParameters parameters_;
  double max_step_;
  bool exact_ = false;
  struct Propagation {
    long long key = -1;  // [ns] the stretch's length
    double c = 1.0, s_over_wd = 0.0, decay = 1.0;
  };
  static constexpr int kPropagations = 4;
  Propagation propagations_[kPropagations];
  int next_propagation_ = 0;
  double omega_;
  double time_ = 0.0;
  double y_ = 0.0;
  double y_dot_ = 0.0;
  double integral_ = 0.0;
  std::deque<std::pair<double, double>> commands_;  // (time applied, voltage)
};

/// The same spool dynamics for a constant sample period, as a difference equation: the bilinear transform
/// prewarped at the natural frequency, the dead time rounded to whole samples, no speed limit or stop. A few
/// nanoseconds a sample where ServoValve's integration takes a hundred: for following the command sample by
/// sample (the regressor's port side near the kink), not for simulating sweeps.
class SampledServoValve {
 public:
  SampledServoValve(const ServoValveParameters& parameters, double sample_period);
  /// Starts at rest at `position` (the commands before as if they had held it there).
  void reset(double position);
  /// The spool one sample after `command_voltage` was applied.
  double step(double command_voltage);

 private:
  static constexpr int kMaxDelay = 64;
  static constexpr int kRing = kMaxDelay + 3;
  double b_ = 0.0, a1_ = 0.0, a2_ = 0.0, gain_ = 0.0;  // y_k = b (u_k + 2 u_k-1 + u_k-2) - a1 y_k-1 - a2 y_k-2
  int delay_ = 0;                                        // dead time [samples]
  double commands_[kRing] = {};                          // recent commands, a ring
  int newest_ = 0;
  double y1_ = 0.0, y2_ = 0.0;
};

}  // namespace die_cushion_ident
