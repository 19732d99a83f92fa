#include "die_cushion_ident/core/model/hydraulic_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

#include "die_cushion_ident/core/model/effect_library.h"
#include "die_cushion_ident/core/model/effects/custom_flow_effect.h"

namespace die_cushion_ident {

namespace {
// Below this port pressure drop the square root's slope is capped: such samples are near cavitation or at
// the tank pressure, where the model is not trusted and the identifier excludes them anyway.
constexpr double kMinimumLinearisationDrop = 1e5;  // [Pa]

double signedSqrtFlow(const ValvePort& port) {
  return port.opening * std::sqrt(std::max(port.pressure_drop, 0.0));
}
}  // namespace

HydraulicModel::HydraulicModel(const CylinderGeometry& geometry, std::vector<std::unique_ptr<Effect>> effects)
    : geometry_(geometry), effects_(std::move(effects)) {
  if (!(geometry.piston_area > 0.0) || !std::isfinite(geometry.piston_area)) {
    throw std::invalid_argument("piston_area must be > 0 m^2");
  }
  if (!(geometry.stroke_length > 0.0) || !std::isfinite(geometry.stroke_length)) {
    throw std::invalid_argument("stroke_length must be > 0 m");
  }
  if (!(geometry.supply_pressure > 0.0) || !std::isfinite(geometry.supply_pressure)) {
    throw std::invalid_argument("supply_pressure must be > 0 Pa");
  }
  if (kFirstEffect + effects_.size() > static_cast<std::size_t>(kMaxParameters)) {
    throw std::invalid_argument("too many effects: at most " + std::to_string(kMaxParameters - kFirstEffect));
  }
  std::set<std::string> seen;
  for (const auto& e : effects_) {
    if (!seen.insert(e->name()).second) throw std::invalid_argument("effect '" + e->name() + "' given twice");
  }
  for (std::size_t i = 0; i < effects_.size(); ++i) {
    if (effects_[i]->coupling() != Effect::Coupling::kOilState) continue;
    if (oil_state_ >= 0) throw std::invalid_argument("at most one effect may change the oil's state");
    oil_state_ = static_cast<int>(i);
  }
  rebuildInfos();
}

HydraulicModel::HydraulicModel(const HydraulicModel& other)
    : geometry_(other.geometry_),
      infos_(other.infos_),
      rate_dependent_flow_(other.rate_dependent_flow_),
      oil_state_(other.oil_state_) {
  for (const auto& e : other.effects_) effects_.push_back(e->clone());
}

HydraulicModel& HydraulicModel::operator=(const HydraulicModel& other) {
  if (this != &other) *this = HydraulicModel(other);
  return *this;
}

HydraulicModel HydraulicModel::fromNames(const CylinderGeometry& geometry,
                                         const std::vector<std::string>& effects,
                                         const std::vector<std::string>& custom_effects,
                                         const OilTemperatureLaw& oil) {
  std::vector<std::unique_ptr<Effect>> list;
  for (const auto& name : effects) list.push_back(makeLibraryEffect(name, oil));
  for (const auto& spec : custom_effects) list.push_back(parseCustomEffect(spec));
  return HydraulicModel(geometry, std::move(list));
}

void HydraulicModel::rebuildInfos() {
  const double A = geometry_.piston_area;
  const double s = geometry_.stroke_length;
  infos_.clear();
  // Effective bulk modulus of oil in steel hoses and cylinders: 0.8..2 GPa; 1e9 is the customary guess.
  infos_.push_back({"bulk_modulus", "Pa", 1.0e9, 1e8, 3e9});
  // A K_v that passes the full swept volume in 1 s through half opening at 100 bar.
  infos_.push_back({"valve_flow_gain", "m^3/(s*Pa^0.5)", A * s / (0.5 * std::sqrt(100e5)), 0.0, 1.0});
  infos_.push_back({"dead_volume", "m^3", 0.25 * A * s, 0.0, 10.0 * A * s});
  for (const auto& e : effects_) infos_.push_back(e->parameterFor(geometry_));
  rate_dependent_flow_ = false;
  for (const auto& e : effects_) rate_dependent_flow_ |= e->outflowDependsOnPressureRate();
}

std::vector<std::string> HydraulicModel::effectNames() const {
  std::vector<std::string> names;
  for (const auto& e : effects_) names.push_back(e->name());
  return names;
}

ParameterVector HydraulicModel::nominalParameters() const {
  ParameterVector nominal(parameterCount());
  for (int i = 0; i < parameterCount(); ++i) nominal(i) = infos_[i].nominal;
  return nominal;
}

double HydraulicModel::chamberVolume(double x, double dead_volume) const {
  return dead_volume + geometry_.piston_area * (geometry_.stroke_length - x);
}

ValvePort HydraulicModel::basePort(const HydraulicSignals& s) const {
  const double side = std::isnan(s.port_side) ? s.y : s.port_side;
  return {s.y, side >= 0.0 ? s.p : geometry_.supply_pressure - s.p};
}

double HydraulicModel::capacitance(const HydraulicSignals& s, const ParameterVector& physical) const {
  double c = chamberVolume(s.x, physical(kDeadVolume)) / physical(kBulkModulus);
  if (oil_state_ >= 0) {
    double factor = 1.0, slope = 0.0;
    effects_[oil_state_]->compressibility(s, physical(kFirstEffect + oil_state_), &factor, &slope);
    c *= factor;
  }
  for (int i = 0; i < effectCount(); ++i) {
    if (effects_[i]->coupling() == Effect::Coupling::kAdditive) {
      c += physical(kFirstEffect + i) * effects_[i]->capacitancePerUnit(s);
    }
  }
  return c;
}

double HydraulicModel::valveFlow(const HydraulicSignals& s, const ParameterVector& physical) const {
  ValvePort port = basePort(s);
  for (int i = 0; i < effectCount(); ++i) {
    if (effects_[i]->coupling() != Effect::Coupling::kValveShape) continue;
    ValvePort unused;
    effects_[i]->shapeValvePort(s.y, physical(kFirstEffect + i), port, unused);
  }
  return physical(kValveFlowGain) * signedSqrtFlow(port);
}

double HydraulicModel::extraOutflow(const HydraulicSignals& s, const ParameterVector& physical) const {
  const double laminar = oil_state_ >= 0 ? effects_[oil_state_]->laminarFlowFactor(s) : 1.0;
  double q = 0.0;
  for (int i = 0; i < effectCount(); ++i) {
    if (effects_[i]->coupling() == Effect::Coupling::kAdditive) {
      q += physical(kFirstEffect + i) * effects_[i]->outflowPerUnit(s) *
           (effects_[i]->laminarFlow() ? laminar : 1.0);
    }
  }
  return q;
}

double HydraulicModel::pressureRate(const HydraulicSignals& s, const ParameterVector& physical) const {
  const double driving = geometry_.piston_area * s.v - valveFlow(s, physical);
  const double c = capacitance(s, physical);
  HydraulicSignals at = s;
  at.dp = 0.0;
  const double guess = (driving - extraOutflow(at, physical)) / c;
  if (!rate_dependent_flow_ || !std::isfinite(guess)) return guess;
  // A flow that depends on dp/dt itself (a custom term not affine in dp): solve
  // C r + Q_extra(r) - (A v - Q_v) = 0 for r by the secant method from the rate without it.
  const auto residual = [&](double r) {
    at.dp = r;
    return c * r + extraOutflow(at, physical) - driving;
  };
  double r0 = guess, f0 = residual(r0);
  double r1 = guess + 1e-3 * std::abs(guess) + 1.0, f1 = residual(r1);
  for (int iteration = 0; iteration < 40; ++iteration) {
    if (f1 == 0.0 || std::abs(r1 - r0) <= 1e-12 * std::abs(r1) + 1e-9) return r1;
    if (f1 == f0) break;
    const double r2 = r1 - f1 * (r1 - r0) / (f1 - f0);
    r0 = r1;
    f0 = f1;
    r1 = r2;
    f1 = residual(r1);
    if (!std::isfinite(f1)) break;
  }
  return std::numeric_limits<double>::quiet_NaN();  // no rate balances the flows: the model does not hold
}

void HydraulicModel::regressionColumns(const HydraulicSignals& s, const ParameterVector& linearisation_point,
                                       double* a, double* g) const {
  const int n = parameterCount();
  std::fill(a, a + n, 0.0);
  std::fill(g, g + n, 0.0);
  a[kBulkModulus] = geometry_.piston_area * (geometry_.stroke_length - s.x);  // coefficient 1/K'
  a[kDeadVolume] = 1.0;                                                       // coefficient V_dead/K'

  // Valve flow q(y, p; nu) at the linearisation point, and its slope in each valve-shape parameter nu_i:
  // K_v q(nu) ~ K_v [q(nu^) - sum nu^_i dq/dnu_i] + sum (K_v nu_i) dq/dnu_i.
  ValvePort port = basePort(s);
  ValvePort derivative_of[kMaxParameters];
  for (int i = 0; i < effectCount(); ++i) {
    const Effect& e = *effects_[i];
    const int k = kFirstEffect + i;
    if (e.coupling() == Effect::Coupling::kAdditive) {
      a[k] = e.capacitancePerUnit(s);
      g[k] = e.outflowPerUnit(s);
    } else if (e.coupling() == Effect::Coupling::kValveShape) {
      derivative_of[k] = ValvePort{0.0, 0.0};
      e.shapeValvePort(s.y, linearisation_point(k), port, derivative_of[k]);
    }
  }
  const double root = std::sqrt(std::max(port.pressure_drop, 0.0));
  const double half_inverse_root = 0.5 / std::sqrt(std::max(port.pressure_drop, kMinimumLinearisationDrop));
  double q_base = port.opening * root;
  for (int i = 0; i < effectCount(); ++i) {
    const int k = kFirstEffect + i;
    if (effects_[i]->coupling() != Effect::Coupling::kValveShape) continue;
    const double dq =
        derivative_of[k].opening * root + port.opening * derivative_of[k].pressure_drop * half_inverse_root;
    g[k] = dq;
    q_base -= linearisation_point(k) * dq;
  }
  g[kValveFlowGain] = q_base;
  if (oil_state_ < 0) return;
  // The oil's state: C_oil = c_0 V h(T; alpha) with c_0 = 1/K', relinearised at alpha^ like a valve shape,
  // c_0 V h(alpha) ~ c_0 V [h(alpha^) - alpha^ dh/dalpha] + (c_0 alpha) V dh/dalpha: the base's capacitive
  // columns take the first factor, the effect's column (coefficient alpha / K') V dh/dalpha, with V at the
  // linearised dead volume (V_dead/K' alpha = V_dead (alpha/K')); exact at the fixed point. Laminar flows
  // take their known factor.
  const Effect& oil = *effects_[oil_state_];
  const int k_oil = kFirstEffect + oil_state_;
  double factor = 1.0, slope = 0.0;
  oil.compressibility(s, linearisation_point(k_oil), &factor, &slope);
  const double base = factor - linearisation_point(k_oil) * slope;
  a[kBulkModulus] *= base;
  a[kDeadVolume] *= base;
  a[k_oil] = s.V * slope;
  g[k_oil] = 0.0;
  const double laminar = oil.laminarFlowFactor(s);
  for (int i = 0; i < effectCount(); ++i) {
    if (effects_[i]->coupling() == Effect::Coupling::kAdditive && effects_[i]->laminarFlow()) {
      g[kFirstEffect + i] *= laminar;
    }
  }
}

ParameterVector HydraulicModel::coefficientsFromPhysical(const ParameterVector& physical) const {
  ParameterVector c(parameterCount());
  c(kBulkModulus) = 1.0 / physical(kBulkModulus);
  c(kValveFlowGain) = physical(kValveFlowGain);
  c(kDeadVolume) = physical(kDeadVolume) / physical(kBulkModulus);
  for (int i = 0; i < effectCount(); ++i) {
    const int k = kFirstEffect + i;
    switch (effects_[i]->coupling()) {
      case Effect::Coupling::kValveShape:
        c(k) = physical(kValveFlowGain) * physical(k);
        break;
      case Effect::Coupling::kOilState:
        c(k) = physical(k) / physical(kBulkModulus);
        break;
      case Effect::Coupling::kAdditive:
        c(k) = physical(k);
        break;
    }
  }
  return c;
}

ParameterVector HydraulicModel::physicalFromCoefficients(const ParameterVector& c,
                                                         CovarianceMatrix* J) const {
  const int n = parameterCount();
  ParameterVector phys(n);
  const double inv_K = c(kBulkModulus);
  const double Kv = c(kValveFlowGain);
  phys(kBulkModulus) = 1.0 / inv_K;
  phys(kValveFlowGain) = Kv;
  phys(kDeadVolume) = c(kDeadVolume) / inv_K;
  if (J) {
    J->setZero(n, n);
    (*J)(kBulkModulus, kBulkModulus) = -1.0 / (inv_K * inv_K);
    (*J)(kValveFlowGain, kValveFlowGain) = 1.0;
    (*J)(kDeadVolume, kDeadVolume) = 1.0 / inv_K;
    (*J)(kDeadVolume, kBulkModulus) = -c(kDeadVolume) / (inv_K * inv_K);
  }
  for (int i = 0; i < effectCount(); ++i) {
    const int k = kFirstEffect + i;
    if (effects_[i]->coupling() == Effect::Coupling::kValveShape) {
      phys(k) = c(k) / Kv;
      if (J) {
        (*J)(k, k) = 1.0 / Kv;
        (*J)(k, kValveFlowGain) = -c(k) / (Kv * Kv);
      }
    } else if (effects_[i]->coupling() == Effect::Coupling::kOilState) {
      phys(k) = c(k) / inv_K;  // alpha = (alpha / K') K'
      if (J) {
        (*J)(k, k) = 1.0 / inv_K;
        (*J)(k, kBulkModulus) = -c(k) / (inv_K * inv_K);
      }
    } else {
      phys(k) = c(k);
      if (J) (*J)(k, k) = 1.0;
    }
  }
  return phys;
}

}  // namespace die_cushion_ident
