#include "die_cushion_ident/core/estimation/identification_config.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "die_cushion_ident/core/model/hydraulic_model.h"

namespace die_cushion_ident {

const char* regressionFormName(RegressionForm form) {
  return form == RegressionForm::kIntegral ? "integral" : "derivative";
}

bool parseRegressionForm(const std::string& text, RegressionForm* form) {
  if (text == "integral") {
    *form = RegressionForm::kIntegral;
  } else if (text == "derivative" || text == "paper") {
    *form = RegressionForm::kDerivative;
  } else {
    return false;
  }
  return true;
}

std::array<double, kInputStreamCount> IdentificationConfig::appliedTopicDelays() const {
  std::array<double, kInputStreamCount> applied = topic_delays;
  for (double& d : applied) d = std::isfinite(d) ? d : 0.0;
  return applied;
}

UniformResampler::Config IdentificationConfig::resamplerConfig() const {
  UniformResampler::Config c = resampler;
  auto& pressure = c.plausible[static_cast<int>(InputStream::kPressure)];
  pressure.min_first = min_plausible_pressure;
  pressure.max_first =
      std::isnan(max_plausible_pressure) ? 2.0 * geometry.supply_pressure : max_plausible_pressure;
  auto& position = c.plausible[static_cast<int>(InputStream::kPosition)];
  position.min_first = -plausible_stroke_margin * geometry.stroke_length;
  position.max_first = (1.0 + plausible_stroke_margin) * geometry.stroke_length;
  position.max_abs_second = max_plausible_velocity;
  auto& valve = c.plausible[static_cast<int>(InputStream::kValve)];
  valve.min_first = -max_plausible_voltage;
  valve.max_first = max_plausible_voltage;
  valve.max_abs_second = 1.5;
  return c;
}

bool IdentificationConfig::topicDelaysSet() const {
  for (double d : topic_delays) {
    if (!std::isnan(d)) return true;
  }
  return false;
}

int IdentificationConfig::velocityHalfWidth() const {
  return std::max(1, static_cast<int>(std::lround(0.5 * velocity_window / resampler.sample_period)));
}

int IdentificationConfig::decimation() const {
  return static_cast<int>(std::lround(identification_period / resampler.sample_period));
}

namespace {
struct NumericKey {
  const char* name;
  double* (*field)(IdentificationConfig&);
};
// Integer keys (filter widths) are stored as double in this table's view and rounded when set.
const NumericKey kNumericKeys[] = {
    {"piston_area", [](IdentificationConfig& c) { return &c.geometry.piston_area; }},
    {"stroke_length", [](IdentificationConfig& c) { return &c.geometry.stroke_length; }},
    {"supply_pressure", [](IdentificationConfig& c) { return &c.geometry.supply_pressure; }},
    {"sample_period", [](IdentificationConfig& c) { return &c.resampler.sample_period; }},
    {"max_gap", [](IdentificationConfig& c) { return &c.resampler.max_gap; }},
    {"stale_timeout", [](IdentificationConfig& c) { return &c.resampler.stale_timeout; }},
    {"restart_jump", [](IdentificationConfig& c) { return &c.resampler.restart_jump; }},
    {"identification_period", [](IdentificationConfig& c) { return &c.identification_period; }},
    {"forgetting_factor", [](IdentificationConfig& c) { return &c.forgetting_factor; }},
    {"initial_covariance", [](IdentificationConfig& c) { return &c.initial_covariance; }},
    {"min_pressure", [](IdentificationConfig& c) { return &c.min_pressure; }},
    {"max_spool_opening", [](IdentificationConfig& c) { return &c.max_spool_opening; }},
    {"min_velocity", [](IdentificationConfig& c) { return &c.min_velocity; }},
    {"min_pressure_rate", [](IdentificationConfig& c) { return &c.min_pressure_rate; }},
    {"valve_natural_frequency", [](IdentificationConfig& c) { return &c.valve.natural_frequency; }},
    {"valve_damping", [](IdentificationConfig& c) { return &c.valve.damping; }},
    {"valve_gain", [](IdentificationConfig& c) { return &c.valve.gain; }},
    {"valve_dead_time", [](IdentificationConfig& c) { return &c.valve.dead_time; }},
    {"valve_command_hold", [](IdentificationConfig& c) { return &c.valve_command_hold; }},
    {"velocity_window", [](IdentificationConfig& c) { return &c.velocity_window; }},
    {"topic_delays/pressure", [](IdentificationConfig& c) { return &c.topic_delays[0]; }},
    {"topic_delays/position", [](IdentificationConfig& c) { return &c.topic_delays[1]; }},
    {"topic_delays/valve", [](IdentificationConfig& c) { return &c.topic_delays[2]; }},
    {"topic_delay_search", [](IdentificationConfig& c) { return &c.topic_delay_search; }},
    {"max_analysed_samples", [](IdentificationConfig& c) { return &c.max_analysed_samples; }},
    {"min_plausible_pressure", [](IdentificationConfig& c) { return &c.min_plausible_pressure; }},
    {"max_plausible_pressure", [](IdentificationConfig& c) { return &c.max_plausible_pressure; }},
    {"plausible_stroke_margin", [](IdentificationConfig& c) { return &c.plausible_stroke_margin; }},
    {"max_plausible_velocity", [](IdentificationConfig& c) { return &c.max_plausible_velocity; }},
    {"max_plausible_voltage", [](IdentificationConfig& c) { return &c.max_plausible_voltage; }},
    {"reference_temperature", [](IdentificationConfig& c) { return &c.oil.reference_temperature; }},
    {"bulk_modulus_temperature_coefficient",
     [](IdentificationConfig& c) { return &c.oil.bulk_modulus_coefficient; }},
    {"bulk_modulus_temperature_coefficient_std",
     [](IdentificationConfig& c) { return &c.oil.bulk_modulus_coefficient_std; }},
    {"leakage_temperature_coefficient", [](IdentificationConfig& c) { return &c.oil.leakage_coefficient; }},
    {"leakage_temperature_coefficient_std",
     [](IdentificationConfig& c) { return &c.oil.leakage_coefficient_std; }},
    {"min_plausible_oil_temperature",
     [](IdentificationConfig& c) { return &c.min_plausible_oil_temperature; }},
    {"max_plausible_oil_temperature",
     [](IdentificationConfig& c) { return &c.max_plausible_oil_temperature; }},
    {"max_plausible_oil_temperature_rate",
     [](IdentificationConfig& c) { return &c.max_plausible_oil_temperature_rate; }},
    {"oil_temperature_max_age", [](IdentificationConfig& c) { return &c.oil_temperature_max_age; }},
};

class Checker {
 public:
  void range(const char* name, double value, double low, double high, const char* unit,
             bool low_open = false) {
    const bool ok = std::isfinite(value) && (low_open ? value > low : value >= low) && value <= high;
    if (!ok) {
      std::ostringstream s;
      s << name << " = " << value << " is invalid: allowed " << (low_open ? "(" : "[") << low << ", " << high
        << "] " << unit;
      errors.push_back(s.str());
    }
  }
  void oddWidth(const char* name, int value, int low, int high) {
    if (value < low || value > high || value % 2 == 0) {
      std::ostringstream s;
      s << name << " = " << value << " is invalid: allowed odd integers in [" << low << ", " << high
        << "] samples";
      errors.push_back(s.str());
    }
  }
  std::vector<std::string> errors;
};
}  // namespace

std::vector<std::string> numericConfigKeys() {
  std::vector<std::string> keys;
  for (const auto& k : kNumericKeys) keys.push_back(k.name);
  keys.push_back("moving_average_width");
  keys.push_back("derivative_width");
  return keys;
}

std::string numericConfigProblem(const std::string& key, double value) {
  if ((key == "moving_average_width" || key == "derivative_width") &&
      !(std::isfinite(value) && value == std::floor(value))) {
    std::ostringstream s;
    s << key << " = " << value << " is invalid: allowed odd whole numbers of samples";
    return s.str();
  }
  return "";
}

bool setNumericConfigValue(IdentificationConfig& config, const std::string& key, double value) {
  if (key == "moving_average_width" || key == "derivative_width") {
    // A non-integer or absurd width becomes an invalid (even or negative) one, which validate() reports.
    const bool integral = std::isfinite(value) && value == std::floor(value) && std::abs(value) < 1e6;
    const int width = integral ? static_cast<int>(value) : -1;
    (key == "moving_average_width" ? config.moving_average_width : config.derivative_width) = width;
    return true;
  }
  for (const auto& k : kNumericKeys) {
    if (key == k.name) {
      *k.field(config) = value;
      return true;
    }
  }
  return false;
}

double numericConfigValue(const IdentificationConfig& config, const std::string& key) {
  if (key == "moving_average_width") return config.moving_average_width;
  if (key == "derivative_width") return config.derivative_width;
  for (const auto& k : kNumericKeys) {
    // The table's fields are read here, never written.
    if (key == k.name) return *k.field(const_cast<IdentificationConfig&>(config));
  }
  return std::numeric_limits<double>::quiet_NaN();
}

namespace {

// The press's geometry and the grid; returns the sample period the other keys are judged against.
double checkGeometryAndGrid(const IdentificationConfig& config, Checker& c) {
  const auto& geometry = config.geometry;
  const auto& resampler = config.resampler;
  c.range("piston_area", geometry.piston_area, 0.0, 10.0, "m^2", true);
  c.range("stroke_length", geometry.stroke_length, 0.0, 5.0, "m", true);
  c.range("supply_pressure", geometry.supply_pressure, 0.0, 1e9, "Pa", true);
  const std::size_t errors_before_period = c.errors.size();
  c.range("sample_period", resampler.sample_period, 1e-5, 0.1, "s");
  // Keys judged against sample_period are judged against the default where it is invalid: otherwise they
  // would only echo its problem under their own names.
  const bool period_ok = c.errors.size() == errors_before_period;
  const double period = period_ok ? resampler.sample_period : IdentificationConfig().resampler.sample_period;
  c.range("max_gap", resampler.max_gap, period, 10.0, "s", true);
  c.range("stale_timeout", resampler.stale_timeout, resampler.max_gap, 60.0, "s");
  c.range("restart_jump", resampler.restart_jump, resampler.stale_timeout, 3600.0, "s", true);
  c.oddWidth("moving_average_width", config.moving_average_width, 1, 1001);
  c.oddWidth("derivative_width", config.derivative_width, 3, 1001);
  c.range("identification_period", config.identification_period, period, 10.0, "s");
  if (period_ok && std::isfinite(config.identification_period) &&
      std::abs(config.identification_period / resampler.sample_period - config.decimation()) > 1e-6) {
    c.errors.push_back("identification_period = " + std::to_string(config.identification_period) +
                       " is invalid: must be a whole multiple of sample_period = " +
                       std::to_string(resampler.sample_period) + " s");
  }
  return period;
}

void checkEstimatorAndValve(const IdentificationConfig& config, Checker& c, double period) {
  c.range("forgetting_factor", config.forgetting_factor, 0.5, 1.0, "", false);
  c.range("initial_covariance", config.initial_covariance, 0.0, 1e12, "", true);
  c.range("min_pressure", config.min_pressure, -kAtmosphericPressure, 1e9, "Pa");
  c.range("max_spool_opening", config.max_spool_opening, 0.0, 1.0, "", true);
  c.range("min_velocity", config.min_velocity, 0.0, 10.0, "m/s");
  c.range("min_pressure_rate", config.min_pressure_rate, 0.0, 1e12, "Pa/s");
  c.range("valve_natural_frequency", config.valve.natural_frequency, 0.0, 5000.0, "Hz", true);
  c.range("valve_damping", config.valve.damping, 0.0, 10.0, "", true);
  c.range("valve_gain", config.valve.gain, -100.0, 100.0, "1/V");
  c.range("valve_dead_time", config.valve.dead_time, 0.0, 1.0, "s");
  // NaN means "not set" for these: a default from the data.
  if (!std::isnan(config.valve_command_hold))
    c.range("valve_command_hold", config.valve_command_hold, 0.0, 1.0, "s");
  for (int s = 0; s < kInputStreamCount; ++s) {
    if (std::isnan(config.topic_delays[s])) continue;
    const std::string key = std::string("topic_delays/") + inputStreamName(static_cast<InputStream>(s));
    c.range(key.c_str(), config.topic_delays[s], -1.0, 1.0, "s");
  }
  c.range("topic_delay_search", config.topic_delay_search, 0.0, 0.5, "s");
  c.range("max_analysed_samples", config.max_analysed_samples, 1e5, 1e9, "samples");
  c.range("velocity_window", config.velocity_window, 2.0 * period, 1.0, "s");
}

void checkPlausibleRanges(const IdentificationConfig& config, Checker& c) {
  c.range("min_plausible_pressure", config.min_plausible_pressure, -1e7, 1e9, "Pa");
  if (!std::isnan(config.max_plausible_pressure)) {
    c.range("max_plausible_pressure", config.max_plausible_pressure,
            std::max(config.min_plausible_pressure, 0.0), 1e10, "Pa", true);
  }
  c.range("plausible_stroke_margin", config.plausible_stroke_margin, 0.0, 10.0, "");
  c.range("max_plausible_velocity", config.max_plausible_velocity, 0.0, 1000.0, "m/s", true);
  c.range("max_plausible_voltage", config.max_plausible_voltage, 0.0, 1e4, "V", true);
  c.range("min_plausible_oil_temperature", config.min_plausible_oil_temperature, -100.0, 300.0, "degC");
  c.range("max_plausible_oil_temperature", config.max_plausible_oil_temperature,
          std::isfinite(config.min_plausible_oil_temperature) ? config.min_plausible_oil_temperature : -100.0,
          300.0, "degC", true);
  c.range("max_plausible_oil_temperature_rate", config.max_plausible_oil_temperature_rate, 0.0, 100.0, "K/s",
          true);
  c.range("oil_temperature_max_age", config.oil_temperature_max_age, 0.0, 3600.0, "s", true);
}

// The oil's temperature law: temperatures in degC, coefficients per kelvin (doc/equations.md).
void checkOilTemperatureLaw(const IdentificationConfig& config, Checker& c) {
  const OilTemperatureLaw& oil = config.oil;
  c.range("reference_temperature", oil.reference_temperature, -30.0, 150.0, "degC");
  // A bulk modulus that rises as the oil warms, or falls by more than 2 % a kelvin, is no oil's.
  c.range("bulk_modulus_temperature_coefficient", oil.bulk_modulus_coefficient, -0.02, 0.0, "1/K");
  c.range("bulk_modulus_temperature_coefficient_std", oil.bulk_modulus_coefficient_std, 0.0, 0.02, "1/K");
  // Viscosity falls as oil warms: a laminar leakage grows, by at most ~10 %/K for any hydraulic fluid.
  c.range("leakage_temperature_coefficient", oil.leakage_coefficient, 0.0, 0.1, "1/K");
  c.range("leakage_temperature_coefficient_std", oil.leakage_coefficient_std, 0.0, 0.1, "1/K");
}

// Each initial value names a parameter of the model and lies in its range.
void checkInitialParameters(const IdentificationConfig& config, Checker& c) {
  try {
    const HydraulicModel model =
        HydraulicModel::fromNames(config.geometry, config.effects, config.custom_effects, config.oil);
    for (const auto& [name, value] : config.initial_parameters) {
      bool known = false;
      for (const auto& info : model.parameterInfos()) {
        if (info.name != name) continue;
        known = true;
        if (!std::isfinite(value) || value < info.lower_bound || value > info.upper_bound ||
            ((name == "bulk_modulus" || name == "valve_flow_gain") && value <= 0.0)) {
          std::ostringstream s;
          s << "initial " << name << " = " << value << " is invalid: allowed (" << info.lower_bound << ", "
            << info.upper_bound << "] " << info.unit;
          c.errors.push_back(s.str());
        }
      }
      if (!known)
        c.errors.push_back("initial value given for '" + name + "', which is not a parameter of the model");
    }
  } catch (const std::exception& e) {
    c.errors.push_back(e.what());
  }
}

}  // namespace

std::vector<std::string> IdentificationConfig::validate() const {
  Checker c;
  const double period = checkGeometryAndGrid(*this, c);
  checkEstimatorAndValve(*this, c, period);
  checkPlausibleRanges(*this, c);
  checkOilTemperatureLaw(*this, c);
  checkInitialParameters(*this, c);
  return c.errors;
}

}  // namespace die_cushion_ident
