#include "die_cushion_ident/core/estimation/volume_balance_regressor.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace die_cushion_ident {

namespace {
enum RawChannel { kT, kP, kX, kU, kY, kOil, kRawCount };

// The valve model can follow the spool sample by sample when the grid has at least five samples per period
// of the valve's natural frequency (80 Hz on the 2 ms grid: 6; on 5 ms: 2.5, too few).
bool resolvesValve(const ServoValveParameters& valve, double sample_period) {
  return valve.natural_frequency * sample_period <= 0.2;
}
bool resolvesValve(const IdentificationConfig& config) {
  return resolvesValve(config.valve, config.resampler.sample_period);
}

// Neighbours each side that judge the port side near the kink: 16 with the valve model (a noise of a sixth of
// the spool's left in its correction), else the two next to it.
int sideNeighbours(const IdentificationConfig& config) {
  return resolvesValve(config) ? VolumeBalanceRegressor::kMaxSideNeighbours : 1;
}

// Quiet samples (|y| within 10 spool-noise stds of the kink) whose measured-minus-modelled spool the side
// judgement averages: the 32 neighbours left a noise of a sixth of the spool's in it, comparable to where a
// holding controller keeps the spool, and the widest windows' dead volume 0.4 % low.
constexpr double kQuietOffsetMemory = 1024.0;
constexpr double kQuietBand = 10.0;  // [spool noise stds]

}  // namespace

VolumeBalanceRegressor::VolumeBalanceRegressor(const HydraulicModel& model,
                                               const IdentificationConfig& config)
    : model_(model),
      form_(config.regression_form),
      dt_(config.resampler.sample_period),
      n_(model.parameterCount()),
      // The integral form closes an increment one sample late (its quadrature looks one sample ahead), and
      // takes each sample sideNeighbours() samples late (the port side looks at the spools around it).
      delay_((config.moving_average_width - 1) / 2 + (config.derivative_width - 1) / 2 +
             (config.regression_form == RegressionForm::kIntegral ? 1 + sideNeighbours(config) : 0)),
      raw_(delay_, kRawCount),
      increment_window_(config.derivative_width - 1, model.parameterCount() + 2),
      window_average_(config.moving_average_width, model.parameterCount() + 2),
      side_by_model_(resolvesValve(config)),
      side_neighbours_(sideNeighbours(config)),
      spool_model_(config.valve, config.resampler.sample_period),
      signal_average_(config.moving_average_width, 5),
      derivative_(config.derivative_width, 2, config.resampler.sample_period),
      aligned_((config.derivative_width - 1) / 2, 5),
      span_flags_(config.derivative_width, 1),
      scratch_(model.parameterCount() + 2, 0.0) {
  valve_column_[HydraulicModel::kValveFlowGain] = true;
  for (int i = 0; i < model.effectCount(); ++i) {
    valve_column_[HydraulicModel::kFirstEffect + i] =
        model.effect(i).coupling() == Effect::Coupling::kValveShape;
  }
}

void VolumeBalanceRegressor::clear() {
  raw_.clear();
  increment_window_.clear();
  window_average_.clear();
  pending_count_ = 0;
  pending_head_ = 0;
  spool_model_started_ = false;
  node_count_ = 0;
  signal_average_.clear();
  derivative_.clear();
  aligned_.clear();
  span_flags_.clear();
}

HydraulicSignals VolumeBalanceRegressor::signalsAt(double t, double p, double dp, double x, double v,
                                                   double u, double y, double T,
                                                   const ParameterVector& point) const {
  HydraulicSignals s;
  s.t = t;
  s.T = T;
  s.p = p;
  s.dp = dp;
  s.x = x;
  s.v = v;
  s.u = u;
  s.y = y;
  s.V = model_.chamberVolume(x, point(HydraulicModel::kDeadVolume));
  return s;
}

