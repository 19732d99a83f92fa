#include "die_cushion_ident/core/fits/free_run_pressure.h"

#include <algorithm>
#include <cmath>

namespace die_cushion_ident {

namespace {
// Vapour pressure (gauge): the model cannot pull the chamber below it.
constexpr double kFloor = 3000.0 - kAtmosphericPressure;
// ROS2's gamma = 1 + 1/sqrt(2): L-stable.
constexpr double kGamma = 1.7071067811865475;

bool usable(const GridSample& s) {
  return s.complete && std::isfinite(s.p) && std::isfinite(s.x) && std::isfinite(s.v) &&
         std::isfinite(FreeRunPressure::spoolOf(s));
}

}  // namespace

double catmullRom(double before, double a, double b, double after, double w) {
  return CatmullRomCubic(before, a, b, after).at(w);
}

CatmullRomCubic::CatmullRomCubic(double before, double a_, double b, double after) : a(a_) {
  const double secant = b - a;
  ta = std::isfinite(before) ? 0.5 * (b - before) : secant;
  const double tb = std::isfinite(after) ? 0.5 * (after - a) : secant;
  square = 3.0 * secant - 2.0 * ta - tb;
  cube = ta + tb - 2.0 * secant;
}

namespace {
// A channel's cubic over the span from a to b (NaN neighbours where there are none).
template <typename Get>
CatmullRomCubic cubicOf(const GridSample* before, const GridSample* a, const GridSample* b,
                        const GridSample* after, Get get) {
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  return CatmullRomCubic(before ? get(*before) : kNone, get(*a), get(*b), after ? get(*after) : kNone);
}
}  // namespace

FreeRunPressure::Span::Span(const GridSample* before_, const GridSample* a_, const GridSample* b_,
                            const GridSample* after_)
    : before(before_),
      a(a_),
      b(b_),
      after(after_),
      x(cubicOf(before_, a_, b_, after_, [](const GridSample& g) { return static_cast<double>(g.x); })),
      v(cubicOf(before_, a_, b_, after_, [](const GridSample& g) { return static_cast<double>(g.v); })),
      y(spoolCubic(before_, a_, b_, after_)) {}

// The valve model's spool between grid samples keeps its exact mean over the interval: Catmull-Rom through
// the samples plus k w (1 - w), whose integral k / 6 makes up the difference. The spool answers each command
// after the dead time, inside an interval, with a kink in its curvature that no curve through the samples
// follows (nor one through their exact slopes: tried); at a fast press's 4 ms impact, with the valve
// answering at 150-250 Hz, Catmull-Rom alone left the free run's optimum 1-2 % low in the bulk modulus and
// 3-6 % in the dead volume on a clean plant; with the mean 0.1 and 0.3 % (doc/equations.md, "The free run's
// spool between samples").
CatmullRomCubic FreeRunPressure::spoolCubic(const GridSample* before, const GridSample* a,
                                            const GridSample* b, const GridSample* after) {
  CatmullRomCubic cubic = cubicOf(before, a, b, after, [](const GridSample& g) { return spoolOf(g); });
  // The mean is over one grid period before b: not for a span that is longer (a grid thinned or jumped
  // without a discontinuity), judged by the span before it.
  const bool one_period = !before || std::abs((b->t - a->t) - (a->t - before->t)) <= 1e-3 * (b->t - a->t);
  if (one_period && std::isfinite(a->y_model) && std::isfinite(b->y_model) &&
      std::isfinite(b->y_model_mean)) {
    const double integral = cubic.a + cubic.ta / 2.0 + cubic.square / 3.0 + cubic.cube / 4.0;
    const double k = 6.0 * (b->y_model_mean - integral);
    cubic.ta += k;
    cubic.square -= k;
  }
  return cubic;
}

FreeRunPressure::FreeRunPressure(const HydraulicModel& model, double min_pressure, double tolerance)
    : model_(model), min_pressure_(min_pressure), tolerance_(tolerance > 0.0 ? tolerance : kDefaultTolerance) {}

double FreeRunPressure::rate(const Span& span, double w, double p, const ParameterVector& theta) const {
  HydraulicSignals s;
  s.t = span.a->t + w * (span.b->t - span.a->t);
  s.p = p;
  s.x = span.x.at(w);
  // Where either end's velocity is derived, the position's slope (FreeRunPressure's class comment).
  s.v = span.a->velocity_derived || span.b->velocity_derived ? span.x.slope(w) / (span.b->t - span.a->t)
                                                             : span.v.at(w);
  s.y = span.y.at(w);
  s.u = span.a->u + w * (span.b->u - span.a->u);
  s.T = span.a->T + w * (span.b->T - span.a->T);
  s.dp = 0.0;
  s.V = model_.chamberVolume(s.x, theta(HydraulicModel::kDeadVolume));
  return model_.pressureRate(s, theta);
}

// Dormand-Prince 5(4) with its embedded 4th-order error estimate and first-same-as-last: about one step of
// six evaluations per grid interval where the chamber is not stiff. Where it is (h |df/dp| beyond the method's
// stability limit of 3.3, Hairer's estimate from the last two stages), the rest of the interval is taken by
// ROS2, which is stable at any step.
bool FreeRunPressure::integrateExplicitly(const Span& span, const ParameterVector& theta, double* w) {
  static constexpr double c2 = 1.0 / 5, c3 = 3.0 / 10, c4 = 4.0 / 5, c5 = 8.0 / 9;
  static constexpr double a21 = 1.0 / 5;
  static constexpr double a31 = 3.0 / 40, a32 = 9.0 / 40;
  static constexpr double a41 = 44.0 / 45, a42 = -56.0 / 15, a43 = 32.0 / 9;
  static constexpr double a51 = 19372.0 / 6561, a52 = -25360.0 / 2187, a53 = 64448.0 / 6561, a54 = -212.0 / 729;
  static constexpr double a61 = 9017.0 / 3168, a62 = -355.0 / 33, a63 = 46732.0 / 5247, a64 = 49.0 / 176,
                          a65 = -5103.0 / 18656;
  static constexpr double b1 = 35.0 / 384, b3 = 500.0 / 1113, b4 = 125.0 / 192, b5 = -2187.0 / 6784, b6 = 11.0 / 84;
  static constexpr double e1 = 71.0 / 57600, e3 = -71.0 / 16695, e4 = 71.0 / 1920, e5 = -17253.0 / 339200,
                          e6 = 22.0 / 525, e7 = -1.0 / 40;
  const double interval = span.b->t - span.a->t;
  double k1 = rate(span, *w, p_, theta);
  int rejections = 0;
  while (*w < 1.0) {
    // A step cut short by the interval's end does not shrink the next one.
    const bool last = h_ >= (1.0 - *w) * interval * (1.0 - 1e-9);
    const double h = last ? (1.0 - *w) * interval : h_;
    const double dw = h / interval;
    const double k2 = rate(span, *w + c2 * dw, p_ + h * a21 * k1, theta);
    const double k3 = rate(span, *w + c3 * dw, p_ + h * (a31 * k1 + a32 * k2), theta);
    const double k4 = rate(span, *w + c4 * dw, p_ + h * (a41 * k1 + a42 * k2 + a43 * k3), theta);
    const double k5 = rate(span, *w + c5 * dw, p_ + h * (a51 * k1 + a52 * k2 + a53 * k3 + a54 * k4), theta);
    const double p6 = p_ + h * (a61 * k1 + a62 * k2 + a63 * k3 + a64 * k4 + a65 * k5);
    const double k6 = rate(span, *w + dw, p6, theta);
    const double next = p_ + h * (b1 * k1 + b3 * k3 + b4 * k4 + b5 * k5 + b6 * k6);
    const double k7 = rate(span, *w + dw, next, theta);
    const double error = std::abs(h * (e1 * k1 + e3 * k3 + e4 * k4 + e5 * k5 + e6 * k6 + e7 * k7));
    if (!std::isfinite(next) || !std::isfinite(error)) return false;
    const double allowed = tolerance_ + 1e-7 * std::abs(p_);
    // pow only where the clamp does not decide (0.9 ratio^0.2 beyond 5 above 5300, below 0.2 under 5e-4): one
    // pow per step was 7 % of an analysis.
    const double ratio = allowed / std::max(error, 1e-300);
    const double factor = ratio >= 5300.0 ? 5.0
                          : ratio <= 5e-4 ? 0.2
                                          : std::clamp(0.9 * std::pow(ratio, 0.2), 0.2, 5.0);
    if (error <= allowed) {
      p_ = std::max(next, kFloor);
      *w = last ? 1.0 : *w + dw;
      ++steps_;
      h_ = std::min(last ? std::max(h_, h * factor) : h * factor, interval);
      // An error estimate that does not fall with the step (a kink of the model in p: the vapour floor, a
      // port switching) would shrink the step without end: the stiff integrator takes over from there.
      if (h_ < interval / 16.0 && *w < 1.0) return true;
      if (!last) k1 = p_ == next ? k7 : rate(span, *w, p_, theta);
      continue;
    }
    ++rejected_;
    // Stiff where h times the rate's slope in p exceeds the method's stability limit on the real axis (the
    // slope from the last two stages, both at the step's end).
    const double slope = std::abs(next - p6) > 1e-9 * std::max(std::abs(p_), 1e5) ? std::abs((k7 - k6) / (next - p6)) : 0.0;
    if (h * slope > 3.25 || ++rejections > 3) {
      h_ = std::min(h * factor, 3.0 / std::max(slope, 1e-30));
      return true;  // the rest of the interval is the stiff integrator's
    }
    h_ = h * factor;
  }
  return true;
}

// ROS2 in the autonomous form (time as a state: its Jacobian column is f_t):
//   W = 1 - gamma h J,  W k1 = f(t, p) + gamma h f_t,  W k2 = f(t + h, p + h k1) - 2 k1 - gamma h f_t,
//   p+ = p + h (3 k1 + k2) / 2;  the order-1 solution p + h k1 differs by h (k1 + k2) / 2: the error estimate.
// ROS2 keeps order 2 with any approximation of J (a W-method), so J is a finite difference.
void FreeRunPressure::integrateStiffly(const Span& span, const ParameterVector& theta, double* w) {
  const double interval = span.b->t - span.a->t;
  // Not below an eighth of the interval: where the model is that far from smooth (a pressure at the vapour
  // floor under a wide-open valve, a fit far from physics) ROS2 stays stable, and a smaller step buys nothing.
  // (A last step a rounding error longer than it is taken as it: it must not be refused without end.)
  const double smallest = interval / 8.0;
  while (*w < 1.0) {
    const bool last = h_ >= (1.0 - *w) * interval * (1.0 - 1e-9);
    const double h = last ? (1.0 - *w) * interval : h_;
    const double dw = h / interval;
    const double f0 = rate(span, *w, p_, theta);
    const double dp = 1e-6 * std::max(std::abs(p_), 1e5);
    const double jacobian = (rate(span, *w, p_ + dp, theta) - f0) / dp;
    const double dw_t = std::min(1e-4, 0.5 * dw);
    const double f_t = (rate(span, *w + dw_t, p_, theta) - f0) / (dw_t * interval);
    const double W = 1.0 - kGamma * h * (std::isfinite(jacobian) ? std::min(jacobian, 0.0) : 0.0);
    const double k1 = (f0 + kGamma * h * f_t) / W;
    const double f1 = rate(span, *w + dw, p_ + h * k1, theta);
    const double k2 = (f1 - 2.0 * k1 - kGamma * h * f_t) / W;
    const double error = std::abs(0.5 * h * (k1 + k2));
    const double next = p_ + 0.5 * h * (3.0 * k1 + k2);
    if (!std::isfinite(next) || !std::isfinite(error)) {
      p_ = std::numeric_limits<double>::quiet_NaN();
      return;
    }
    const double allowed = tolerance_ + 1e-7 * std::abs(p_);
    // The estimate is of the order-1 solution's error, of order h^2: the step scales with its square root.
    const double factor = std::clamp(0.9 * std::sqrt(allowed / std::max(error, 1e-300)), 0.2, 4.0);
    if (error <= allowed || h <= smallest * (1.0 + 1e-6)) {
      p_ = std::max(next, kFloor);
      *w = last ? 1.0 : *w + dw;
      ++steps_;
      ++stiff_steps_;
      h_ = std::clamp(last ? std::max(h_, h * factor) : h * factor, smallest, interval);
    } else {
      ++rejected_;
      h_ = std::max(h * factor, smallest);
    }
  }
}

void FreeRunPressure::integrate(const Span& span, const ParameterVector& theta) {
  const double interval = span.b->t - span.a->t;
  if (!(h_ > 0.0) || h_ > interval) h_ = interval;
  double w = 0.0;
  // Where the last intervals were stiff, the next go to ROS2 directly (a fit far from physics can be stiff
  // everywhere, and a failed explicit attempt per interval tripled the cost); the explicit method is tried
  // again after kStiffMemory of them.
  if (stiff_intervals_ == 0 || stiff_intervals_ >= kStiffMemory) {
    if (!integrateExplicitly(span, theta, &w)) {
      p_ = std::numeric_limits<double>::quiet_NaN();
      return;
    }
    stiff_intervals_ = 0;
  }
  if (w < 1.0) {
    integrateStiffly(span, theta, &w);
    ++stiff_intervals_;
  }
}

double FreeRunPressure::step(const GridSample& s, const ParameterVector& theta, const GridSample* next) {
  // Whether the chamber is above the bar, read where no noise it selects lies (see the class comment): the
  // sample before, unless that is the anchor a run would start from; then the one before it. Unknown at a
  // stretch's first samples, which anchor.
  const bool would_start = anchored_this_step_;
  anchored_this_step_ = false;
  if (s.discontinuity || !usable(s))
    measured_back_[0] = measured_back_[1] = std::numeric_limits<double>::quiet_NaN();
  const double decides = would_start ? measured_back_[1] : measured_back_[0];
  measured_back_[1] = measured_back_[0];
  measured_back_[0] = usable(s) ? s.p : std::numeric_limits<double>::quiet_NaN();
  if (!usable(s) || !usable(previous_) || s.discontinuity || !anchored_ || !(decides >= min_pressure_) ||
      !(s.t > previous_.t)) {
    have_before_previous_ = false;
    previous_ = s;
    anchored_ = usable(s);
    anchored_this_step_ = anchored_;
    p_ = s.p;
    if (std::isfinite(restart_pressure_)) {
      // A pressure the caller averaged: it decides the next step (not this sample's own noise).
      p_ = measured_back_[0] = measured_back_[1] = restart_pressure_;
      restart_pressure_ = std::numeric_limits<double>::quiet_NaN();
    }
    h_ = 0.0;
    return pressure();
  }
  const bool after_usable = next && usable(*next) && !next->discontinuity && next->t > s.t;
  const Span span{have_before_previous_ ? &before_previous_ : nullptr, &previous_, &s, after_usable ? next : nullptr};
  integrate(span, theta);
  // A parameter set far from the truth (an estimator that has just started) can make the model diverge;
  // beyond twice the supply pressure it says nothing any more: start again from the measurement.
  if (!std::isfinite(p_) || p_ > 2.0 * model_.geometry().supply_pressure) {
    p_ = s.p;
    h_ = 0.0;
    anchored_this_step_ = true;
  }
  before_previous_ = previous_;
  have_before_previous_ = true;
  previous_ = s;
  return p_;
}

}  // namespace die_cushion_ident
