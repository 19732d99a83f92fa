#include "die_cushion_ident/core/simulation/die_cushion_simulator.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace die_cushion_ident {

namespace {
// Oil cannot be pulled below its vapour pressure; the chamber then cavitates and the model does not hold.
constexpr double kVapourPressureGauge = 3000.0 - kAtmosphericPressure;  // [Pa]

int indexOf(const HydraulicModel& model, const std::string& name) {
  const auto& infos = model.parameterInfos();
  for (std::size_t i = 0; i < infos.size(); ++i) {
    if (infos[i].name == name) return static_cast<int>(i);
  }
  return -1;
}
}  // namespace

std::map<std::string, double> defaultTrueParameters() {
  return {
      {"bulk_modulus", 1.2e9},           // oil with hoses
      {"valve_flow_gain", 6e-6},         // 600 l/min at half opening and 100 bar
      {"dead_volume", 3e-3},             // 3 l of hoses and valve block
      {"leakage_conductance", 1.5e-11},  // 9 l/min at 100 bar: a worn seal
      {"air_volume", 3e-4},              // 0.3 l of free air at atmospheric pressure
      {"valve_overlap", 0.03},
      {"tank_pressure", 6e5},
  };
}

DieCushionSimulator::DieCushionSimulator(const SimulatorConfig& config)
    : config_(config),
      model_(HydraulicModel::fromNames(config.geometry, config.effects, config.custom_effects, config.oil)),
      program_(config.cycle),
      controller_(config.controller, config.geometry.piston_area, config.geometry.supply_pressure),
      valve_(config.valve, std::min(config.integration_step, 1e-4)),
      rng_(config.seed) {
  if (!(config.integration_step > 0.0 && config.integration_step <= 1e-3)) {
    throw std::invalid_argument("simulator integration_step must be in (0, 1e-3] s");
  }
  if (!(config.control_period >= config.integration_step)) {
    throw std::invalid_argument("simulator control_period must be >= integration_step");
  }
  if (!(config.cycle.drawing_depth < config.geometry.stroke_length)) {
    throw std::invalid_argument("drawing_depth must be below stroke_length");
  }
  if (config.oil_temperature.recorded() &&
      !(std::isfinite(config.oil_temperature.warming_rate) && config.oil_temperature.sensor_rate > 0.0 &&
        config.oil_temperature.sensor_noise >= 0.0)) {
    throw std::invalid_argument(
        "simulator: the oil temperature's warming rate must be finite, its sensor rate > 0");
  }
  const auto defaults = defaultTrueParameters();
  true_parameters_ = model_.nominalParameters();
  for (int i = 0; i < model_.parameterCount(); ++i) {
    const auto it = defaults.find(model_.parameterInfos()[i].name);
    if (it != defaults.end()) true_parameters_(i) = it->second;
  }
  for (const auto& [name, value] : config.parameters) setTrueParameter(name, value);

  const auto start = program_.at(0.0);
  state_.p = start.pressure_setpoint;
  state_.x = start.x;
  const double rates[kInputStreamCount] = {config.sensors.pressure_rate, config.sensors.position_rate,
                                           config.sensors.valve_rate};
  for (int s = 0; s < kInputStreamCount; ++s) {
    if (!(rates[s] > 0.0)) throw std::invalid_argument("sensor rates must be > 0 Hz");
    next_sample_[s] = (0.3 * s) / rates[s];  // the streams are not sampled in step with each other
  }
  next_sample_[static_cast<int>(InputStream::kValve)] = 0.0;
}

void DieCushionSimulator::setTrueParameter(const std::string& name, double value) {
  const int i = indexOf(model_, name);
  if (i < 0) {
    throw std::invalid_argument("simulator: '" + name +
                                "' is not a parameter of the simulated model (effects: " +
                                std::to_string(model_.effectCount()) + " active)");
  }
  if (!std::isfinite(value))
    throw std::invalid_argument("simulator: parameter '" + name + "' must be finite");
  true_parameters_(i) = value;
}

double DieCushionSimulator::trueParameter(const std::string& name) const {
  const int i = indexOf(model_, name);
  if (i < 0) throw std::invalid_argument("simulator: no parameter '" + name + "'");
  return true_parameters_(i);
}

