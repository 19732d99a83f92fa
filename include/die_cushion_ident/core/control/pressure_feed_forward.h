#pragma once

#include <cstdint>
#include <optional>
#include <utility>

#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/valve/servo_valve.h"

namespace die_cushion_ident {

/// The identified model turned round (paper, Fig. 19): the valve command that makes the cushion follow a
/// desired pressure trajectory at the measured motion, for the cell controller to add to its PI output.
///
/// The volume balance asks for the valve flow  Q_v* = A v - Q_extra(p_ref) - C(p_ref, x) dp_ref/dt;
/// the valve's static characteristic (the model's Q_v(y, p), with overlap and tank pressure when
/// identified) is inverted for the spool opening y by bisection (monotonic in y), and y / K_valve is the
/// voltage. The valve answers late (dead time plus 2 D / w0 of its 2nd-order part, leadTime()): the caller
/// passes the trajectory as it will be that far ahead (a press program is known in advance; a live caller
/// extrapolates). On the simulator that preview is what makes the difference: 0.2 bar drawing error with
/// it, 2.6 bar without. The command never leaves [-max_voltage, max_voltage]; non-finite inputs give 0 V
/// (nothing is added to the PI).
class PressureFeedForward {
 public:
  /// `model` must outlive this object (it is not copied: a custom effect's copy costs a probe of its
  /// operating range); `physical`: its identified parameters; `valve`: the valve model (gain [1/V] for the
  /// static inverse, dead time, natural frequency and damping for the lead). Throws std::invalid_argument
  /// for a zero or non-finite valve gain, a non-positive voltage limit or parameters that do not fit.
  PressureFeedForward(const HydraulicModel& model, const ParameterVector& physical,
                      const ServoValveParameters& valve, double max_voltage);
  /// New identified parameters (same model); throws std::invalid_argument as the constructor.
  void setParameters(const ParameterVector& physical);

  /// Spool opening [-] (in [-1, 1]) that makes the model's pressure rate equal dp_ref at p_ref.
  double spoolOpening(double p_ref, double dp_ref, double x, double v) const;
  /// The feed-forward voltage [V] for a reference pressure [Pa] and its rate [Pa/s] at position x [m],
  /// velocity v [m/s], all taken leadTime() ahead; false in `valid` (may be null) when an input was not
  /// finite.
  double command(double p_ref, double dp_ref, double x, double v, bool* valid = nullptr) const;
  /// [s] how far ahead the trajectory should be taken: the valve's dead time plus 2 D / w0.
  double leadTime() const { return lead_; }

 private:
  const HydraulicModel& model_;
  ParameterVector physical_;
  double valve_gain_;
  double max_voltage_;
  double lead_;
};

/// The pressure set-point as a cell controller streams it: the newest value and its rate from the last two
/// samples, extrapolated to the time the valve will answer. NaN values and stamps that do not advance are
/// refused and counted; a reference older than the allowed age is not used.
class PressureReference {
 public:
  enum class Push { kAccepted, kNonFinite, kNotAdvancing };
  Push push(double stamp, double pressure);
  /// {pressure, rate} at `now + ahead` [Pa, Pa/s], or nothing when no sample is fresher than `max_age` at
  /// `now`.
  std::optional<std::pair<double, double>> at(double now, double ahead, double max_age) const;
  bool received() const { return count_ > 0; }
  double newestStamp() const { return t1_; }
  std::uint64_t rejected() const { return rejected_; }

 private:
  double t0_ = 0.0, p0_ = 0.0, t1_ = -1e18, p1_ = 0.0;
  std::uint64_t count_ = 0, rejected_ = 0;
};

}  // namespace die_cushion_ident
