#include "die_cushion_ident/core/model/formula_term.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {
// The breakpoint in the unit a press engineer reads: bar, mm, mm/s, spool fraction.
std::string readable(char signal, double value) {
  switch (signal) {
    case 'p':
      return formatted(FMT_STRING("{:.1f} bar"), value * 1e-5);
    case 'x':
      return formatted(FMT_STRING("{:.1f} mm"), value * 1e3);
    case 'v':
      return formatted(FMT_STRING("{:.0f} mm/s"), value * 1e3);
    default:
      return formatted(FMT_STRING("{:.3g}"), value);
  }
}

// "s-B" written without a double sign: x-0.12, v+0.05.
std::string minus(char signal, double breakpoint) {
  return std::string(1, signal) + (breakpoint >= 0.0 ? "-" + compactNumber(breakpoint)
                                                     : "+" + compactNumber(-breakpoint));
}
}  // namespace

std::string compactNumber(double value) {
  std::string s = formatted(FMT_STRING("{:.4g}"), value);
  // 1.21e+07 -> 1.21e7, 1e-05 -> 1e-5
  const auto e = s.find('e');
  if (e != std::string::npos) {
    std::string mantissa = s.substr(0, e), exponent = s.substr(e + 1);
    const bool negative = exponent[0] == '-';
    if (exponent[0] == '+' || exponent[0] == '-') exponent = exponent.substr(1);
    while (exponent.size() > 1 && exponent[0] == '0') exponent = exponent.substr(1);
    s = mantissa + "e" + (negative ? "-" : "") + exponent;
  }
  return s;
}

FormulaTerm::FormulaTerm(Shape shape, char signal, double breakpoint, double supply_pressure, int sign)
    : shape_(shape), signal_(signal), breakpoint_(breakpoint), supply_pressure_(supply_pressure), sign_(sign) {
  if (signal != 'p' && signal != 'x' && signal != 'v' && signal != 'y') {
    throw std::invalid_argument(std::string("formula term on unknown signal '") + signal + "'");
  }
}

std::vector<FormulaTerm> FormulaTerm::searchSpace(double supply_pressure) {
  std::vector<FormulaTerm> space;
  const auto add = [&](Shape shape, char signal) { space.emplace_back(shape, signal, 0.0, supply_pressure); };
  add(Shape::kHingeAbove, 'p');
  add(Shape::kHingeBelow, 'p');
  for (char s : {'x', 'v', 'y'}) {
    add(Shape::kHingeAbove, s);
    add(Shape::kHingeBelow, s);
    add(Shape::kPressureAbove, s);
    add(Shape::kPressureBelow, s);
  }
  add(Shape::kOrifice, 'p');
  add(Shape::kQuadratic, 'p');
  add(Shape::kDrainNotch, 'y');
  add(Shape::kSupplyNotch, 'y');
  add(Shape::kComplianceAbove, 'p');
  add(Shape::kComplianceBelow, 'p');
  add(Shape::kComplianceFalling, 'p');
  add(Shape::kComplianceAbove, 'x');
  add(Shape::kComplianceBelow, 'x');
  return space;
}

bool FormulaTerm::hasBreakpoint() const { return shape_ != Shape::kOrifice && shape_ != Shape::kQuadratic; }

FormulaTerm FormulaTerm::withBreakpoint(double breakpoint) const {
  FormulaTerm t = *this;
  t.breakpoint_ = breakpoint;
  return t;
}

FormulaTerm FormulaTerm::withSign(int sign) const {
  FormulaTerm t = *this;
  t.sign_ = sign;
  return t;
}

bool FormulaTerm::isCompliance() const {
  return shape_ == Shape::kComplianceAbove || shape_ == Shape::kComplianceBelow ||
         shape_ == Shape::kComplianceFalling;
}

bool FormulaTerm::mayBeInflow() const {
  // A relief flows out, conductances and compliances are positive; flows driven by the motion or the
  // spool, and a refill below a pressure, may go either way.
  if (shape_ == Shape::kHingeBelow) return true;
  return shape_ == Shape::kHingeAbove && signal_ != 'p';
}

