#include "die_cushion_ident/core/effects/custom_flow_effect.h"

#include <muParser.h>

#include <cctype>
#include <cmath>
#include <stdexcept>

#include "die_cushion_ident/core/effect_library.h"

namespace die_cushion_ident {

namespace {
bool isIdentifier(const std::string& s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  for (char c : s) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
  }
  return true;
}
}  // namespace

CustomFlowEffect::CustomFlowEffect(std::string name, std::string expression)
    : name_(std::move(name)), expression_(std::move(expression)), parser_(std::make_unique<mu::Parser>()) {
  if (!isIdentifier(name_)) {
    throw std::invalid_argument("custom effect name '" + name_ +
                                "' must be an identifier (letters, digits, underscore)");
  }
  if (isLibraryEffect(name_)) {
    throw std::invalid_argument("custom effect name '" + name_ +
                                "' is a library effect; choose another name");
  }
  try {
    parser_->DefineVar("p", &bound_.p);
    parser_->DefineVar("dp", &bound_.dp);
    parser_->DefineVar("x", &bound_.x);
    parser_->DefineVar("v", &bound_.v);
    parser_->DefineVar("u", &bound_.u);
    parser_->DefineVar("y", &bound_.y);
    parser_->DefineVar("V", &bound_.V);
    parser_->DefineVar("t", &bound_.t);
    parser_->SetExpr(expression_);
    parser_->Eval();  // compiles and reports unknown names or syntax errors now, not mid-run
  } catch (const mu::Parser::exception_type& e) {
    throw std::invalid_argument("custom effect '" + name_ + "': cannot use expression '" + expression_ +
                                "': " + e.GetMsg() + " (signals: p, dp, x, v, u, y, V, t)");
  }
}

CustomFlowEffect::~CustomFlowEffect() = default;

std::unique_ptr<Effect> CustomFlowEffect::clone() const {
  return std::make_unique<CustomFlowEffect>(name_, expression_);
}

ParameterInfo CustomFlowEffect::parameter() const {
  return {name_ + "_theta", "m^3/s per unit of (" + expression_ + ")", 1.0};
}

double CustomFlowEffect::outflowPerUnit(const HydraulicSignals& signals) const {
  bound_ = signals;
  const double value = parser_->Eval();
  return std::isfinite(value) ? value : 0.0;
}

std::unique_ptr<CustomFlowEffect> parseCustomEffect(const std::string& name_equals_expression) {
  const auto pos = name_equals_expression.find('=');
  if (pos == std::string::npos || pos == 0 || pos + 1 == name_equals_expression.size()) {
    throw std::invalid_argument("custom effect '" + name_equals_expression + "' must read NAME=EXPR");
  }
  return std::make_unique<CustomFlowEffect>(name_equals_expression.substr(0, pos),
                                            name_equals_expression.substr(pos + 1));
}

}  // namespace die_cushion_ident
