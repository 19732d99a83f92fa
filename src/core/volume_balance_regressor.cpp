#include "die_cushion_ident/core/volume_balance_regressor.h"

#include <algorithm>
#include <cmath>

namespace die_cushion_ident {

namespace {
enum RawChannel { kT, kP, kX, kU, kY, kRawCount };
}

VolumeBalanceRegressor::VolumeBalanceRegressor(const HydraulicModel& model, const IdentificationConfig& config)
    : model_(model),
      form_(config.regression_form),
      dt_(config.resampler.sample_period),
      n_(model.parameterCount()),
      delay_((config.moving_average_width - 1) / 2 + (config.derivative_width - 1) / 2),
      raw_(delay_, kRawCount),
      increment_window_(config.derivative_width - 1, model.parameterCount() + 2),
      window_average_(config.moving_average_width, model.parameterCount() + 2),
      signal_average_(config.moving_average_width, 5),
      derivative_(config.derivative_width, 2, config.resampler.sample_period),
      aligned_((config.derivative_width - 1) / 2, 5),
      span_flags_(config.derivative_width, 1),
      scratch_(model.parameterCount() + 2, 0.0) {}

void VolumeBalanceRegressor::clear() {
  raw_.clear();
  increment_window_.clear();
  window_average_.clear();
  has_previous_ = false;
  signal_average_.clear();
  derivative_.clear();
  aligned_.clear();
  span_flags_.clear();
}

HydraulicSignals VolumeBalanceRegressor::signalsAt(double t, double p, double dp, double x, double v, double u,
                                                   double y, const ParameterVector& point) const {
  HydraulicSignals s;
  s.t = t;
  s.p = p;
  s.dp = dp;
  s.x = x;
  s.v = v;
  s.u = u;
  s.y = y;
  s.V = model_.chamberVolume(x, point(HydraulicModel::kDeadVolume));
  return s;
}

void VolumeBalanceRegressor::fillColumns(const HydraulicSignals& s, const ParameterVector& point,
                                         double pressure_change, double dt, double* out) const {
  double a[kMaxParameters], g[kMaxParameters];
  model_.regressionColumns(s, point, a, g);
  for (int j = 0; j < n_; ++j) out[j] = a[j] * pressure_change + g[j] * dt;
}

bool VolumeBalanceRegressor::push(const GridSample& sample, bool usable, const ParameterVector& point,
                                  RegressionRow* row) {
  if (sample.discontinuity) clear();
  const double raw[kRawCount] = {sample.t, sample.p, sample.x, sample.u, sample.y};
  const bool raw_ready = raw_.push(raw);
  const bool ready = form_ == RegressionForm::kIntegral ? pushIntegral(sample, usable, point, row)
                                                        : pushDerivative(sample, usable, point, row);
  if (!ready || !raw_ready) return false;
  row->t = raw_.output(kT);
  row->p = raw_.output(kP);
  row->x = raw_.output(kX);
  row->u = raw_.output(kU);
  row->y = raw_.output(kY);
  row->velocity = row->z / model_.geometry().piston_area;
  row->pressure_rate = row->phi[HydraulicModel::kDeadVolume];  // column a = 1: the window-mean dp/dt
  return true;
}

// The balance A dx = sum_j c_j (a_j dp + g_j dt) holds for every increment, so it also holds for any linear
// filter of the increments: summing d-1 of them and averaging b such sums loses nothing and adds no bias.
bool VolumeBalanceRegressor::pushIntegral(const GridSample& s, bool usable, const ParameterVector& point,
                                          RegressionRow* row) {
  double* channels = scratch_.data();  // [z, phi_0 .. phi_{n-1}, unusable]
  const bool have_increment = has_previous_;
  if (have_increment) {
    std::fill(scratch_.begin(), scratch_.end(), 0.0);
    if (usable && previous_usable_) {
      const double dx = s.x - previous_.x;
      const double dp = s.p - previous_.p;
      const HydraulicSignals mid =
          signalsAt(0.5 * (s.t + previous_.t), 0.5 * (s.p + previous_.p), dp / dt_, 0.5 * (s.x + previous_.x),
                    dx / dt_, 0.5 * (s.u + previous_.u), 0.5 * (s.y + previous_.y), point);
      channels[0] = model_.geometry().piston_area * dx;
      fillColumns(mid, point, dp, dt_, channels + 1);
    } else {
      channels[n_ + 1] = 1.0;
    }
  }
  previous_ = s;
  previous_usable_ = usable;
  has_previous_ = true;
  if (!have_increment) return false;

  increment_window_.push(channels);
  if (!increment_window_.full()) return false;
  if (!window_average_.push(increment_window_.sum())) return false;

  const auto& averaged = window_average_.output();
  const double per_second = 1.0 / (static_cast<double>(increment_window_.width()) * dt_);
  row->z = averaged[0] * per_second;
  for (int j = 0; j < n_; ++j) row->phi[j] = averaged[j + 1] * per_second;
  row->valid = averaged[n_ + 1] < 1e-9;  // counts of unusable samples, exact in doubles
  return true;
}

// The paper's form: filter the signals, differentiate, then evaluate the model at the filtered signals.
bool VolumeBalanceRegressor::pushDerivative(const GridSample& s, bool usable, const ParameterVector& point,
                                            RegressionRow* row) {
  if (usable) {
    held_[0] = s.p;
    held_[1] = s.x;
    held_[2] = s.u;
    held_[3] = s.y;
  }
  const double signals[5] = {held_[0], held_[1], held_[2], held_[3], usable ? 0.0 : 1.0};
  if (!signal_average_.push(signals)) return false;
  const auto& filtered = signal_average_.output();
  const bool derivative_ready = derivative_.push(filtered.data());
  const bool aligned_ready = aligned_.push(filtered.data());
  span_flags_.push(filtered[4]);
  if (!derivative_ready || !aligned_ready) return false;

  const double dp = derivative_.output(0);
  const double v = derivative_.output(1);
  const HydraulicSignals f = signalsAt(s.t - delay_ * dt_, aligned_.output(0), dp, aligned_.output(1), v,
                                       aligned_.output(2), aligned_.output(3), point);
  row->z = model_.geometry().piston_area * v;
  fillColumns(f, point, dp, 1.0, row->phi);
  row->valid = span_flags_.sum(0) < 1e-9;
  return true;
}

}  // namespace die_cushion_ident
