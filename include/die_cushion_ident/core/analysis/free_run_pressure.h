#pragma once

#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"

namespace die_cushion_ident {

/// The pressure a model predicts on its own: the volume balance integrated over time, driven only by the
/// measured position, velocity and spool (free run, not one step ahead). This is the error a user sees
/// when the model is used for simulation or control design; it accumulates what the one-step equation
/// error hides. Integrated by RK4 in 4 substeps per grid interval with linearly interpolated inputs.
/// The model is re-anchored to the measured pressure where it does not hold (cavitation below
/// `min_pressure`, a gap or restart of the grid, an incomplete sample) and on resync().
class FreeRunPressure {
 public:
  FreeRunPressure(const HydraulicModel& model, double min_pressure);

  /// Advances to grid sample `s` with the given physical parameters; returns the modelled pressure [Pa]
  /// (NaN while the model is not anchored).
  double step(const GridSample& s, const ParameterVector& parameters);
  void resync() { anchored_ = false; }
  double pressure() const { return anchored_ ? p_ : std::numeric_limits<double>::quiet_NaN(); }
  /// True when the last step was re-anchored (its residual is zero by construction, not a model result).
  bool anchoredThisStep() const { return anchored_this_step_; }

 private:
  double rate(const GridSample& a, const GridSample& b, double w, double p,
              const ParameterVector& theta) const;

  const HydraulicModel& model_;
  double min_pressure_;
  GridSample previous_;
  double p_ = 0.0;
  bool anchored_ = false;
  bool anchored_this_step_ = false;
};

}  // namespace die_cushion_ident