double DieCushionSimulator::pressureRate(double t, double p, double y) const {
  const auto point = program_.at(t);
  HydraulicSignals s;
  s.t = t;
  s.p = p;
  s.x = point.x;
  s.v = point.v;
  s.y = y;
  s.u = state_.u;
  s.V = model_.chamberVolume(point.x, true_parameters_(HydraulicModel::kDeadVolume));
  s.T = config_.oil_temperature.at(t);
  return model_.pressureRate(s, true_parameters_);
}

void DieCushionSimulator::integratePlant(double t0, double h, double y0, double y1) {
  const double ym = 0.5 * (y0 + y1);
  const double p = state_.p;
  const double k1 = pressureRate(t0, p, y0);
  const double k2 = pressureRate(t0 + 0.5 * h, p + 0.5 * h * k1, ym);
  const double k3 = pressureRate(t0 + 0.5 * h, p + 0.5 * h * k2, ym);
  const double k4 = pressureRate(t0 + h, p + h * k3, y1);
  state_.p = std::max(p + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4), kVapourPressureGauge);
}

void DieCushionSimulator::step(std::vector<SimulatedMeasurement>* out) {
  const double dt = config_.control_period;
  const auto now = program_.at(state_.t);
  state_.pressure_setpoint = now.pressure_setpoint;
  const double measured_p = state_.p + config_.sensors.pressure_noise * normal_(rng_);
  const bool continuous = !override_voltage_ && command_signal_;
  double added = 0.0;
  if (feed_forward_ && !override_voltage_ && !continuous) {
    // The press program is known ahead: the command is taken from where the trajectory will be when the
    // valve has answered (its lead time).
    const auto ahead = program_.at(state_.t + feed_forward_->leadTime());
    const double rate =
        (program_.at(state_.t + feed_forward_->leadTime() + dt).pressure_setpoint - ahead.pressure_setpoint) /
        dt;
    added = feed_forward_->command(ahead.pressure_setpoint, rate, ahead.x, ahead.v);
    if (!std::isfinite(added)) added = 0.0;  // no command the model can give: the PI alone
  }
  state_.u = override_voltage_ ? *override_voltage_
             : continuous      ? command_signal_(state_.t)
                               : controller_.update(dt, measured_p, now.pressure_setpoint, now.v, added);
  if (out) sampleValve(out);
  // The oil temperature's sensor, at its own slow rate.
  const OilTemperatureProfile& oil = config_.oil_temperature;
  if (out && oil.recorded() && state_.t + 1e-9 >= oil_index_ / oil.sensor_rate) {
    ++oil_index_;
    StreamSample m;
    m.stamp = state_.t;
    m.first = oil.at(state_.t) + oil.sensor_noise * normal_(rng_);
    m.second = std::numeric_limits<double>::quiet_NaN();
    oil_messages_.push_back(m);
  }
  const int substeps = std::max(1, static_cast<int>(std::ceil(dt / config_.integration_step - 1e-9)));
  const double h = dt / substeps;
  for (int i = 0; i < substeps; ++i) {
    const double y0 = valve_.position();
    // A continuous command changes within the control period: the valve sees it at each step's middle.
    const double y1 = valve_.advance(h, continuous ? command_signal_(state_.t + 0.5 * h) : state_.u);
    integratePlant(state_.t, h, y0, y1);
    state_.t += h;
    state_.y = y1;
    const auto point = program_.at(state_.t);
    state_.x = point.x;
    state_.v = point.v;
    state_.phase = point.phase;
    state_.cycle = point.cycle;
    if (out) sampleSensors(out);
  }
}

void DieCushionSimulator::run(double duration, std::vector<SimulatedMeasurement>* out) {
  const double end = state_.t + duration;
  while (state_.t < end - 1e-12) step(out);
}

void DieCushionSimulator::sampleValve(std::vector<SimulatedMeasurement>* out) {
  const SensorConfig& sc = config_.sensors;
  const int s = static_cast<int>(InputStream::kValve);
  if (state_.t + 0.5 * config_.integration_step < next_sample_[s]) return;
  ++sample_index_[s];
  next_sample_[s] = sample_index_[s] / sc.valve_rate;
  if (sc.drop_probability > 0.0 && uniform_(rng_) < sc.drop_probability) return;
  SimulatedMeasurement m;
  m.stream = InputStream::kValve;
  m.sample.stamp = state_.t;
  m.sample.first = state_.u;
  m.sample.second = sc.measure_spool ? std::clamp(state_.y + sc.spool_noise * normal_(rng_), -1.0, 1.0)
                                     : std::numeric_limits<double>::quiet_NaN();
  out->push_back(m);
}

