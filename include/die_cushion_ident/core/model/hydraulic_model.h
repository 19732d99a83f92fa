#pragma once

#include <memory>
#include <string>
#include <vector>

#include "die_cushion_ident/core/model/effect.h"
#include "die_cushion_ident/core/model/hydraulic_signals.h"
#include "die_cushion_ident/core/model/oil_temperature_law.h"
#include "die_cushion_ident/core/model/parameter_vector.h"

namespace die_cushion_ident {

/// The grey-box pressure build-up model of shared/CONTRACT.md with its active effects:
///
///   C(p, x) dp/dt = A v - Q_v - Q_extra,    C = V(x) / K' + sum_additive theta_i c_i(p),
///   V(x) = V_dead + A (s - x),              Q_v = K_v * opening(y) * sqrt(max(dp_port, 0)),
///   Q_extra = sum_additive theta_i q_i(signals).
/// With an oil-state effect (oil_temperature) V/K' takes its factor h(T; alpha) and the laminar flows
/// theirs, f(T): C = h V / K' + ...,  Q_extra = sum theta_i f_i q_i.
///
/// Physical parameters, in this order: bulk_modulus K' [Pa], valve_flow_gain K_v [m^3/(s Pa^0.5)],
/// dead_volume V_dead [m^3], then one per effect in the order given.
///
/// For identification the balance is written linearly in the coefficients
///   c = [1/K', K_v, V_dead/K', c_effect...],  c_effect = theta (additive), K_v * theta (valve shape) or
///   theta / K' (oil state):
///   A v = sum_j c_j (a_j dp/dt + g_j)
/// with the columns a_j, g_j from regressionColumns(); doc/equations.md derives it.
class HydraulicModel {
 public:
  static constexpr int kBulkModulus = 0;
  static constexpr int kValveFlowGain = 1;
  static constexpr int kDeadVolume = 2;
  static constexpr int kFirstEffect = 3;

  HydraulicModel(const CylinderGeometry& geometry, std::vector<std::unique_ptr<Effect>> effects);
  HydraulicModel(const HydraulicModel& other);
  HydraulicModel& operator=(const HydraulicModel& other);
  HydraulicModel(HydraulicModel&&) = default;
  HydraulicModel& operator=(HydraulicModel&&) = default;

  /// Builds a model from effect names (library) and NAME=EXPR strings (custom); throws std::invalid_argument.
  /// `oil`: the oil's temperature law, for the oil_temperature effect.
  static HydraulicModel fromNames(const CylinderGeometry& geometry, const std::vector<std::string>& effects,
                                  const std::vector<std::string>& custom_effects = {},
                                  const OilTemperatureLaw& oil = OilTemperatureLaw());

  const CylinderGeometry& geometry() const { return geometry_; }
  int parameterCount() const { return kFirstEffect + static_cast<int>(effects_.size()); }
  int effectCount() const { return static_cast<int>(effects_.size()); }
  /// The parameter index of the oil-state effect (oil_temperature), -1 where the model has none.
  int oilStateParameter() const { return oil_state_ < 0 ? -1 : kFirstEffect + oil_state_; }
  const Effect& effect(int i) const { return *effects_[i]; }
  std::vector<std::string> effectNames() const;
  /// Name, unit and nominal value of every physical parameter, in parameter order.
  const std::vector<ParameterInfo>& parameterInfos() const { return infos_; }
  /// Nominal physical parameters: oil-and-hose bulk modulus, geometry-derived gain and volume, effect
  /// nominals.
  ParameterVector nominalParameters() const;

  double chamberVolume(double x, double dead_volume) const;

  // --- Simulation (true parameters) ---
  double capacitance(const HydraulicSignals& s, const ParameterVector& physical) const;   ///< [m^3/Pa]
  double valveFlow(const HydraulicSignals& s, const ParameterVector& physical) const;     ///< Q_v [m^3/s]
  double extraOutflow(const HydraulicSignals& s, const ParameterVector& physical) const;  ///< [m^3/s]
  /// dp/dt [Pa/s] solving the balance (s.dp is ignored); NaN where no rate balances the flows.
  double pressureRate(const HydraulicSignals& s, const ParameterVector& physical) const;

  // --- Identification ---
  /// Columns a_j, g_j (arrays of parameterCount()) at signals s. Valve-shape effects are linearised around
  /// the parameters in `linearisation_point` (physical units), exact when it equals the truth.
  void regressionColumns(const HydraulicSignals& s, const ParameterVector& linearisation_point, double* a,
                         double* g) const;
  ParameterVector coefficientsFromPhysical(const ParameterVector& physical) const;
  /// Physical parameters from coefficients; `jacobian` (optional) receives d physical / d coefficients.
  ParameterVector physicalFromCoefficients(const ParameterVector& coefficients,
                                           CovarianceMatrix* jacobian = nullptr) const;

 private:
  ValvePort basePort(const HydraulicSignals& s) const;
  void rebuildInfos();

  CylinderGeometry geometry_;
  std::vector<std::unique_ptr<Effect>> effects_;
  std::vector<ParameterInfo> infos_;
  bool rate_dependent_flow_ = false;  // some effect's flow reads dp/dt: pressureRate() solves for it
  int oil_state_ = -1;                // the oil-state effect's index among the effects, -1: none
};

}  // namespace die_cushion_ident
