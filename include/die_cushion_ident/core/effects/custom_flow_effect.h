#pragma once

#include <memory>
#include <string>

#include "die_cushion_ident/core/effect.h"

namespace mu {
class Parser;
}

namespace die_cushion_ident {

/// A user's own flow term, Q_extra += theta * expr(p, dp, x, v, u, y, V, t), written as a muparser
/// expression (e.g. "max(p - 180e5, 0)" for a relief valve cracking at 180 bar).
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
  double outflowPerUnit(const HydraulicSignals& signals) const override;
  const std::string& expression() const { return expression_; }

 private:
  void probe() const;

  std::string name_;
  std::string expression_;
  mutable HydraulicSignals bound_;  // the parser reads its variables from here
  std::unique_ptr<mu::Parser> parser_;
};

/// Parses "NAME=EXPR" as given on analyze_bag's command line; throws std::invalid_argument.
std::unique_ptr<CustomFlowEffect> parseCustomEffect(const std::string& name_equals_expression);

}  // namespace die_cushion_ident
