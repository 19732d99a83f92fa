#pragma once

#include <Eigen/Core>
#include <array>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "die_cushion_ident/core/model/hydraulic_signals.h"
#include "die_cushion_ident/core/model/oil_temperature_law.h"
#include "die_cushion_ident/core/signal/oil_temperature_input.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"
#include "die_cushion_ident/core/valve/servo_valve.h"

namespace die_cushion_ident {

/// How the volume balance becomes a regression (doc/equations.md).
enum class RegressionForm {
  /// Default. The balance's primitives (state functions and running integrals) are filtered by the moving
  /// average and differenced over the derivative window: the filtered equation holds exactly, no smear bias.
  kIntegral,
  /// The paper's: pressure and position are filtered, differentiated, and the regressors formed from the
  /// filtered signals. Biased where the pressure changes fast; kept for comparison.
  kDerivative,
};
const char* regressionFormName(RegressionForm form);
bool parseRegressionForm(const std::string& text, RegressionForm* form);

/// Everything the hydraulic identification needs; the ROS layer and analyze_bag fill it from parameters/YAML.
/// Names match the configuration keys; units SI.
constexpr double kUnsetDelay() { return std::numeric_limits<double>::quiet_NaN(); }

struct IdentificationConfig {
  CylinderGeometry geometry;                ///< piston_area, stroke_length, supply_pressure
  std::vector<std::string> effects;         ///< library effects in the model
  std::vector<std::string> custom_effects;  ///< NAME=EXPR
  /// The oil's temperature law: reference temperature [degC], the coefficients [1/K] of the bulk modulus and
  /// of a laminar leakage, and the temperature the model's parameters hold at (doc/equations.md).
  OilTemperatureLaw oil;

  UniformResampler::Config resampler;    ///< sample_period 0.002 s (paper), gaps, staleness
  int moving_average_width = 31;         ///< b [samples], odd (paper: 31)
  int derivative_width = 25;             ///< d [samples], odd (paper: 25)
  double identification_period = 0.010;  ///< [s], multiple of sample_period (paper: 10 ms)
  RegressionForm regression_form = RegressionForm::kIntegral;

  double forgetting_factor = 0.998;  ///< lambda (paper: 0.998)
  /// P0 = this * I for the normalised parameters (1 = the initial value): a prior std of 1000x the initial
  /// value, so weakly excited effects (air shows only at low pressure) are not pulled towards their start.
  double initial_covariance = 1e6;
  /// Initial physical values by parameter name; the rest start at their nominal values. In normalised form
  /// every parameter then starts at 1, as in the paper.
  std::map<std::string, double> initial_parameters;

  double min_pressure = 5e5;        ///< [Pa] below: near cavitation, model not trusted
  double max_spool_opening = 0.95;  ///< [-] beyond: valve saturated
  double min_velocity = 0.002;      ///< [m/s] excitation dead zone: below this and ...
  double min_pressure_rate = 2e6;   ///< [Pa/s] ... below this, a window carries no information

  /// Spool model used when the spool position is not measured (NaN on the valve topic).
  ServoValveParameters valve;
  /// The valve model's spool for the recorded commands drives the free run instead of the measured spool
  /// (whose white noise a shut valve integrates): set where the model is known to follow the spool
  /// (SettingsFromRecording fitted it to the recording's operation). Where the spool is not measured the
  /// model's spool drives everything anyway.
  bool valve_model_drives_free_run = false;
  /// The covariance of `valve`'s natural_frequency [Hz], damping, gain [1/V] and dead_time [s] where it was
  /// fitted to the recording's operation (ValveOperationFit::covariance), which made the grid's y_model; zero
  /// where it is configured. Its error moves the free run's spool, and with it the refined parameters
  /// (ParameterUncertainty::valve_model).
  Eigen::Matrix4d valve_covariance = Eigen::Matrix4d::Zero();
  /// The held-out tests refine each training fit by its free run's error (refineByOutputError) where that
  /// reaches the noise: set by the offline analysis; the live ranking, which must keep pace with the
  /// strokes, leaves it off.
  bool refine_held_out_fits = false;
  /// [Pa] the pressure sensor's noise read from its messages (MessageNoise::forGrid), set by the analyses
  /// where the grid lies between the messages and its own second differences see interpolations; 0: the
  /// noise is estimated on the grid. Not a configuration key.
  double grid_pressure_noise = 0.0;
  /// [s] how long the valve amplifier holds each command; NaN (default) = one valve message interval;
  /// 0 = the voltage was sampled from a continuous signal (no hold to divide out of a sweep's response).
  double valve_command_hold = std::numeric_limits<double>::quiet_NaN();

