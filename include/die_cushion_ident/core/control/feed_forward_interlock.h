#pragma once

#include <optional>
#include <string>
#include <vector>

#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/valve/servo_valve.h"

namespace die_cushion_ident {

/// What the feed-forward accepts from the live estimate and the sweeps.
struct FeedForwardInterlockLimits {
  /// [1/s] an identified parameter's fastest relative change: the live estimate's jumps (a converging RLS,
  /// a forgetting factor after a model change, ~reset, ~set_effects) reach the valve no faster than this.
  double parameter_rate = 0.5;
  /// A sweep's valve gain [1/V] is used only with the reference gain's sign and within [1/band, band] times
  /// it (the reference: the configured ~valve_gain, else the last accepted sweep's).
  double valve_gain_band = 2.0;
  /// [s] the longest lead the inverse may take the trajectory ahead (the valve's dead time plus 2 D / w0): a
  /// fitted dead time of seconds would extrapolate the set-point far beyond what it said.
  double max_lead = 0.03;
};

/// The valve models a sweep may give that the feed-forward will use: natural frequency [Hz], damping [-] and
/// dead time [s] within what servo valves on die cushions have.
struct ValveSanity {
  static constexpr double kMinNaturalFrequency = 5.0, kMaxNaturalFrequency = 2000.0;
  static constexpr double kMinDamping = 0.05, kMaxDamping = 5.0;
  static constexpr double kMaxDeadTime = 0.05;
};

/// The safety layer between the live estimate and PressureFeedForward (issues 28, 45). The feed-forward is
/// the model turned round; with a sign reversed (a valve flow gain, a bulk modulus or an air volume below
/// zero from a converging estimator, a sweep fitted to the wrong sign) it becomes positive feedback on the
/// pressure. This class
///  - refuses parameters outside their physical range by more than 3 of their stds (bulk modulus, flow gain
///    and dead volume > 0 in any case, every library effect's parameter within its range for this cushion,
///    every parameter finite), and takes one outside by less at the range's edge (an air volume estimated at
///    -2e-6 m^3 +- 3e-6 is an air volume of 0: refusing it would stop the feed-forward half the time);
///  - refuses a valve model with a gain of the wrong sign or far from the reference, or whose natural
///    frequency, damping, dead time or lead leave their sanity ranges; a sweep it accepts becomes the
///    reference (where no gain is configured), one it refuses leaves the last accepted in use;
///  - follows accepted parameters at a bounded relative rate, across a new model too (~set_effects: the
///    parameters both models share continue, a new effect's starts from 0, its absence) and a restart.
/// The chamber's compliance at the operating point is PressureFeedForward's check; the output's slew, limit
/// and hysteresis are FeedForwardOutput's.
class FeedForwardInterlock {
 public:
  /// `configured_valve_gain` [1/V]: the configured ~valve_gain, or NaN. Throws std::invalid_argument for
  /// limits that are not positive and finite (the band below 1).
  FeedForwardInterlock(const FeedForwardInterlockLimits& limits, double configured_valve_gain);

  /// "" where `physical` (of `model`, in its parameter order, with standard deviations `stds`) may drive the
  /// valve, else why not; `usable` (may be null) receives them moved into their ranges.
  std::string checkParameters(const HydraulicModel& model, const ParameterVector& physical,
                              const ParameterVector& stds, ParameterVector* usable = nullptr) const;
  /// "" where a valve model with `gain` [1/V] (and, from a sweep, its dynamics) may be inverted, else why
  /// not.
  std::string checkValve(const ServoValveParameters& valve, bool from_sweep) const;
  /// Offers a sweep's valve model: accepted (true) when checkValve passes, and then the one in use and,
  /// without a configured gain, the reference for the next; refused, the last accepted stays in use.
  bool offerSweptValve(const ServoValveParameters& valve, std::string* refusal);
  /// The valve model the inverse uses: the last accepted sweep's, else the configured gain without lag
  /// (nothing where neither exists).
  std::optional<ServoValveParameters> valve() const;
  bool valveFromSweep() const { return swept_.has_value(); }

  /// The parameters to use `dt` [s] after the last call: `identified` itself the first time, else each
  /// moved toward it by at most parameter_rate * dt of its own magnitude. A model with other parameter
  /// names continues from the parameters in use where the names match and from 0 where they are new.
  const ParameterVector& follow(const HydraulicModel& model, const ParameterVector& identified, double dt);
  const FeedForwardInterlockLimits& limits() const { return limits_; }

 private:
  FeedForwardInterlockLimits limits_;
  double configured_gain_;
  std::optional<ServoValveParameters> swept_;  // the last accepted sweep's model
  std::vector<std::string> names_;             // of parameters_, empty before the first follow()
  ParameterVector parameters_;
};

}  // namespace die_cushion_ident
