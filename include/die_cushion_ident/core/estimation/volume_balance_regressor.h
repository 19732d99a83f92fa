#pragma once

#include <limits>

#include "die_cushion_ident/core/estimation/identification_config.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/signal/signal_filters.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"
#include "die_cushion_ident/core/signal/white_noise_estimator.h"
#include "die_cushion_ident/core/valve/servo_valve.h"

namespace die_cushion_ident {

/// One equation of the volume balance, averaged over a window:  z = sum_j c_j phi_j + e.
struct RegressionRow {
  double t = 0.0;                             ///< time the row describes, the centre of its window [s]
  double z = 0.0;                             ///< displaced flow A v [m^3/s]
  double phi[kMaxParameters] = {};            ///< column j multiplies coefficient c_j (HydraulicModel)
  double p = 0.0, x = 0.0, u = 0.0, y = 0.0;  ///< measured signals at t
  double T = std::numeric_limits<double>::quiet_NaN();  ///< oil temperature at t [degC]; NaN: none
  double velocity = 0.0;                      ///< window-mean dx/dt [m/s]
  double pressure_rate = 0.0;                 ///< window-mean dp/dt [Pa/s]
  bool valid = false;                         ///< every sample under the window was usable
};

/// Turns the uniform sample stream into regression rows of the volume balance, with the paper's moving
/// average (width b) and symmetrical derivative (width d). Both forms produce one row per sample, centred
/// (b-1)/2 + (d-1)/2 samples in the past, with the same units, so they can be compared one to one.
class VolumeBalanceRegressor {
 public:
  /// Samples each side of a sample that correct the valve model near the port's kink: 16 (32 ms at 2 ms).
  /// At the widest windows 4, 8 and 16 left -2.0, -1.7 and -1.1 % dead-volume bias, 24 and 32 no less
  /// (doc/equations.md).
  static constexpr int kMaxSideNeighbours = 16;
  VolumeBalanceRegressor(const HydraulicModel& model, const IdentificationConfig& config);

  /// Adds one sample (with the spool position filled in). `usable` is false for samples the model must not
  /// see (incomplete, cavitation, saturated valve); every row whose window touches one is marked invalid.
  /// Valve-shape effects and the chamber volume use `linearisation_point` (physical parameters).
  /// Returns true when `row` holds a new row.
  bool push(const GridSample& sample, bool usable, const ParameterVector& linearisation_point,
            RegressionRow* row);
  void clear();
  /// The valve model that judges the port side near the kink (a sweep identified the valve): used from the
  /// next sample on, started afresh at the measured spool.
  void setValveModel(const ServoValveParameters& valve);
  int delaySamples() const { return delay_; }

 private:
  HydraulicSignals signalsAt(double t, double p, double dp, double x, double v, double u, double y, double T,
                             const ParameterVector& linearisation_point) const;
  /// `split_at_kink`: the spool crossed 0 within the sample's interval; its valve columns are the drain
  /// part's flow plus the supply part's (GridSample::y_drain, y_supply).
  bool pushIntegral(const GridSample& s, bool usable, double drain_weight, bool split_at_kink,
                    const ParameterVector& point, RegressionRow* row);
  bool pushDerivative(const GridSample& s, bool usable, const ParameterVector& point, RegressionRow* row);
  /// The integral form's sample: held among the pending ones until its neighbours are in.
  bool pushPending(const GridSample& sample, bool usable, const ParameterVector& point, RegressionRow* row);
  /// The valve model's spool for the sample's command (0 where the model does not judge the side).
  double modelledSpool(const GridSample& sample);
  /// How much of the middle pending sample's flow leaves through the drain port (1: all, 0: none, between:
  /// near the kink); `split_at_kink`: its spool crossed 0 within its interval.
  double middleDrainWeight(bool* split_at_kink);
  struct Node;
  /// The node's columns a (capacitance) and g (flow) at its sample.
  void nodeColumns(Node& node, double drain_weight, bool split_at_kink, const ParameterVector& point);
  /// The increment between nodes 1 and 2 (0 and 3 the outer quadrature points): [z, phi_0 .. phi_{n-1},
  /// unusable].
  void incrementBetweenNodes(double* channels);
  struct Pending;
  Pending& pending(int k) { return pending_[(pending_head_ + k) % (2 * side_neighbours_ + 1)]; }
  const HydraulicModel& model_;
  RegressionForm form_;
  double dt_;
  int n_;
  int delay_;
  DelayLine raw_;  // t, p, x, u, y at the row's time

  // Integral form: increments -> window sum over d-1 increments -> moving average over b.
  // The last four samples with their columns, newest last, for the 4-point flow quadrature.
  struct Node {
    GridSample sample;
    bool usable = false;
    double a[kMaxParameters];
    double g[kMaxParameters];
  };
  SlidingWindowSum increment_window_;
  MovingAverageFilter window_average_;
  // The last 2 side_neighbours_ + 1 samples: the middle one goes on. Within 3 noise stds of the port's kink
  // its port side is judged by the valve model's spool, corrected by the measured-minus-modelled spool of
  // earlier quiet samples (or, until there are enough, of its neighbours), so that its own spool noise does
  // not choose the side (doc/equations.md, "Spool noise at the port's kink").
  struct Pending {
    GridSample sample;
    bool usable = false;
    double modelled_spool = 0.0;  // the valve model's spool for the sample's command
  };
  bool valve_column_[kMaxParameters] = {};  // the column is valve flow (K_v or a valve-shape effect)
  bool side_by_model_;     // the grid resolves the valve: its model judges the port side near the kink
  int side_neighbours_;    // spool samples each side that judge it
  Pending pending_[2 * kMaxSideNeighbours + 1];
  WhiteNoiseEstimator spool_noise_;
  SampledServoValve spool_model_;
  bool spool_model_started_ = false;
  // The valve model's offset from the measured spool where the spool is quiet near the kink (a null offset,
  // what the model misses at rest), exponentially weighted over about kQuietOffsetMemory such samples.
  double quiet_offset_sum_ = 0.0;
  double quiet_offset_weight_ = 0.0;
  int pending_count_ = 0;
  int pending_head_ = 0;
  Node nodes_[4];
  int node_count_ = 0;

  // Derivative form: moving average of signals -> symmetric derivative; the rest delayed to line up.
  MovingAverageFilter signal_average_;
  SymmetricDerivative derivative_;
  DelayLine aligned_;
  SlidingWindowSum span_flags_;
  double held_[4] = {0, 0, 0, 0};

  std::vector<double> scratch_;
};

}  // namespace die_cushion_ident