  /// [s] window of the least-squares differentiator that derives the velocity from the position where
  /// the position topic carries none (VelocityFromPosition); it delays every sample by half of it. The
  /// default (one grid sample each side: a central difference) keeps the impact sharp for the stroke phases
  /// and the equation-error fit (the free run reads the position's own slope: doc/sensor_configurations.md).
  double velocity_window = 0.004;
  /// [s] how late each topic's stamps are against the true measurement instant (pressure, position,
  /// valve); subtracted from the stamps. NaN = not set: analyze_bag estimates it from the data, the node
  /// uses 0. Only differences between topics matter.
  std::array<double, kInputStreamCount> topic_delays = {kUnsetDelay(), kUnsetDelay(), kUnsetDelay()};
  /// [s] the standard uncertainty of the topics' common clock offset against the pressure where the offsets
  /// were estimated and applied: the free run's (its sandwich) where it pinned it on the survey, else the
  /// integral form's resolution; 0 where the offsets were configured or none was applied. Its error shifts
  /// the measured pressure against every input, and with it the refined parameters
  /// (ParameterUncertainty::clock_offsets). Not a configuration key.
  double common_delay_std = 0.0;
  /// [s] largest clock offset between two topics that the estimate from the data looks for.
  double topic_delay_search = 0.05;
  /// [samples] the most grid the offline analysis keeps (48 bytes each): a longer recording's cycle-based
  /// analyses judge evenly spaced whole cycles (EvenlyThinnedCycles). 600 000 = 20 minutes at 2 ms, 29 MB.
  double max_analysed_samples = 600000;

  /// Physically plausible inputs; a message outside is rejected and counted like a NaN one.
  double min_plausible_pressure = -2e5;  ///< [Pa] gauge: vacuum is -1 bar, plus room for sensor noise
  /// [Pa]; NaN (default) = twice the supply pressure
  double max_plausible_pressure = std::numeric_limits<double>::quiet_NaN();
  double plausible_stroke_margin = 0.1;   ///< x in [-margin s, (1 + margin) s]
  double max_plausible_velocity = 10.0;   ///< [m/s] |v|
  double max_plausible_voltage = 100.0;   ///< [V] |u|; the spool |y| <= 1.5 (normalised to 1)
  /// [degC] the oil temperature topic's plausible range (a mineral oil's pour point to its flash point's
  /// margin); outside, and NaN, is rejected and counted.
  double min_plausible_oil_temperature = -30.0;
  double max_plausible_oil_temperature = 150.0;
  /// [K/s] an oil in a tank of litres cannot change faster: a message that jumps more from the last accepted
  /// one is rejected as implausible (a sensor fault, a wrong channel).
  double max_plausible_oil_temperature_rate = 2.0;
  /// [s] how long the last oil temperature holds without a new message; beyond, the grid has none (the
  /// topic fell silent: the oil_temperature effect does nothing there, and the analysis says so).
  double oil_temperature_max_age = 10.0;
  /// The resampler's configuration with the plausible bounds filled in from the geometry.
  UniformResampler::Config resamplerConfig() const;
  /// The oil temperature topic's checks.
  OilTemperatureInput::Config oilTemperatureInputConfig() const {
    OilTemperatureInput::Config c;
    c.min_plausible = min_plausible_oil_temperature;
    c.max_plausible = max_plausible_oil_temperature;
    c.max_rate = max_plausible_oil_temperature_rate;
    c.max_age = oil_temperature_max_age;
    c.gap = 0.5 * oil_temperature_max_age;
    return c;
  }

  /// topic_delays with unset entries as 0.
  std::array<double, kInputStreamCount> appliedTopicDelays() const;
  bool topicDelaysSet() const;
  int velocityHalfWidth() const;  ///< K of VelocityFromPosition [samples]

  /// Every problem as "name = value is invalid: allowed range"; empty when the configuration is usable.
  std::vector<std::string> validate() const;
  int decimation() const;  ///< grid samples per identification step
};

/// Names of the numeric configuration keys (the same in YAML, ROS parameters and on command lines).
std::vector<std::string> numericConfigKeys();
/// A problem with a value before it is set, in words ("" if none): a filter width that is not a whole
/// number is named as given (31.5), not as the invalid width it would become.
std::string numericConfigProblem(const std::string& key, double value);
/// Sets a numeric key (e.g. "forgetting_factor", "piston_area", "max_gap"); false if the key is unknown.
/// Values are checked later by validate(), so that every problem is reported at once.
bool setNumericConfigValue(IdentificationConfig& config, const std::string& key, double value);
/// A numeric key's value (the filter widths as numbers); NaN for an unknown key.
double numericConfigValue(const IdentificationConfig& config, const std::string& key);

}  // namespace die_cushion_ident