void VolumeBalanceRegressor::setValveModel(const ServoValveParameters& valve) {
  // The neighbours (and so the regressor's delay) stay as built; the 1/2-1/4 weighting needs only two.
  side_by_model_ = resolvesValve(valve, dt_) && side_neighbours_ == kMaxSideNeighbours;
  spool_model_ = SampledServoValve(valve, dt_);
  spool_model_started_ = false;
  quiet_offset_sum_ = quiet_offset_weight_ = 0.0;
}

bool VolumeBalanceRegressor::push(const GridSample& sample, bool usable, const ParameterVector& point,
                                  RegressionRow* row) {
  if (sample.discontinuity) clear();
  const double raw[kRawCount] = {sample.t, sample.p, sample.x, sample.u, sample.y, sample.T};
  const bool raw_ready = raw_.push(raw);
  const bool ready = form_ == RegressionForm::kDerivative ? pushDerivative(sample, usable, point, row)
                                                          : pushPending(sample, usable, point, row);
  if (!ready || !raw_ready) return false;
  row->t = raw_.output(kT);
  row->p = raw_.output(kP);
  row->x = raw_.output(kX);
  row->u = raw_.output(kU);
  row->y = raw_.output(kY);
  row->T = raw_.output(kOil);
  row->velocity = row->z / model_.geometry().piston_area;
  row->pressure_rate = row->phi[HydraulicModel::kDeadVolume];  // column a = 1: the window-mean dp/dt
  return true;
}

double VolumeBalanceRegressor::modelledSpool(const GridSample& sample) {
  // The valve model follows the command: near the kink its spool tells the port side with an error that is
  // independent of the measured spool's noise. It takes the command's mean over the interval, which holds
  // the commands a controller faster than the grid issued between grid points (its dither around 0 while
  // it holds pressure): on u alone the widest windows' dead volume was 0.8 % lower.
  const double command = std::isfinite(sample.u_mean) ? sample.u_mean : sample.u;
  if (!side_by_model_ || !std::isfinite(command)) return 0.0;
  if (!spool_model_started_) {
    spool_model_.reset(std::isfinite(sample.y) ? sample.y : 0.0);
    spool_model_started_ = true;
    return std::isfinite(sample.y) ? sample.y : 0.0;
  }
  return spool_model_.step(command);
}

bool VolumeBalanceRegressor::pushPending(const GridSample& sample, bool usable, const ParameterVector& point,
                                         RegressionRow* row) {
  const int span = 2 * side_neighbours_ + 1;
  // A ring of the last `span` samples (pending(0) the oldest): copying them along each sample cost more
  // than the rest of the regressor.
  if (pending_count_ == span) {
    pending_head_ = (pending_head_ + 1) % span;
    pending_count_ = span - 1;
  }
  const double modelled = modelledSpool(sample);
  pending(pending_count_++) = {sample, usable, modelled};
  if (pending_count_ != span) return false;
  bool split_at_kink = false;
  const double drain_weight = middleDrainWeight(&split_at_kink);
  const Pending& middle = pending(side_neighbours_);
  return pushIntegral(middle.sample, middle.usable, drain_weight, split_at_kink, point, row);
}

