#include "die_cushion_ident/core/analysis/free_run_pressure.h"

#include <algorithm>
#include <cmath>

namespace die_cushion_ident {

namespace {
// RK4 substeps per grid interval. The chamber's stiffest time constant (small volume, stiff oil, valve wide
// open) is a few ms: at 1 ms substeps h*lambda stays below 0.5, where RK4's error is far under the sensors'
// noise (2 against 4 substeps changed a recording's free-run error by 1e-5 relative), at half the cost.
constexpr int kSubsteps = 2;
// Vapour pressure (gauge): the model cannot pull the chamber below it.
constexpr double kFloor = 3000.0 - kAtmosphericPressure;

bool usable(const GridSample& s) {
  return s.complete && std::isfinite(s.p) && std::isfinite(s.x) && std::isfinite(s.v) && std::isfinite(s.y);
}
}  // namespace

FreeRunPressure::FreeRunPressure(const HydraulicModel& model, double min_pressure)
    : model_(model), min_pressure_(min_pressure) {}

double FreeRunPressure::rate(const GridSample& a, const GridSample& b, double w, double p,
                             const ParameterVector& theta) const {
  HydraulicSignals s;
  s.t = a.t + w * (b.t - a.t);
  s.p = p;
  s.x = a.x + w * (b.x - a.x);
  s.v = a.v + w * (b.v - a.v);
  s.y = a.y + w * (b.y - a.y);
  s.u = a.u + w * (b.u - a.u);
  s.dp = 0.0;
  s.V = model_.chamberVolume(s.x, theta(HydraulicModel::kDeadVolume));
  return model_.pressureRate(s, theta);
}

double FreeRunPressure::step(const GridSample& s, const ParameterVector& theta) {
  anchored_this_step_ = false;
  if (!usable(s) || !usable(previous_) || s.discontinuity || !anchored_ || s.p < min_pressure_ ||
      !(s.t > previous_.t)) {
    previous_ = s;
    anchored_ = usable(s);
    anchored_this_step_ = anchored_;
    p_ = s.p;
    return pressure();
  }
  const double h = (s.t - previous_.t) / kSubsteps;
  for (int i = 0; i < kSubsteps; ++i) {
    const double w0 = static_cast<double>(i) / kSubsteps, w1 = static_cast<double>(i + 1) / kSubsteps;
    const double wm = 0.5 * (w0 + w1);
    const double k1 = rate(previous_, s, w0, p_, theta);
    const double k2 = rate(previous_, s, wm, p_ + 0.5 * h * k1, theta);
    const double k3 = rate(previous_, s, wm, p_ + 0.5 * h * k2, theta);
    const double k4 = rate(previous_, s, w1, p_ + h * k3, theta);
    p_ = std::max(p_ + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4), kFloor);
  }
  // A parameter set far from the truth (an estimator that has just started) can make the model diverge;
  // beyond twice the supply pressure it says nothing any more: start again from the measurement.
  if (!std::isfinite(p_) || p_ > 2.0 * model_.geometry().supply_pressure) {
    p_ = s.p;
    anchored_this_step_ = true;
  }
  previous_ = s;
  return p_;
}

}  // namespace die_cushion_ident
