#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "die_cushion_ident/core/control/pressure_feed_forward.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/signal/oil_temperature_input.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"
#include "die_cushion_ident/core/simulation/press_cycle.h"
#include "die_cushion_ident/core/simulation/pressure_controller.h"
#include "die_cushion_ident/core/valve/servo_valve.h"
#include "die_cushion_ident/core/valve/valve_message_spool.h"

namespace die_cushion_ident {

/// Sensors of the simulated cushion: Gaussian noise, per-stream rates and sampling-instant jitter.
struct SensorConfig {
  double pressure_noise = 0.2e5;  ///< [Pa] standard deviation
  double position_noise = 2e-6;   ///< [m]
  double velocity_noise = 1e-4;   ///< [m/s]
  double spool_noise = 0.002;     ///< [-]
  double pressure_rate = 1000.0;  ///< [Hz]
  double position_rate = 1000.0;
  double valve_rate = 1000.0;     ///< at most the control rate: sampled at command updates
  double jitter = 5e-5;           ///< [s] standard deviation of the sampling instant (pressure, position)
  bool publish_velocity = true;   ///< JointState velocity[0] present
  bool measure_spool = true;      ///< spool position measured (else NaN)
  double drop_probability = 0.0;  ///< chance that a message is lost
};

/// The oil's temperature while the simulated press runs, and its sensor.
struct OilTemperatureProfile {
  /// [degC] at the start; NaN (default): the oil's temperature is neither modelled nor recorded.
  double start = std::numeric_limits<double>::quiet_NaN();
  double warming_rate =
      0.0;  ///< [K/s] the oil warms linearly over the run (a shift's start: ~20 K in 30 min)
  double sensor_noise = 0.05;  ///< [K] standard deviation of the sensor's readings
  double sensor_rate = 2.0;    ///< [Hz] temperature messages
  bool recorded() const { return std::isfinite(start); }
  /// [degC] the true oil temperature at t (NaN where none is modelled).
  double at(double t) const { return start + warming_rate * t; }
};

struct SimulatorConfig {
  CylinderGeometry geometry;
  std::vector<std::string> effects;          ///< active in the plant
  std::vector<std::string> custom_effects;   ///< NAME=EXPR, active in the plant
  std::map<std::string, double> parameters;  ///< true physical parameters by name; others take defaults
  /// The oil's law; with the effect oil_temperature the true parameters hold at its origin (the reference
  /// temperature, 40 degC, unless set), its coefficient bulk_modulus_temperature_coefficient.
  OilTemperatureLaw oil;
  OilTemperatureProfile oil_temperature;  ///< the oil's temperature over the run, and its sensor
  ServoValveParameters valve;
  PressCycleConfig cycle;
  PressureControllerConfig controller;
  SensorConfig sensors;
  double integration_step = 1e-4;  ///< [s] RK4 step of the plant
  double control_period = 1e-3;    ///< [s] controller and valve command rate
  std::uint64_t seed = 1;
};

/// True default parameters of the simulated cushion (a 250 mm cylinder with hoses), by parameter name.
std::map<std::string, double> defaultTrueParameters();

/// One message the simulated sensors produced.
struct SimulatedMeasurement {
  InputStream stream;
  StreamSample sample;
};

/// The die cushion integrated with the same physics the identifier assumes (HydraulicModel), driven by a
/// press-cycle program, a pressure controller and the servo valve's spool dynamics; cavitation clamps the
/// pressure at vapour pressure, where the model does not hold. Ground truth for tests and the demo.
class DieCushionSimulator {
 public:
  struct State {
    double t = 0.0, p = 0.0, x = 0.0, v = 0.0, y = 0.0, u = 0.0;
    double pressure_setpoint = 0.0;
    StrokePhase phase = StrokePhase::kRest;
    int cycle = 0;
  };

  explicit DieCushionSimulator(const SimulatorConfig& config);

