#include "die_cushion_ident/core/valve/servo_valve.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace die_cushion_ident {

double ServoValveParameters::lowFrequencyDelay() const {
  const double omega = 2.0 * M_PI * natural_frequency;
  return std::max(0.0, (std::isfinite(dead_time) ? dead_time : 0.0) +
                           (omega > 0.0 && std::isfinite(omega) ? 2.0 * damping / omega : 0.0));
}

ServoValve::ServoValve(const ServoValveParameters& parameters, double max_step)
    : parameters_(parameters), max_step_(max_step), omega_(2.0 * M_PI * parameters.natural_frequency) {
  if (!(parameters.natural_frequency > 0.0))
    throw std::invalid_argument("valve natural_frequency must be > 0 Hz");
  if (!(parameters.damping > 0.0)) throw std::invalid_argument("valve damping must be > 0");
  if (!(parameters.dead_time >= 0.0)) throw std::invalid_argument("valve dead_time must be >= 0 s");
  if (!std::isfinite(parameters.gain)) throw std::invalid_argument("valve gain must be finite");
  if (!(parameters.max_spool_velocity > 0.0)) throw std::invalid_argument("max_spool_velocity must be > 0");
  if (!(max_step > 0.0)) throw std::invalid_argument("valve integration step must be > 0 s");
  reset();
}

ServoValve ServoValve::exact(const ServoValveParameters& parameters) {
  ServoValve valve(parameters);
  valve.exact_ = true;
  return valve;
}

// The deviation e = y - K u from the held command's steady state obeys e'' + 2 a e' + w0^2 e = 0, a = D w0:
//   e(h) = exp(-a h) [e0 C + (e0' + a e0) S / wd],   e'(h) = exp(-a h) [e0' C - (a e0' + w0^2 e0) S / wd],
// C, S = cos, sin (wd = w0 sqrt(1 - D^2), D < 1) or cosh, sinh (wd = w0 sqrt(D^2 - 1), D > 1); S / wd -> h
// and C -> 1 where critically damped.
void ServoValve::propagateLinear(double h, double u) {
  // The coefficients depend on h alone, and recorded commands come at a few intervals: a small cache of them
  // (keyed by h to the nanosecond) saves the exponential and the trigonometry of nearly every stretch.
  const long long key = std::llround(h * 1e9);
  Propagation* p = nullptr;
  for (Propagation& cached : propagations_) {
    if (cached.key == key) p = &cached;
  }
  if (!p) {
    p = &propagations_[next_propagation_];
    next_propagation_ = (next_propagation_ + 1) % kPropagations;
    const double hk = key * 1e-9;
    const double w = omega_, d2 = parameters_.damping * parameters_.damping;
    p->key = key;
    p->c = 1.0;
    p->s_over_wd = hk;
    if (std::abs(d2 - 1.0) > 1e-6) {
      const double wd = w * std::sqrt(std::abs(1.0 - d2));
      p->c = d2 < 1.0 ? std::cos(wd * hk) : std::cosh(wd * hk);
      p->s_over_wd = (d2 < 1.0 ? std::sin(wd * hk) : std::sinh(wd * hk)) / wd;
    }
    p->decay = std::exp(-parameters_.damping * omega_ * hk);
  }
  const double w = omega_, a = parameters_.damping * omega_;
  const double e0 = y_ - parameters_.gain * u, de0 = y_dot_;
  const double e = p->decay * (e0 * p->c + (de0 + a * e0) * p->s_over_wd);
  const double de = p->decay * (de0 * p->c - (a * de0 + w * w * e0) * p->s_over_wd);
  // The equation itself integrated over the stretch: [e'] + 2 a [e] + w0^2 int e = 0.
  integral_ +=
      parameters_.gain * u * static_cast<double>(key) * 1e-9 - (de - de0 + 2.0 * a * (e - e0)) / (w * w);
  y_dot_ = de;
  y_ = e + parameters_.gain * u;
  if (std::abs(y_) >= 1.0) {  // against the mechanical stop
    y_ = std::clamp(y_, -1.0, 1.0);
    if (y_ * y_dot_ > 0.0) y_dot_ = 0.0;
  }
}

void ServoValve::reset(double position) {
  time_ = 0.0;
  y_ = position;
  y_dot_ = 0.0;
  integral_ = 0.0;
  commands_.clear();
  commands_.emplace_back(-std::numeric_limits<double>::infinity(),
                         parameters_.gain != 0.0 ? position / parameters_.gain : 0.0);
}

double ServoValve::delayedCommand(double t) {
  const double seen = t - parameters_.dead_time;
  while (commands_.size() >= 2 && commands_[1].first <= seen) commands_.pop_front();
  return commands_.front().second;
}

