#pragma once

#include <limits>
#include <memory>
#include <string>

#include "die_cushion_ident/core/model/hydraulic_signals.h"

namespace die_cushion_ident {

/// A physically named parameter with its SI unit and a typical magnitude (used for scaling and as default
/// start).
struct ParameterInfo {
  std::string name;
  std::string unit;
  double nominal = 1.0;
  double lower_bound = -std::numeric_limits<double>::infinity();  ///< physically plausible range
  double upper_bound = std::numeric_limits<double>::infinity();
};

/// Opening and pressure drop of the metering edge in use: Q_v = K_v * opening * sqrt(max(pressure_drop, 0)).
struct ValvePort {
  double opening = 0.0;        ///< effective opening [-]
  double pressure_drop = 0.0;  ///< [Pa]
};

/// One physical effect that extends the base pressure build-up model by one parameter theta.
///
/// Additive effects enter the volume balance linearly:
///   C += theta * capacitancePerUnit(signals),   Q_extra += theta * outflowPerUnit(signals).
/// Valve-shape effects reshape the valve port (dead band, back pressure); they are nonlinear in theta and
/// the identifier relinearises them around the current estimate (doc/equations.md). Oil-state effects change
/// the oil itself (its temperature): they scale the oil's compressibility V/K' by a factor nonlinear in
/// theta, relinearised like the valve shape, and the laminar flows of the additive effects by a known factor.
class Effect {
 public:
  enum class Coupling { kAdditive, kValveShape, kOilState };

  virtual ~Effect() = default;
  virtual std::unique_ptr<Effect> clone() const = 0;

  /// Name as used in configuration and summary.yaml (part of the interface for library effects).
  virtual std::string name() const = 0;
  /// One line of physics for a user who wonders what the effect means.
  virtual std::string explanation() const = 0;
  /// The same with the parameter's fitted value in it where that says more ("... at -0.41 %/K").
  virtual std::string explanationFor(double /*theta*/) const { return explanation(); }
  virtual ParameterInfo parameter() const = 0;
  /// The parameter with its physical range scaled to this cushion (a sign check alone would accept an air
  /// volume of 1 m^3 or a leakage of 6000 l/min at 100 bar).
  virtual ParameterInfo parameterFor(const CylinderGeometry& /*geometry*/) const { return parameter(); }
  virtual Coupling coupling() const { return Coupling::kAdditive; }

  /// Additive effects: extra capacitance per unit of theta [m^3/Pa per unit].
  virtual double capacitancePerUnit(const HydraulicSignals& /*signals*/) const { return 0.0; }
  /// Additive effects: the exact integral of capacitancePerUnit over dp from `from` to `to` [m^3/Pa * Pa per
  /// unit], where the effect has a closed-form primitive; false to leave it to the trapezoid rule (exact
  /// for a capacitance linear in p, 11 % high for the air column's convex one at a 5 bar step).
  virtual bool capacitanceIncrement(const HydraulicSignals& /*from*/, const HydraulicSignals& /*to*/,
                                    double* /*increment*/) const {
    return false;
  }
  /// Additive effects: extra outflow per unit of theta [m^3/s per unit].
  virtual double outflowPerUnit(const HydraulicSignals& /*signals*/) const { return 0.0; }
  /// True when outflowPerUnit() reads signals.dp other than through capacitancePerUnit(): the model then
  /// solves the balance for dp/dt instead of evaluating it once.
  virtual bool outflowDependsOnPressureRate() const { return false; }

  /// Valve-shape effects: reshape `port` for spool position y and parameter theta, and give the
  /// derivative of both port quantities with respect to theta in `derivative`.
  virtual void shapeValvePort(double /*y*/, double /*theta*/, ValvePort& /*port*/,
                              ValvePort& /*derivative*/) const {}

  /// Additive effects: the flow passes a narrow gap (laminar, conductance inversely proportional to the
  /// oil's viscosity): it follows the oil's temperature where the model has an oil-state effect.
  virtual bool laminarFlow() const { return false; }
  /// Whether the effect reads the oil temperature (HydraulicSignals::T): offered by the effect ranking only
  /// where the recording has one.
  virtual bool needsOilTemperature() const { return false; }
  /// Oil-state effects: the factor on the oil's compressibility V/K' at the signals for parameter theta
  /// (1 at the model's temperature origin), and its derivative in theta.
  virtual void compressibility(const HydraulicSignals& /*signals*/, double /*theta*/, double* factor,
                               double* slope) const {
    *factor = 1.0;
    *slope = 0.0;
  }
  /// Oil-state effects: the factor on laminar flows at the signals (1 at the temperature origin).
  virtual double laminarFlowFactor(const HydraulicSignals& /*signals*/) const { return 1.0; }
};

}  // namespace die_cushion_ident