  /// Advances by one control period; messages that fell due are appended to `out` in stamp order per stream.
  /// The oil temperature's messages (config.oil_temperature) are kept for takeOilTemperature().
  void step(std::vector<SimulatedMeasurement>* out);
  /// The oil temperature messages (stamp, degC in `first`) sent since the last call, oldest first.
  void takeOilTemperature(std::vector<StreamSample>* out) {
    out->insert(out->end(), oil_messages_.begin(), oil_messages_.end());
    oil_messages_.clear();
  }
  /// Advances by `duration` seconds.
  void run(double duration, std::vector<SimulatedMeasurement>* out);

  /// While set, the valve follows this voltage instead of the pressure controller (a sine sweep).
  void setValveCommandOverride(std::optional<double> voltage) { override_voltage_ = voltage; }
  /// While set (and no override is), the valve follows u(t) evaluated at every integration step: a command
  /// from a continuous signal generator rather than a held amplifier output. Messages sample it.
  void setValveCommandSignal(std::function<double(double)> signal) { command_signal_ = std::move(signal); }
  /// While set, the model's feed-forward voltage for the program's pressure set-point (and its rate) at
  /// the cushion's motion is added to the pressure controller's command (paper, Fig. 19).
  void setFeedForward(std::shared_ptr<const PressureFeedForward> feed_forward) {
    feed_forward_ = std::move(feed_forward);
  }
  /// Changes a true parameter from now on (e.g. a bulk-modulus step when air is drawn in).
  void setTrueParameter(const std::string& name, double value);

  const State& state() const { return state_; }
  const HydraulicModel& model() const { return model_; }
  const ParameterVector& trueParameters() const { return true_parameters_; }
  double trueParameter(const std::string& name) const;
  const PressCycleProgram& program() const { return program_; }
  const SimulatorConfig& config() const { return config_; }

 private:
  double pressureRate(double t, double p, double y) const;
  void integratePlant(double t0, double h, double y0, double y1);
  void sampleSensors(std::vector<SimulatedMeasurement>* out);
  // The valve amplifier reports at its command updates: the voltage in force from the stamp on and the
  // spool position at that instant (the convention the sweep analysis relies on, doc/valve_sweep.md).
  void sampleValve(std::vector<SimulatedMeasurement>* out);

  SimulatorConfig config_;
  HydraulicModel model_;
  ParameterVector true_parameters_;
  PressCycleProgram program_;
  PressureController controller_;
  ServoValve valve_;
  std::optional<double> override_voltage_;
  std::function<double(double)> command_signal_;
  std::shared_ptr<const PressureFeedForward> feed_forward_;
  State state_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
  double next_sample_[kInputStreamCount] = {0.0, 0.0, 0.0};
  std::int64_t sample_index_[kInputStreamCount] = {0, 0, 0};
  std::int64_t oil_index_ = 0;
  std::vector<StreamSample> oil_messages_;
};

/// Runs `simulator` for `duration` seconds and passes what its sensors sent through `resampler` onto
/// `grid` (not flushed: a run in several parts keeps one grid); `valve_model` (may be null) adds its spool
/// to the valve messages as the identification pipeline does; `oil` (may be null) takes the oil temperature's
/// messages and gives the new grid samples their temperature, as the pipeline does.
void simulateOnGrid(DieCushionSimulator& simulator, double duration, UniformResampler& resampler,
                    std::vector<GridSample>* grid, ValveMessageSpool* valve_model = nullptr,
                    OilTemperatureInput* oil = nullptr);
/// The same for one run, flushed: the uniform samples of `duration` seconds of the simulated press, with
/// the simulated valve's own model spool (a valve known exactly, as after a sweep).
std::vector<GridSample> simulateGrid(DieCushionSimulator& simulator, double duration,
                                     const UniformResampler::Config& resampler = {});

/// The pressure tracking error rms [Pa] during drawing over `cycles` press cycles of `plant` under its PI
/// controller, with the controller's nominal velocity feed-forward on or off and `feed_forward` (a model's,
/// may be null) added: the paper's Fig. 19 comparison.
double drawingPressureErrorRms(SimulatorConfig plant, std::shared_ptr<const PressureFeedForward> feed_forward,
                               bool nominal_velocity_feed_forward, int cycles);

}  // namespace die_cushion_ident