double VolumeBalanceRegressor::middleDrainWeight(bool* split_at_kink) {
  const int span = 2 * side_neighbours_ + 1;
  const int mid = side_neighbours_;
  const auto known = [&](int k) { return pending(k).usable && std::isfinite(pending(k).sample.y); };
  if (known(mid - 1) && known(mid) && known(mid + 1)) {
    spool_noise_.add(pending(mid - 1).sample.y, pending(mid).sample.y, pending(mid + 1).sample.y);
  }
  // Within 3 noise stds of the port's kink the sample's own noisy sign would bias the flow column (its
  // noise decides the side it is weighed on). Where the grid resolves the valve, the side is judged by the
  // valve model's spool, moved onto the measurement by the neighbours' mean measured-minus-modelled
  // spool, whose noise is independent of this sample's; on a coarser grid the model cannot follow the
  // spool, and the side is weighted 1/2 by the sample's own sign and 1/4 by each neighbour's, which
  // cancels the bias where the spool is spread evenly (doc/equations.md, "Spool noise at the port's kink").
  const auto drains = [](double y) { return y >= 0.0 ? 1.0 : 0.0; };
  const double own = drains(pending(mid).sample.y);
  const GridSample& middle = pending(mid).sample;
  const double spool_sigma = spool_noise_.sigma();
  const bool near_kink = std::abs(middle.y) < 3.0 * spool_sigma;
  // The oldest sample, not the middle one, goes into the quiet offset: the middle one's own noise must
  // stay out of its side judgement.
  if (side_by_model_ && known(0) && std::abs(pending(0).sample.y) < kQuietBand * spool_sigma) {
    constexpr double kKeep = 1.0 - 1.0 / kQuietOffsetMemory;
    quiet_offset_sum_ = kKeep * quiet_offset_sum_ + (pending(0).sample.y - pending(0).modelled_spool);
    quiet_offset_weight_ = kKeep * quiet_offset_weight_ + 1.0;
  }
  // Away from the noise's reach a spool that crossed 0 within the interval (a controller dithering it
  // faster than the grid) drains and fills in it: both parts' flows (dead volume -1.1 % at b 51 / d 35
  // on the 2 ms grid of a 1 kHz controller without them).
  *split_at_kink = !near_kink && middle.y_drain > 0.0f && middle.y_supply < 0.0f;
  if (!near_kink) return own;
  if (side_by_model_ && quiet_offset_weight_ >= span - 1) {
    return drains(pending(mid).modelled_spool + quiet_offset_sum_ / quiet_offset_weight_);
  }
  if (side_by_model_) {
    double offset = 0.0;
    int neighbours = 0;
    for (int k = 0; k < span; ++k) {
      if (k == mid || !known(k)) continue;
      offset += pending(k).sample.y - pending(k).modelled_spool;
      ++neighbours;
    }
    return neighbours > 0 ? drains(pending(mid).modelled_spool + offset / neighbours) : own;
  }
  double drain_weight = 0.5 * own;
  for (int k : {mid - 1, mid + 1}) drain_weight += 0.25 * (known(k) ? drains(pending(k).sample.y) : own);
  return drain_weight;
}

void VolumeBalanceRegressor::nodeColumns(Node& node, double drain_weight, bool split_at_kink,
                                         const ParameterVector& point) {
  const GridSample& s = node.sample;
  const Node* before = node_count_ > 0 ? &nodes_[node_count_ - 1] : nullptr;
  const bool have_before = before && before->usable;
  const double v = have_before ? (s.x - before->sample.x) / dt_ : 0.0;
  const double dp = have_before ? (s.p - before->sample.p) / dt_ : 0.0;
  HydraulicSignals signals = signalsAt(s.t, s.p, dp, s.x, v, s.u, s.y, s.T, point);
  if (drain_weight == 0.0 || drain_weight == 1.0) {
    signals.port_side = drain_weight == 1.0 ? 1.0 : -1.0;
    model_.regressionColumns(signals, point, node.a, node.g);
  } else {  // the spool near its kink: the columns of both ports, weighted
    double a_supply[kMaxParameters], g_supply[kMaxParameters];
    signals.port_side = 1.0;
    model_.regressionColumns(signals, point, node.a, node.g);
    signals.port_side = -1.0;
    model_.regressionColumns(signals, point, a_supply, g_supply);
    for (int j = 0; j < n_; ++j) {
      node.a[j] = drain_weight * node.a[j] + (1.0 - drain_weight) * a_supply[j];
      node.g[j] = drain_weight * node.g[j] + (1.0 - drain_weight) * g_supply[j];
    }
  }
  if (!split_at_kink) return;
  double a_part[kMaxParameters], g_drain[kMaxParameters], g_supply[kMaxParameters];
  signals.y = s.y_drain;
  signals.port_side = 1.0;
  model_.regressionColumns(signals, point, a_part, g_drain);
  signals.y = s.y_supply;
  signals.port_side = -1.0;
  model_.regressionColumns(signals, point, a_part, g_supply);
  for (int j = 0; j < n_; ++j) {
    if (valve_column_[j]) node.g[j] = g_drain[j] + g_supply[j];
  }
}

