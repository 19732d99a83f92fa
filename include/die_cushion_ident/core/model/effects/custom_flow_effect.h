#pragma once

#include <memory>
#include <string>

#include "die_cushion_ident/core/model/effect.h"

namespace mu {
class Parser;
}

namespace die_cushion_ident {

/// A user's own flow term, Q_extra += theta * expr(p, dp, x, v, u, y, V, t), written as a muparser
/// expression (e.g. "max(p - 180e5, 0)" for a relief valve cracking at 180 bar).
///
/// A term in dp (the pressure rate dp/dt) means the same in the fit, the free run and the simulator: an
/// expression affine in dp, expr = f(signals) + dp * c(signals), is split into a flow f (evaluated at
/// dp = 0) and a capacitance c (the slope in dp), so "dp*max(p-50e5,0)" is a compliance that the free run
/// integrates like the chamber's own. An expression not affine in dp (dp^2, abs(dp)) stays a flow that
/// depends on dp; HydraulicModel::pressureRate then solves the balance for dp/dt.
/// Evaluation reuses one parser, so one instance must not be shared between threads (clone() instead).
class CustomFlowEffect final : public Effect {
 public:
  /// Throws std::invalid_argument naming the problem (bad name, syntax error, unknown signal, or a term
  /// that is non-finite, beyond 1e30 or zero everywhere over the signals' operating range).
  CustomFlowEffect(std::string name, std::string expression);
  ~CustomFlowEffect() override;
  CustomFlowEffect(const CustomFlowEffect&) = delete;
  CustomFlowEffect& operator=(const CustomFlowEffect&) = delete;

  std::unique_ptr<Effect> clone() const override;
  std::string name() const override { return name_; }
  std::string explanation() const override { return "user-defined flow term " + expression_; }
  ParameterInfo parameter() const override;
  double capacitancePerUnit(const HydraulicSignals& signals) const override;
  double outflowPerUnit(const HydraulicSignals& signals) const override;
  bool outflowDependsOnPressureRate() const override { return dp_nonlinear_; }
  const std::string& expression() const { return expression_; }

 private:
  void probe();
  /// The expression at one probe point; throws where it cannot be evaluated or is not finite there.
  double probedValue(const HydraulicSignals& signals) const;
  double evaluate(const HydraulicSignals& signals, double dp) const;

  bool dp_affine_ = false;     // expr = f + dp * c with c not identically 0
  bool dp_nonlinear_ = false;  // expr depends on dp, not affinely
  std::string name_;
  std::string expression_;
  mutable HydraulicSignals bound_;  // the parser reads its variables from here
  std::unique_ptr<mu::Parser> parser_;
};

/// Parses "NAME=EXPR" as given on analyze_bag's command line; throws std::invalid_argument.
std::unique_ptr<CustomFlowEffect> parseCustomEffect(const std::string& name_equals_expression);

}  // namespace die_cushion_ident