int FormulaTerm::complexity() const {
  if (!hasBreakpoint()) return 1;
  const bool product = shape_ == Shape::kPressureAbove || shape_ == Shape::kPressureBelow ||
                       shape_ == Shape::kDrainNotch || shape_ == Shape::kSupplyNotch;
  return product ? 3 : 2;
}

double FormulaTerm::signalValue(double p, double x, double v, double y) const {
  switch (signal_) {
    case 'p': return p;
    case 'x': return x;
    case 'v': return v;
    default: return y;
  }
}

double FormulaTerm::value(double p, double x, double v, double y) const {
  const double s = signalValue(p, x, v, y);
  const double b = breakpoint_;
  double f = 0.0;
  switch (shape_) {
    case Shape::kHingeAbove: f = std::max(s - b, 0.0); break;
    case Shape::kHingeBelow: f = std::max(b - s, 0.0); break;
    case Shape::kPressureAbove: f = s > b ? p : 0.0; break;
    case Shape::kPressureBelow: f = s < b ? p : 0.0; break;
    case Shape::kOrifice: f = std::sqrt(std::max(p, 0.0)); break;
    case Shape::kQuadratic: f = p * p; break;
    case Shape::kDrainNotch: f = std::max(y - b, 0.0) * std::sqrt(std::max(p, 0.0)); break;
    case Shape::kSupplyNotch: f = -std::max(b - y, 0.0) * std::sqrt(std::max(supply_pressure_ - p, 0.0)); break;
    case Shape::kComplianceAbove: f = s > b ? 1.0 : 0.0; break;
    case Shape::kComplianceBelow: f = s < b ? 1.0 : 0.0; break;
    case Shape::kComplianceFalling: f = std::max(b - p, 0.0); break;
  }
  return sign_ * f;
}

std::string FormulaTerm::expression() const {
  const std::string s(1, signal_);
  const std::string b = compactNumber(breakpoint_);
  std::string e;
  switch (shape_) {
    case Shape::kHingeAbove: e = "max(" + minus(signal_, breakpoint_) + ",0)"; break;
    case Shape::kHingeBelow: e = "max(" + b + "-" + s + ",0)"; break;
    case Shape::kPressureAbove: e = "p*(" + s + ">" + b + ")"; break;
    case Shape::kPressureBelow: e = "p*(" + s + "<" + b + ")"; break;
    case Shape::kOrifice: e = "sqrt(max(p,0))"; break;
    case Shape::kQuadratic: e = "p^2"; break;
    case Shape::kDrainNotch: e = "max(" + minus('y', breakpoint_) + ",0)*sqrt(max(p,0))"; break;
    case Shape::kSupplyNotch:
      e = "-max(" + b + "-y,0)*sqrt(max(" + compactNumber(supply_pressure_) + "-p,0))";
      break;
    case Shape::kComplianceAbove: e = "dp*(" + s + ">" + b + ")"; break;
    case Shape::kComplianceBelow: e = "dp*(" + s + "<" + b + ")"; break;
    case Shape::kComplianceFalling: e = "dp*max(" + b + "-p,0)"; break;
  }
  return sign_ < 0 ? "-" + e : e;
}

std::string FormulaTerm::name() const {
  switch (shape_) {
    case Shape::kHingeAbove:
    case Shape::kHingeBelow:
      if (signal_ == 'p') return shape_ == Shape::kHingeAbove ? "relief" : sign_ < 0 ? "refill" : "low_pressure_outflow";
      return signal_ == 'x' ? "stroke_flow" : signal_ == 'v' ? "velocity_flow" : "spool_flow";
    case Shape::kPressureAbove:
    case Shape::kPressureBelow: return signal_ == 'x' ? "stroke_leak" : signal_ == 'v' ? "motion_leak" : "spool_leak";
    case Shape::kOrifice: return "orifice_leak";
    case Shape::kQuadratic: return "quadratic_leak";
    case Shape::kDrainNotch: return "drain_notch";
    case Shape::kSupplyNotch: return "supply_notch";
    case Shape::kComplianceAbove:
      return signal_ == 'p' ? "accumulator" : "stroke_compliance";
    case Shape::kComplianceBelow: return signal_ == 'p' ? "soft_low_pressure" : "stroke_compliance";
    case Shape::kComplianceFalling: return "low_pressure_compliance";
  }
  return "term";
}

