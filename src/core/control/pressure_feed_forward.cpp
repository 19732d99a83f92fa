#include "die_cushion_ident/core/control/pressure_feed_forward.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "die_cushion_ident/core/util/formatted.h"

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

double PressureFeedForward::invert(double wanted, HydraulicSignals& s) const {
  const auto flow = [&](double y) {
    s.y = y;
    return model_.valveFlow(s, physical_);
  };
  const auto exact = [&](double q) {
    double lo = -1.0, hi = 1.0;
    if (q <= flow(lo)) return lo;
    if (q >= flow(hi)) return hi;
    for (int i = 0; i < 50; ++i) {  // the valve flow rises with the opening: bisection to 1e-15
      const double mid = 0.5 * (lo + hi);
      (flow(mid) < q ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  };
  // The dead band around y = 0: where the first opening in each direction passes flow of that direction.
  const auto edge = [&](double direction) {
    if (!(direction * flow(direction) > 0.0)) return direction;  // no flow that way at all
    double closed = 0.0, open = 1.0;
    for (int i = 0; i < 50; ++i) {
      const double mid = 0.5 * (closed + open);
      (direction * flow(direction * mid) > 0.0 ? open : closed) = mid;
    }
    return direction * open;
  };
  const double y_plus = edge(1.0), y_minus = edge(-1.0);
  const double width = 0.5 * (y_plus - y_minus);
  if (!(width > 1e-9)) return exact(wanted);
  const double y_hi = std::min(y_plus + width, 1.0), y_lo = std::max(y_minus - width, -1.0);
  const double q_hi = flow(y_hi), q_lo = flow(y_lo);
  if (!(q_hi > 0.0) || !(q_lo < 0.0) || wanted >= q_hi || wanted <= q_lo) return exact(wanted);
  // Linear on each side of zero flow, which stays at the band's middle (a centred spool passes nothing).
  const double y_zero = 0.5 * (y_plus + y_minus);
  return wanted >= 0.0 ? y_zero + (y_hi - y_zero) * wanted / q_hi : y_zero + (y_lo - y_zero) * wanted / q_lo;
}

double PressureFeedForward::opening(const SetpointAhead& setpoint, double x, double v,
                                    std::string* refusal) const {
  const auto refuse = [&](const std::string& why) {
    if (refusal) *refusal = why;
    return std::numeric_limits<double>::quiet_NaN();
  };
  const double p_ahead = setpoint.ahead(), rate = setpoint.rate;
  if (!(std::isfinite(p_ahead) && std::isfinite(setpoint.pressure) && std::isfinite(x) && std::isfinite(v))) {
    return refuse("the set-point, its rate or the cushion's position or velocity is not finite");
  }
  HydraulicSignals s;
  s.x = std::clamp(x, 0.0, model_.geometry().stroke_length);  // a preview beyond the stroke is not a chamber
  s.v = v;
  s.T = oil_temperature_;
  s.V = model_.chamberVolume(s.x, physical_(HydraulicModel::kDeadVolume));
  // The compliance the rate meets, at the set-point's newest value: the capacitance plus what every outflow
  // term in dp/dt adds (a custom p*dp term is a compressibility), as the secant of those terms up to the
  // rate. Not positive, the rate's term would turn round.
  HydraulicSignals now = s, resting = s;
  now.p = resting.p = setpoint.pressure;
  now.dp = rate;
  resting.dp = 0.0;
  const double capacitance = model_.capacitance(now, physical_);
  const double h = std::max(1e5, 1e-3 * std::abs(rate));
  HydraulicSignals above = now, below = now;
  above.dp = rate + h;
  below.dp = rate - h;
  const double compliance =
      capacitance +
      (model_.extraOutflow(above, physical_) - model_.extraOutflow(below, physical_)) / (2.0 * h);
  if (!(compliance > 0.0) || !std::isfinite(compliance)) {
    return refuse(formatted(FMT_STRING("the chamber's compliance at {:.1f} bar"), setpoint.pressure * 1e-5) +
                  formatted(FMT_STRING(" and x = {:.3f} m is "), s.x) +
                  formatted(FMT_STRING("{:.3g} m^3/Pa"), compliance) +
                  ", not positive: the set-point's rate would act the wrong way");
  }
  const double rate_flow =
      capacitance * rate + model_.extraOutflow(now, physical_) - model_.extraOutflow(resting, physical_);
  // The flows that do not depend on the rate, at the pressure the valve will meet.
  s.p = p_ahead;
  s.dp = 0.0;
  const double wanted = model_.geometry().piston_area * v - model_.extraOutflow(s, physical_) - rate_flow;
  if (!std::isfinite(wanted)) return refuse("the model's flows are not finite at the set-point");
  return invert(wanted, s);
}

double PressureFeedForward::spoolOpening(const SetpointAhead& setpoint, double x, double v,
                                         std::string* refusal) const {
  const double y = opening(setpoint, x, v, refusal);
  if (!std::isfinite(y)) return y;
  // The answer to a slightly steeper rise: never further towards the drain (positive feedback on the
  // set-point). The library's effects cannot turn it round; a custom term may.
  SetpointAhead steeper = setpoint;
  steeper.rate += std::max(1e5, 1e-3 * std::abs(setpoint.rate));
  const double y_steeper = opening(steeper, x, v, nullptr);
  if (!(y_steeper <= y + 1e-12)) {
    if (refusal) {
      *refusal =
          formatted(FMT_STRING("the model's inverse turns round at {:.1f} bar"), setpoint.pressure * 1e-5) +
          formatted(FMT_STRING(" and {:.3g} Pa/s: a steeper rise would open the valve towards the drain"),
                    setpoint.rate);
    }
    return std::numeric_limits<double>::quiet_NaN();
  }
  return y;
}

double PressureFeedForward::command(const SetpointAhead& setpoint, double x, double v,
                                    std::string* refusal) const {
  const double y = spoolOpening(setpoint, x, v, refusal);
  if (!std::isfinite(y)) return y;
  return std::clamp(y / valve_gain_, -max_voltage_, max_voltage_);
}

namespace {
constexpr std::size_t kKept = 256;    // set-points kept for the rate's window
constexpr double kRestartJump = 1.0;  // [s] a stamp this far behind the newest: the stream started again
}  // namespace

PressureReference::Push PressureReference::push(double stamp, double pressure, double arrival_steady) {
  if (!std::isfinite(stamp) || !std::isfinite(pressure)) {
    ++rejected_;
    return Push::kNonFinite;
  }
  Push result = Push::kAccepted;
  if (!samples_.empty() && stamp < samples_.back().first - kRestartJump) {
    samples_.clear();
    result = Push::kRestarted;
  } else if (!samples_.empty() && !(stamp > samples_.back().first)) {
    ++rejected_;
    return Push::kNotAdvancing;
  }
  samples_.emplace_back(stamp, pressure);
  if (samples_.size() > kKept) samples_.pop_front();
  arrival_ = arrival_steady;
  ++count_;
  return result;
}

double PressureReference::rate() const {
  // The set-points of the window, and older ones until they span half of it (a slow stream).
  const double newest = samples_.back().first;
  std::size_t first = samples_.size() - 1;
  while (first > 0 && (samples_[first - 1].first >= newest - limits_.rate_window ||
                       newest - samples_[first].first < 0.5 * limits_.rate_window)) {
    --first;
  }
  const double span = newest - samples_[first].first;
  if (!(span >= 0.1 * limits_.rate_window)) return 0.0;  // too short to tell a rate from the noise
  double mean_t = 0.0, mean_p = 0.0;
  const double n = static_cast<double>(samples_.size() - first);
  for (std::size_t i = first; i < samples_.size(); ++i) {
    mean_t += (samples_[i].first - newest) / n;
    mean_p += samples_[i].second / n;
  }
  double stt = 0.0, stp = 0.0;
  for (std::size_t i = first; i < samples_.size(); ++i) {
    const double dt = samples_[i].first - newest - mean_t;
    stt += dt * dt;
    stp += dt * (samples_[i].second - mean_p);
  }
  return std::clamp(stp / stt, -limits_.max_rate, limits_.max_rate);
}

std::optional<SetpointAhead> PressureReference::at(Instant now, double ahead, std::string* why) const {
  const auto stale = [&](const std::string& reason) -> std::optional<SetpointAhead> {
    if (why) *why = reason;
    return std::nullopt;
  };
  if (samples_.empty()) return stale("no pressure_setpoint received yet");
  const double t1 = samples_.back().first, p1 = samples_.back().second;
  const double age = now.clock - t1, silent = now.steady - arrival_;
  if (!(age <= limits_.max_age)) {
    return stale(
        formatted(FMT_STRING("pressure_setpoint is stale (stamped {:.3f} s before the clock, "), age) +
        formatted(FMT_STRING("allowed {:.3f} s)"), limits_.max_age));
  }
  if (!(silent <= limits_.max_age)) {
    return stale(
        formatted(FMT_STRING("pressure_setpoint is lost (none arrived for {:.0f} ms, "), silent * 1e3) +
        formatted(FMT_STRING("allowed {:.0f} ms)"), limits_.max_age * 1e3));
  }
  if (!(age >= -limits_.max_clock_offset)) {
    return stale(
        formatted(FMT_STRING("pressure_setpoint is stamped {:.3f} s ahead of the clock (tolerance "), -age) +
        formatted(FMT_STRING("{:.3f} s): its clock is not the node's"), limits_.max_clock_offset));
  }
  // Extrapolated over the valve's lag and the set-point's own age, never further.
  return SetpointAhead{p1, rate(), std::clamp(now.clock + ahead - t1, 0.0, limits_.max_age + ahead)};
}

}  // namespace die_cushion_ident