void VolumeBalanceRegressor::incrementBetweenNodes(double* channels) {
  if (!(nodes_[0].usable && nodes_[1].usable && nodes_[2].usable && nodes_[3].usable)) {
    channels[n_ + 1] = 1.0;
    return;
  }
  const GridSample& s1 = nodes_[1].sample;
  const GridSample& s2 = nodes_[2].sample;
  const double dp = s2.p - s1.p;
  channels[0] = model_.geometry().piston_area * (s2.x - s1.x);
  const double w_outer = -dt_ / 24.0, w_inner = 13.0 * dt_ / 24.0;
  for (int j = 0; j < n_; ++j) {
    double capacitive = 0.5 * (nodes_[1].a[j] + nodes_[2].a[j]) * dp;
    if (j >= HydraulicModel::kFirstEffect) {
      HydraulicSignals from, to;
      from.p = s1.p;
      from.x = s1.x;
      to.p = s2.p;
      to.x = s2.x;
      double exact = 0.0;
      const Effect& e = model_.effect(j - HydraulicModel::kFirstEffect);
      if (e.coupling() == Effect::Coupling::kAdditive && e.capacitanceIncrement(from, to, &exact))
        capacitive = exact;
    }
    const double flow =
        w_outer * (nodes_[0].g[j] + nodes_[3].g[j]) + w_inner * (nodes_[1].g[j] + nodes_[2].g[j]);
    channels[j + 1] = capacitive + flow;
  }
}

// The balance A dx = sum_j c_j (a_j dp + g_j dt) holds for every increment, so it also holds for any linear
// filter of the increments: summing d-1 of them and averaging b such sums loses nothing and adds no bias.
// Quadrature of one increment between samples k-1 and k: the capacitance part by the trapezoid rule
// (its noise is uncorrelated with dp), the flow part by the 4-point rule on k-2 .. k+1, which is exact for
// cubics; the 2nd-order midpoint rule biased stiff, fast-controlled cushions (doc/equations.md).
bool VolumeBalanceRegressor::pushIntegral(const GridSample& s, bool usable, double drain_weight,
                                          bool split_at_kink, const ParameterVector& point,
                                          RegressionRow* row) {
  if (node_count_ == 4) {
    for (int i = 0; i < 3; ++i) nodes_[i] = nodes_[i + 1];
    node_count_ = 3;
  }
  Node& node = nodes_[node_count_];
  node.sample = s;
  node.usable = usable;
  if (usable) nodeColumns(node, drain_weight, split_at_kink, point);
  ++node_count_;
  if (node_count_ < 4) return false;
  double* channels = scratch_.data();
  std::fill(scratch_.begin(), scratch_.end(), 0.0);
  incrementBetweenNodes(channels);
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
  // The oil's temperature changes over minutes: the sample's own stands for the row's time.
  const HydraulicSignals f = signalsAt(s.t - delay_ * dt_, aligned_.output(0), dp, aligned_.output(1), v,
                                       aligned_.output(2), aligned_.output(3), s.T, point);
  row->z = model_.geometry().piston_area * v;
  double a[kMaxParameters], g[kMaxParameters];
  model_.regressionColumns(f, point, a, g);
  for (int j = 0; j < n_; ++j) row->phi[j] = a[j] * dp + g[j];
  row->valid = span_flags_.sum(0) < 1e-9;
  return true;
}

}  // namespace die_cushion_ident
