#pragma once

#include <cstdint>
#include <limits>

#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"

namespace die_cushion_ident {

/// Catmull-Rom between a and b at w in [0, 1], with the outer points before and after (the secant where one
/// is NaN): C1, exact for quadratics. The free run's interpolation of its inputs between grid samples.
double catmullRom(double before, double a, double b, double after, double w);

/// catmullRom's cubic over one interval, its coefficients computed once for the free run's six or seven
/// stages there (the same arithmetic: the same values).
struct CatmullRomCubic {
  CatmullRomCubic(double before, double a, double b, double after);
  double at(double w) const { return a + w * (ta + w * (square + w * cube)); }
  /// d/dw of at(w): the channel's change per span.
  double slope(double w) const { return ta + w * (2.0 * square + 3.0 * w * cube); }
  double a, ta, square, cube;
};

/// The pressure a model predicts on its own: the volume balance
///
///   dp/dt = f(t, p) = (A v(t) - Q_v(y(t), p) - Q_extra(p, ...)) / C(p, x(t))
///
/// integrated over time, driven only by the measured position x, velocity v (x's own slope where v is
/// derived from it) and the spool y (the valve
/// model's, GridSample::y_model, where there is one: it carries none of the spool sensor's noise; between
/// grid samples with its exact mean over the interval, GridSample::y_model_mean). This is
/// the error a user sees when the model is used for simulation or control design; it accumulates what the
/// one-step equation error hides.
///
/// Its own error is held far below the sensors' noise (doc/equations.md, "The free run"):
///  - the inputs between grid samples are cubic (Catmull-Rom through the two samples each side, C1, exact
///    for quadratics), not linear: a 4 ms impact seen on a 1 ms grid left 0.5 bar with linear inputs;
///  - a velocity derived from the position (GridSample::velocity_derived) is not read: v is the slope of the
///    position's own cubic, so the volume swept over each interval is the position's change. The derived
///    samples are least-squares slopes over the velocity window, a mean of the motion over 2-4 ms; read
///    between samples they spread the impact's compression over the window's neighbours, and the refined
///    bulk modulus came out 2.4-4.9 % low on fast presses, 0.6-1.2 % on small stiff ones and 0.4-0.9 % on
///    slow ones (12 recordings, 2026-12-07; with a valve overlap, mean z -1.34 over 30 calibration ones);
///  - the ODE is integrated under step-size control to `tolerance` [Pa] per step: by Dormand-Prince 5(4)
///    (about one step a grid interval), and where the chamber is stiff (h |df/dp| beyond its stability
///    limit: a small chamber behind a wide-open valve has time constants below 0.5 ms) by ROS2 (Verwer et al.
///    1999), an L-stable Rosenbrock method of order 2, stable at any step. Boost.Odeint's rosenbrock4 was
///    weighed: 2.4 us a step on this scalar problem against about 0.1 us here, and the ranking integrates the
///    recording some twenty times; ROS2 alone needed 9-17 steps a 1 ms interval for 20 Pa.
/// The model is re-anchored to the measured pressure where it does not hold (cavitation below
/// `min_pressure`, a gap or restart of the grid, an incomplete sample) and on resync(). Whether the pressure
/// is below `min_pressure` is read where no noise it would select lies: neither in the sample whose error
/// it lets count nor in the anchor the run started from. So a run starts when the sample before its anchor
/// was above the bar, and goes on while the sample before the current one is. Decided by the current
/// sample, a run started from the last sample measured below the bar, on a slow crossing the one whose
/// noise had pulled it down (0.2 bar of noise left entrained air 2.6 % low on small stiff presses, 13 % at
/// 0.6 bar, about 0 at 0.01 bar; doc/resolution.md "The free run"); decided two samples back throughout, a
/// run went on only where its anchor was high. This holds where neighbouring grid samples carry independent
/// noise; where they are interpolated from the same pressure message (a grid between or finer than the
/// messages) some selection is left, and a restart's pressure (restartAt) both starts and decides its run.
class FreeRunPressure {
 public:
  /// [Pa] local error allowed per integration step; the default keeps the free run's own error about a
  /// thousandth of a 0.2 bar sensor noise.
  static constexpr double kDefaultTolerance = 20.0;
  FreeRunPressure(const HydraulicModel& model, double min_pressure, double tolerance = kDefaultTolerance);

  /// Advances to grid sample `s` with the given physical parameters; returns the modelled pressure [Pa]
  /// (NaN while the model is not anchored). `next` (may be null: the newest sample live) is the sample
  /// after `s`, for the inputs' cubic interpolation up to `s`.
  double step(const GridSample& s, const ParameterVector& parameters, const GridSample* next = nullptr);
  void resync() { anchored_ = false; }
  /// Starts again at the next step from `pressure` [Pa] (a measurement averaged over a few samples, say)
  /// instead of that step's own measured pressure.
  void restartAt(double pressure) {
    anchored_ = false;
    restart_pressure_ = pressure;
  }
  double pressure() const { return anchored_ ? p_ : std::numeric_limits<double>::quiet_NaN(); }
  /// True when the last step was re-anchored (its residual is zero by construction, not a model result).
  bool anchoredThisStep() const { return anchored_this_step_; }
  /// Integration steps taken and rejected by the error control so far.
  std::uint64_t steps() const { return steps_; }
  std::uint64_t rejectedSteps() const { return rejected_; }
  /// Of the steps, those taken by the stiff integrator.
  std::uint64_t stiffSteps() const { return stiff_steps_; }

  /// The spool that drives the free run at a sample: the valve model's where there is one, else measured.
  static double spoolOf(const GridSample& s) { return std::isfinite(s.y_model) ? s.y_model : s.y; }

 private:
  /// The inputs at w in [0, 1] between a and b by Catmull-Rom (its outer points: before, after).
  struct Span {
    Span(const GridSample* before, const GridSample* a, const GridSample* b, const GridSample* after);
    const GridSample* before;
    const GridSample* a;
    const GridSample* b;
    const GridSample* after;
    CatmullRomCubic x, v, y;  ///< position, velocity and spool between a and b
  };
  static CatmullRomCubic spoolCubic(const GridSample* before, const GridSample* a, const GridSample* b,
                                    const GridSample* after);
  double rate(const Span& span, double w, double p, const ParameterVector& theta) const;
  void integrate(const Span& span, const ParameterVector& theta);
  /// Dormand-Prince 5(4) from w on; false where it fails (non-finite). Stops early where the chamber is stiff.
  bool integrateExplicitly(const Span& span, const ParameterVector& theta, double* w);
  /// ROS2 from w to the end of the span.
  void integrateStiffly(const Span& span, const ParameterVector& theta, double* w);

  const HydraulicModel& model_;
  double min_pressure_;
  double tolerance_;
  GridSample before_previous_, previous_;
  bool have_before_previous_ = false;
  /// [Pa] the measured pressure one and two samples back in this stretch (NaN before it has them): what
  /// decides whether the chamber is below min_pressure.
  double measured_back_[2] = {std::numeric_limits<double>::quiet_NaN(),
                              std::numeric_limits<double>::quiet_NaN()};
  double p_ = 0.0;
  double restart_pressure_ = std::numeric_limits<double>::quiet_NaN();
  double h_ = 0.0;  // [s] the step the error control proposes next
  bool anchored_ = false;
  bool anchored_this_step_ = false;
  std::uint64_t steps_ = 0, rejected_ = 0, stiff_steps_ = 0;
  static constexpr int kStiffMemory = 16;
  int stiff_intervals_ = 0;  // intervals in a row that needed the stiff integrator
};

}  // namespace die_cushion_ident