std::string FormulaTerm::unit() const {
  switch (shape_) {
    case Shape::kHingeAbove:
    case Shape::kHingeBelow:
      return signal_ == 'p' ? "m^3/(s*Pa)" : signal_ == 'x' ? "m^2/s" : signal_ == 'v' ? "m^2" : "m^3/s";
    case Shape::kPressureAbove:
    case Shape::kPressureBelow: return "m^3/(s*Pa)";
    case Shape::kOrifice:
    case Shape::kDrainNotch:
    case Shape::kSupplyNotch: return "m^3/(s*Pa^0.5)";
    case Shape::kQuadratic: return "m^3/(s*Pa^2)";
    case Shape::kComplianceAbove:
    case Shape::kComplianceBelow: return "m^3/Pa";
    case Shape::kComplianceFalling: return "m^3/Pa^2";
  }
  return "";
}

std::string FormulaTerm::explanation() const {
  const std::string at = readable(signal_, breakpoint_);
  const std::string direction = sign_ < 0 ? "into" : "out of";
  const char* what = signal_ == 'x' ? "the stroke" : signal_ == 'v' ? "the velocity" : "the spool opening";
  switch (shape_) {
    case Shape::kHingeAbove:
      if (signal_ == 'p') return "a flow out of the chamber that starts above " + at + ", like a relief valve cracking";
      return "a flow " + direction + " the chamber that grows with " + what + " above " + at;
    case Shape::kHingeBelow:
      if (signal_ == 'p') {
        return sign_ < 0 ? "a flow into the chamber below " + at + ", like an anti-cavitation (refill) check valve"
                         : "a flow out of the chamber that grows as the pressure falls below " + at;
      }
      return "a flow " + direction + " the chamber that grows as " + what + " falls below " + at;
    case Shape::kPressureAbove:
    case Shape::kPressureBelow: {
      const std::string side = shape_ == Shape::kPressureAbove ? " above " : " below ";
      if (signal_ == 'x') {
        return "a leakage proportional to pressure, open only" + std::string(shape_ == Shape::kPressureAbove ? " beyond " : " before ") +
               at + " of stroke, like a groove or port that the piston seal passes";
      }
      return "a leakage proportional to pressure, open only while " + std::string(what) + " is" + side + at;
    }
    case Shape::kOrifice:
      return "a leakage through a sharp-edged orifice (turbulent, proportional to the square root of the pressure)";
    case Shape::kQuadratic: return "a flow out of the chamber growing with the square of the pressure (a seal lifting)";
    case Shape::kDrainNotch:
      return "the drain edge passes more oil beyond a spool opening of " + at +
             " (a notch, or a larger flow gain at large openings)";
    case Shape::kSupplyNotch:
      return "the supply edge passes more oil beyond a spool opening of " + at;
    case Shape::kComplianceAbove:
      if (signal_ == 'p') return "a compliance that switches in above " + at + ", like a spring-loaded accumulator";
      return "an extra compliance beyond " + at + " of stroke, like a volume the piston uncovers";
    case Shape::kComplianceBelow:
      if (signal_ == 'p') return "the chamber is softer below " + at + " (air, or hoses not yet stretched)";
      return "an extra compliance before " + at + " of stroke";
    case Shape::kComplianceFalling: return "a compliance that grows as the pressure falls below " + at;
  }
  return "";
}

}  // namespace die_cushion_ident