void ServoValve::integrate(double h, double u) {
  const double w2 = omega_ * omega_;
  const double two_d_w = 2.0 * parameters_.damping * omega_;
  const double target = parameters_.gain * u;
  const double vmax = parameters_.max_spool_velocity;
  // The speed limit acts inside the derivative, so that the position can never move faster than allowed.
  auto speed = [&](double yd) { return std::clamp(yd, -vmax, vmax); };
  auto accel = [&](double y, double yd) { return w2 * (target - y) - two_d_w * yd; };
  const double k1y = speed(y_dot_), k1v = accel(y_, y_dot_);
  const double v2 = y_dot_ + 0.5 * h * k1v, k2y = speed(v2), k2v = accel(y_ + 0.5 * h * k1y, v2);
  const double v3 = y_dot_ + 0.5 * h * k2v, k3y = speed(v3), k3v = accel(y_ + 0.5 * h * k2y, v3);
  const double v4 = y_dot_ + h * k3v, k4y = speed(v4), k4v = accel(y_ + h * k3y, v4);
  // The integral as a third state (its rate is y): RK4's weights on the stages' positions, each held at the
  // mechanical stop as the position is (unclamped, a spool pinned at the stop averaged up to 1.0055).
  const auto stopped = [](double y) { return std::clamp(y, -1.0, 1.0); };
  integral_ += h / 6.0 *
               (stopped(y_) + 2.0 * stopped(y_ + 0.5 * h * k1y) + 2.0 * stopped(y_ + 0.5 * h * k2y) +
                stopped(y_ + h * k3y));
  y_ += h / 6.0 * (k1y + 2 * k2y + 2 * k3y + k4y);
  y_dot_ = speed(y_dot_ + h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v));
  if (std::abs(y_) >= 1.0) {  // against the mechanical stop
    y_ = std::clamp(y_, -1.0, 1.0);
    if (y_ * y_dot_ > 0.0) y_dot_ = 0.0;
  }
}

double ServoValve::advance(double dt, double command_voltage) {
  if (!(dt > 0.0)) return y_;
  if (std::isfinite(command_voltage)) commands_.emplace_back(time_, command_voltage);
  const double end = time_ + dt;
  while (time_ < end) {
    // Steps end exactly where the delayed command switches, so the dead time is not rounded to a step.
    const double u = delayedCommand(time_ + 1e-12);
    double stop = exact_ ? end : std::min(end, time_ + max_step_);
    if (commands_.size() >= 2) stop = std::min(stop, commands_[1].first + parameters_.dead_time);
    if (!(stop > time_)) stop = exact_ ? end : std::min(end, time_ + max_step_);
    if (exact_) {
      propagateExactly(stop - time_, u);
    } else {
      integrate(stop - time_, u);
    }
    time_ = stop;
  }
  return y_;
}

void ServoValve::propagateExactly(double h, double u) {
  // The closed form knows neither the mechanical stop nor the speed limit. Where the stretch comes near
  // either, it is integrated in small steps like the plant's own valve, which saturates inside the step.
  const double y0 = y_, yd0 = y_dot_, integral0 = integral_;
  propagateLinear(h, u);
  const double vmax = parameters_.max_spool_velocity;
  const bool saturates = std::abs(y_) >= 1.0 || std::abs(y_dot_) > vmax ||
                         std::abs(parameters_.gain * u) >= 1.0 || std::abs(yd0) >= vmax;
  if (!saturates) return;
  y_ = y0;
  y_dot_ = yd0;
  integral_ = integral0;
  for (double done = 0.0; done < h;) {
    const double step = std::min(max_step_, h - done);
    integrate(step, u);
    done += step;
  }
}

SampledServoValve::SampledServoValve(const ServoValveParameters& p, double sample_period) {
  const double w = 2.0 * M_PI * p.natural_frequency;
  // s = c (z - 1) / (z + 1), c prewarped so that the natural frequency maps exactly.
  const double c = w / std::tan(0.5 * w * sample_period);
  const double a0 = c * c + 2.0 * p.damping * w * c + w * w;
  b_ = p.gain * w * w / a0;
  a1_ = (2.0 * w * w - 2.0 * c * c) / a0;
  a2_ = (c * c - 2.0 * p.damping * w * c + w * w) / a0;
  gain_ = p.gain;
  delay_ = std::clamp(static_cast<int>(std::lround(p.dead_time / sample_period)), 0, kMaxDelay);
}

void SampledServoValve::reset(double position) {
  const double u = gain_ != 0.0 ? position / gain_ : 0.0;
  std::fill(std::begin(commands_), std::end(commands_), u);
  y1_ = y2_ = position;
}

double SampledServoValve::step(double command_voltage) {
  // A ring of the recent commands, newest at newest_: the one `delay_` samples back and the two before it.
  newest_ = (newest_ + kRing - 1) % kRing;
  commands_[newest_] = command_voltage;
  const auto back = [&](int k) { return commands_[(newest_ + delay_ + k) % kRing]; };
  const double y = b_ * (back(0) + 2.0 * back(1) + back(2)) - a1_ * y1_ - a2_ * y2_;
  y2_ = y1_;
  y1_ = y;
  return y;
}

}  // namespace die_cushion_ident