void DieCushionSimulator::sampleSensors(std::vector<SimulatedMeasurement>* out) {
  const SensorConfig& sc = config_.sensors;
  const double rates[kInputStreamCount] = {sc.pressure_rate, sc.position_rate, sc.valve_rate};
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  for (int s = 0; s < kInputStreamCount; ++s) {
    if (static_cast<InputStream>(s) == InputStream::kValve) continue;
    if (state_.t + 1e-12 < next_sample_[s]) continue;
    const double period = 1.0 / rates[s];
    ++sample_index_[s];
    const double nominal = (sample_index_[s] + 0.3 * s) / rates[s];
    next_sample_[s] = std::max(nominal + sc.jitter * normal_(rng_), state_.t + 0.1 * period);
    if (sc.drop_probability > 0.0 && uniform_(rng_) < sc.drop_probability) continue;
    SimulatedMeasurement m;
    m.stream = static_cast<InputStream>(s);
    m.sample.stamp = state_.t;
    switch (m.stream) {
      case InputStream::kPressure:
        m.sample.first = state_.p + sc.pressure_noise * normal_(rng_);
        m.sample.second = kNaN;
        break;
      case InputStream::kPosition:
        m.sample.first = state_.x + sc.position_noise * normal_(rng_);
        m.sample.second = sc.publish_velocity ? state_.v + sc.velocity_noise * normal_(rng_) : kNaN;
        break;
      case InputStream::kValve:
        break;
    }
    out->push_back(m);
  }
}

void simulateOnGrid(DieCushionSimulator& simulator, double duration, UniformResampler& resampler,
                    std::vector<GridSample>* grid, ValveMessageSpool* valve_model, OilTemperatureInput* oil) {
  std::vector<SimulatedMeasurement> messages;
  simulator.run(duration, &messages);
  std::vector<StreamSample> temperatures;
  simulator.takeOilTemperature(&temperatures);
  const std::size_t first_new = grid->size();
  for (auto& m : messages) {
    if (valve_model && m.stream == InputStream::kValve) valve_model->process(&m.sample);
    resampler.push(m.stream, m.sample, grid);
  }
  if (!oil) return;
  for (const StreamSample& t : temperatures)
    oil->push(t.stamp, t.first, std::numeric_limits<double>::quiet_NaN());
  for (std::size_t i = first_new; i < grid->size(); ++i)
    (*grid)[i].T = static_cast<float>(oil->peek((*grid)[i].t));
}

std::vector<GridSample> simulateGrid(DieCushionSimulator& simulator, double duration,
                                     const UniformResampler::Config& config) {
  UniformResampler resampler(config);
  ValveMessageSpool valve_model(simulator.config().valve, config.max_gap, true);
  OilTemperatureInput oil;
  std::vector<GridSample> grid;
  simulateOnGrid(simulator, duration, resampler, &grid, &valve_model, &oil);
  const std::size_t before_flush = grid.size();
  resampler.flush(&grid);
  if (oil.any()) {
    for (std::size_t i = before_flush; i < grid.size(); ++i)
      grid[i].T = static_cast<float>(oil.peek(grid[i].t));
  }
  return grid;
}

double drawingPressureErrorRms(SimulatorConfig plant, std::shared_ptr<const PressureFeedForward> feed_forward,
                               bool nominal_velocity_feed_forward, int cycles) {
  plant.controller.velocity_feed_forward = nominal_velocity_feed_forward;
  DieCushionSimulator simulator(plant);
  simulator.setFeedForward(std::move(feed_forward));
  const double end = cycles * simulator.program().cycleDuration();
  double sum = 0.0;
  long n = 0;
  while (simulator.state().t < end) {
    simulator.step(nullptr);
    const auto& s = simulator.state();
    if (s.phase != StrokePhase::kDrawing) continue;
    sum += (s.p - s.pressure_setpoint) * (s.p - s.pressure_setpoint);
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : 0.0;
}

}  // namespace die_cushion_ident
