#include "die_cushion_ident/core/model/effects/custom_flow_effect.h"

#include <muParser.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "die_cushion_ident/core/model/effect_library.h"
#include "die_cushion_ident/core/util/formatted.h"

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
  probe();
}

namespace {
// The pressure rates at which a term is probed for its dependence on dp: zero, a typical rate and the
// extremes of a stiff cushion (1e8 Pa/s is 1000 bar/s), both signs.
constexpr double kRateUnit = 1e6;  // [Pa/s]
const double kProbeRates[] = {0.0, kRateUnit, -1e8, 0.5e8, 1e8};

bool sameValue(double a, double b, double scale) { return std::abs(a - b) <= 1e-9 * scale; }
}  // namespace

double CustomFlowEffect::evaluate(const HydraulicSignals& signals, double dp) const {
  bound_ = signals;
  bound_.dp = dp;
  const double value = parser_->Eval();
  return std::isfinite(value) ? value : 0.0;
}

namespace {

std::string describeSignals(const HydraulicSignals& s) {
  return formatted(FMT_STRING("p = {:g} Pa, dp = {:g} Pa/s, x = {:g} m, v = {:g} m/s, u = {:g} V, y = {:g}, "
                              "V = {:g} m^3"),
                   s.p, s.dp, s.x, s.v, s.u, s.y, s.V);
}

}  // namespace

double CustomFlowEffect::probedValue(const HydraulicSignals& s) const {
  constexpr double kAbsurd = 1e30;  // p^4 at 300 bar is 8e29: anything larger is no flow term
  bound_ = s;
  double value = 0.0;
  try {
    value = parser_->Eval();
  } catch (const mu::Parser::exception_type& e) {
    throw std::invalid_argument("custom effect '" + name_ + "': '" + expression_ +
                                "' cannot be evaluated at " + describeSignals(s) + ": " + e.GetMsg());
  }
  if (!std::isfinite(value) || std::abs(value) > kAbsurd) {
    const std::string number = formatted(FMT_STRING("{:g}"), value);
    throw std::invalid_argument(
        "custom effect '" + name_ + "': '" + expression_ + "' evaluates to " + number + " at " +
        describeSignals(s) + " (inside the operating range): a flow term must stay finite and below 1e30 " +
        "there; guard it, e.g. max(p, 1e5) in a denominator");
  }
  return value;
}

void CustomFlowEffect::probe() {
  // Evaluate over the signals' plausible operating range: a term that is non-finite or absurd there
  // would wreck the estimator, one that is always zero cannot be identified. Both are refused now, with
  // the point that shows it, instead of being reported later as "fitted" at their initial value.
  // The same points tell whether the term is affine in dp (a capacitance) or depends on it otherwise.
  static const double kP[] = {0.0, 1e5, 30e5, 100e5, 200e5, 300e5};
  static const double kX[] = {0.0, 0.1, 0.25};
  static const double kV[] = {-0.3, 0.0, 0.3};
  static const double kU[] = {-1.0, 0.0, 1.0};
  static const double kY[] = {-0.5, 0.0, 0.5};
  static const double kVolume[] = {0.005, 0.02};
  static const double kT[] = {0.0, 100.0};
  bool varies = false, uses_dp = false, affine = true;
  double first = std::numeric_limits<double>::quiet_NaN();
  for (double p : kP)
    for (double x : kX)
      for (double v : kV)
        for (double u : kU)
          for (double y : kY)
            for (double volume : kVolume)
              for (double t : kT) {
                double at[5];
                for (int k = 0; k < 5; ++k) {
                  at[k] = probedValue({t, p, kProbeRates[k], x, v, u, y, volume});
                  if (std::isnan(first)) first = at[k];
                  varies |= at[k] != first;
                }
                const double scale = std::abs(at[0]) + std::abs(at[2]) + std::abs(at[4]) + 1e-300;
                const double slope = (at[1] - at[0]) / kRateUnit;
                uses_dp |= !(at[1] == at[0] && at[2] == at[0] && at[3] == at[0] && at[4] == at[0]);
                affine &= sameValue(at[2], at[0] - 1e8 * slope, scale) &&
                          sameValue(at[3], at[0] + 0.5e8 * slope, scale) &&
                          sameValue(at[4], at[0] + 1e8 * slope, scale);
              }
  if (!varies && first == 0.0) {
    throw std::invalid_argument("custom effect '" + name_ + "': '" + expression_ +
                                "' is 0 everywhere in the operating range: there is no flow to identify");
  }
  dp_affine_ = uses_dp && affine;
  dp_nonlinear_ = uses_dp && !affine;
}

CustomFlowEffect::~CustomFlowEffect() = default;

std::unique_ptr<Effect> CustomFlowEffect::clone() const {
  return std::make_unique<CustomFlowEffect>(name_, expression_);
}

ParameterInfo CustomFlowEffect::parameter() const {
  return {name_ + "_theta", "m^3/s per unit of (" + expression_ + ")", 1.0};
}

double CustomFlowEffect::capacitancePerUnit(const HydraulicSignals& signals) const {
  if (!dp_affine_) return 0.0;
  return (evaluate(signals, kRateUnit) - evaluate(signals, 0.0)) / kRateUnit;
}

double CustomFlowEffect::outflowPerUnit(const HydraulicSignals& signals) const {
  return evaluate(signals, dp_affine_ ? 0.0 : signals.dp);
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
