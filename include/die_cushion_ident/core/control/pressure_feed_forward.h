#pragma once

#include <cstdint>
#include <deque>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/valve/instant.h"
#include "die_cushion_ident/core/valve/servo_valve.h"

namespace die_cushion_ident {

/// A pressure set-point as the feed-forward takes it: its newest value [Pa], its rate [Pa/s] and how far
/// [s] ahead it is wanted (the valve's lag plus the set-point's own age): the pressure then is
/// pressure + rate * horizon.
struct SetpointAhead {
  double pressure = 0.0;
  double rate = 0.0;
  double horizon = 0.0;
  double ahead() const { return pressure + rate * horizon; }
};

/// The identified model turned round (paper, Fig. 19): the valve command that makes the cushion follow a
/// desired pressure trajectory at the measured motion, for the cell controller to add to its PI output.
///
/// The volume balance asks for the valve flow  Q_v* = A v - Q_extra(p_ref) - C(p_ref, x) dp_ref/dt;
/// the valve's static characteristic (the model's Q_v(y, p), with overlap and tank pressure when
/// identified) is inverted for the spool opening y by bisection (monotonic in y), and y / K_valve is the
/// voltage. Where the characteristic has a dead band (a valve overlap: no flow for |y| <= y_0) its exact
/// inverse jumps across the band as the wanted flow changes sign, 2 y_0 / K at once (0.4 V at a 2 %
/// overlap), and the inputs' noise made it chatter: inside a flow band as wide as the flow at an opening of
/// one band width beyond the overlap, the opening is interpolated across the band instead (continuous,
/// monotonic, through the band's middle at zero flow). The valve answers late (dead time plus 2 D / w0 of
/// its 2nd-order part, leadTime()): the caller passes the trajectory as it will be that far ahead (a press
/// program is known in advance; a live caller extrapolates). On the simulator that preview is what makes
/// the difference: 0.2 bar drawing error with it, 2.6 bar without. The command never leaves
/// [-max_voltage, max_voltage]; the position is taken within the stroke; a chamber whose compliance
/// (capacitance plus every dp/dt term of the outflow) is not positive at the operating point gives no
/// command (a negative one would reverse the set-point-rate term: positive feedback).
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

  /// Spool opening [-] (in [-1, 1]) that makes the model's pressure rate equal the set-point's rate (within
  /// the dead band's interpolation), x taken within the stroke; NaN (and `refusal`, if given) where the
  /// inputs are not finite, the chamber's compliance is not positive or a steeper rise would not open the
  /// valve further towards supply.
  double spoolOpening(const SetpointAhead& setpoint, double x, double v,
                      std::string* refusal = nullptr) const;
  /// The same for a set-point taken as it is (no horizon): p_ref [Pa], dp_ref [Pa/s].
  double spoolOpening(double p_ref, double dp_ref, double x, double v, std::string* refusal = nullptr) const {
    return spoolOpening(SetpointAhead{p_ref, dp_ref, 0.0}, x, v, refusal);
  }
  /// The feed-forward voltage [V] for the set-point at position x [m], velocity v [m/s], these taken
  /// leadTime() ahead; NaN, with the reason in `refusal` (may be null), where spoolOpening gives none.
  double command(const SetpointAhead& setpoint, double x, double v, std::string* refusal = nullptr) const;
  double command(double p_ref, double dp_ref, double x, double v, std::string* refusal = nullptr) const {
    return command(SetpointAhead{p_ref, dp_ref, 0.0}, x, v, refusal);
  }
  /// [s] how far ahead the trajectory should be taken: the valve's dead time plus 2 D / w0.
  double leadTime() const { return lead_; }
  /// The oil's temperature [degC] the model's oil_temperature effect reads (NaN: not measured, the
  /// parameters as they are, at the reference temperature).
  void setOilTemperature(double celsius) { oil_temperature_ = celsius; }

 private:
  /// The wanted valve flow's inverse over the characteristic at `s` (s.y is set on the way).
  double invert(double wanted, HydraulicSignals& s) const;
  /// The opening for `setpoint` without the monotonicity check; NaN with `refusal` where there is none.
  double opening(const SetpointAhead& setpoint, double x, double v, std::string* refusal) const;

  const HydraulicModel& model_;
  ParameterVector physical_;
  double valve_gain_;
  double max_voltage_;
  double lead_;
  double oil_temperature_ = std::numeric_limits<double>::quiet_NaN();
};

/// What the feed-forward accepts of the cell controller's set-point stream.
struct SetpointLimits {
  double max_age = 0.05;  ///< [s] older than this (stamp against the clock, arrival on steady time): stale
  double max_clock_offset = 0.1;  ///< [s] a stamp further ahead of the clock is not trusted
  double rate_window = 0.02;      ///< [s] the rate is the least-squares slope of the set-points this far back
  double max_rate = 2e9;          ///< [Pa/s] the rate is never taken beyond this
};

/// The pressure set-point as a cell controller streams it: the newest value and its rate, the slope over a
/// window of the recent set-points (two set-points 10 us apart gave a rate near 1e9 Pa/s and drove the
/// output to its limit), bounded, extrapolated to the time the valve will answer. NaN values and stamps that
/// do not advance are refused and counted; a stamp more than a second behind the newest restarts it (a
/// bag played again). A set-point is used only while its stamp is neither older than max_age nor further
/// than max_clock_offset ahead of the clock, and it arrived within max_age of steady time.
class PressureReference {
 public:
  enum class Push { kAccepted, kNonFinite, kNotAdvancing, kRestarted };

  explicit PressureReference(const SetpointLimits& limits = {}) : limits_(limits) {}
  Push push(double stamp, double pressure, double arrival_steady);
  /// The set-point to take `ahead` [s] of `now.clock` (its newest value, its rate, the horizon from its
  /// stamp, bounded by max_age + ahead), or nothing (the reason in `why`, if given).
  std::optional<SetpointAhead> at(Instant now, double ahead, std::string* why = nullptr) const;
  bool received() const { return !samples_.empty() || count_ > 0; }
  double newestStamp() const { return samples_.empty() ? -1e18 : samples_.back().first; }
  std::uint64_t rejected() const { return rejected_; }
  const SetpointLimits& limits() const { return limits_; }

 private:
  /// [Pa/s] the least-squares slope over the window (0 where the set-points span too little time).
  double rate() const;

  SetpointLimits limits_;
  std::deque<std::pair<double, double>> samples_;  // (stamp, pressure), newest last, at most kKept
  double arrival_ = -1e18;
  std::uint64_t count_ = 0, rejected_ = 0;
};

}  // namespace die_cushion_ident
