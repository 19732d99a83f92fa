#include "die_cushion_ident/core/control/pressure_feed_forward.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace die_cushion_ident {

PressureFeedForward::PressureFeedForward(const HydraulicModel& model, const ParameterVector& physical,
                                         const ServoValveParameters& valve, double max_voltage)
    : model_(model), valve_gain_(valve.gain), max_voltage_(max_voltage) {
  setParameters(physical);
  if (!(std::abs(valve.gain) > 0.0) || !std::isfinite(valve.gain)) {
    throw std::invalid_argument("feed-forward: the valve gain must be finite and non-zero [1/V]");
  }
  if (!(max_voltage > 0.0) || !std::isfinite(max_voltage)) {
    throw std::invalid_argument("feed-forward: the voltage limit must be > 0 V");
  }
  lead_ = valve.lowFrequencyDelay();
}

void PressureFeedForward::setParameters(const ParameterVector& physical) {
  if (physical.size() != model_.parameterCount() || !physical.allFinite() ||
      !(physical(HydraulicModel::kBulkModulus) > 0.0)) {
    throw std::invalid_argument("feed-forward: the parameters do not fit the model (or are not finite)");
  }
  physical_ = physical;
}

double PressureFeedForward::spoolOpening(double p_ref, double dp_ref, double x, double v) const {
  HydraulicSignals s;
  s.p = p_ref;
  s.x = x;
  s.v = v;
  s.dp = dp_ref;
  s.V = model_.chamberVolume(x, physical_(HydraulicModel::kDeadVolume));
  const double wanted = model_.geometry().piston_area * v - model_.extraOutflow(s, physical_) -
                        model_.capacitance(s, physical_) * dp_ref;
  const auto flow = [&](double y) {
    s.y = y;
    return model_.valveFlow(s, physical_);
  };
  double lo = -1.0, hi = 1.0;
  if (wanted <= flow(lo)) return lo;
  if (wanted >= flow(hi)) return hi;
  for (int i = 0; i < 50; ++i) {  // the valve flow rises with the opening: bisection to 1e-15
    const double mid = 0.5 * (lo + hi);
    (flow(mid) < wanted ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double PressureFeedForward::command(double p_ref, double dp_ref, double x, double v, bool* valid) const {
  const bool finite = std::isfinite(p_ref) && std::isfinite(dp_ref) && std::isfinite(x) && std::isfinite(v);
  if (valid) *valid = finite;
  if (!finite) return 0.0;
  const double y = spoolOpening(p_ref, dp_ref, x, v);
  return std::clamp(y / valve_gain_, -max_voltage_, max_voltage_);
}

PressureReference::Push PressureReference::push(double stamp, double pressure) {
  if (!std::isfinite(stamp) || !std::isfinite(pressure)) {
    ++rejected_;
    return Push::kNonFinite;
  }
  if (count_ > 0 && !(stamp > t1_)) {
    ++rejected_;
    return Push::kNotAdvancing;
  }
  t0_ = t1_;
  p0_ = p1_;
  t1_ = stamp;
  p1_ = pressure;
  ++count_;
  return Push::kAccepted;
}

std::optional<std::pair<double, double>> PressureReference::at(double now, double ahead, double max_age) const {
  if (count_ == 0 || !(now - t1_ <= max_age)) return std::nullopt;
  const double rate = count_ >= 2 ? (p1_ - p0_) / (t1_ - t0_) : 0.0;
  return std::make_pair(p1_ + rate * (now + ahead - t1_), rate);
}

}  // namespace die_cushion_ident
