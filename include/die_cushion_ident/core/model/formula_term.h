#pragma once

#include <string>
#include <vector>

#include "die_cushion_ident/core/model/hydraulic_signals.h"

namespace die_cushion_ident {

/// One typed term of the volume balance that the formula search may propose for error no library effect
/// explains: a flow out of the chamber, theta * f(signals) [m^3/s], or a compliance, theta * c(signals)
/// [m^3/Pa] (written "dp*c" as a custom effect). Every term has a physical reading, an SI unit for theta
/// (which must come out positive: a negative conductance or compliance is discarded) and at most one
/// breakpoint, found by a one-dimensional search.
class FormulaTerm {
 public:
  enum class Shape {
    kHingeAbove,         ///< max(s - s0, 0)            (signal p: a relief valve cracking at s0)
    kHingeBelow,         ///< max(s0 - s, 0)
    kPressureAbove,      ///< p * (s > s0)              (a leakage path open above s0 of x, v or y)
    kPressureBelow,      ///< p * (s < s0)
    kOrifice,            ///< sqrt(max(p, 0))           (turbulent leakage through a sharp edge)
    kQuadratic,          ///< p^2
    kDrainNotch,         ///< max(y - s0, 0) * sqrt(max(p, 0))          (more drain opening beyond s0)
    kSupplyNotch,        ///< max(s0 - y, 0) * sqrt(max(p_S - p, 0))    (... on the supply edge, y < s0)
    kComplianceAbove,    ///< compliance (s > s0)       (a spring accumulator above s0 of p; a volume at x)
    kComplianceBelow,    ///< compliance (s < s0)
    kComplianceFalling,  ///< compliance max(s0 - p, 0) (softer the lower the pressure)
  };

  /// `signal` is one of p, x, v, y; `sign` is +1, or -1 for a flow into the chamber (x, v, y terms only).
  FormulaTerm(Shape shape, char signal, double breakpoint, double supply_pressure, int sign = +1);

  /// The shapes tried on each signal (the search space, small and typed).
  static std::vector<FormulaTerm> searchSpace(double supply_pressure);

  Shape shape() const { return shape_; }
  char signal() const { return signal_; }
  bool hasBreakpoint() const;
  double breakpoint() const { return breakpoint_; }
  FormulaTerm withBreakpoint(double breakpoint) const;
  FormulaTerm withSign(int sign) const;
  int sign() const { return sign_; }
  bool isCompliance() const;
  /// Whether theta < 0 can be rewritten as an inflow (sign -1) rather than being unphysical.
  bool mayBeInflow() const;
  /// Simplicity for ties: 1 without a breakpoint, 2 a hinge or indicator, 3 a product of two signals.
  int complexity() const;

  /// Flow per unit theta [m^3/s per unit], or compliance per unit theta for compliance terms.
  double value(double p, double x, double v, double y) const;

  std::string name() const;        ///< a physical name for the custom effect, e.g. "relief"
  std::string expression() const;  ///< muparser expression for --custom-effect, e.g. "max(p-1.21e7,0)"
  std::string unit() const;        ///< SI unit of theta
  std::string explanation() const;

 private:
  double signalValue(double p, double x, double v, double y) const;

  Shape shape_;
  char signal_;
  double breakpoint_;
  double supply_pressure_;
  int sign_;
};

/// A number as short as muparser and a reader want it: 1.21e7, 0.125, -0.05.
std::string compactNumber(double value);

}  // namespace die_cushion_ident
