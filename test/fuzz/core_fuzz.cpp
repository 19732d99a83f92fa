#include "core_fuzz.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "die_cushion_ident/core/analysis/offline_analysis.h"
#include "die_cushion_ident/core/control/valve_supervisor.h"
#include "die_cushion_ident/core/estimation/identification_pipeline.h"
#include "die_cushion_ident/core/model/effect_library.h"
#include "die_cushion_ident/core/valve/recorded_sweep.h"
#include "die_cushion_ident/core/valve/servo_valve_fit.h"
#include "die_cushion_ident/core/valve/valve_sweep.h"

namespace die_cushion_ident {
namespace fuzz {

namespace {

class Bytes {
 public:
  Bytes(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool empty() const { return position_ >= size_; }
  std::uint8_t byte() { return position_ < size_ ? data_[position_++] : 0; }
  /// A value in [lo, hi], or (1 time in 16) something hostile: NaN, +-Inf, 0, negative, huge.
  double number(double lo, double hi) {
    const std::uint8_t selector = byte();
    const double unit = (byte() * 256 + byte()) / 65535.0;
    switch (selector % 32) {
      case 0:
        return std::numeric_limits<double>::quiet_NaN();
      case 1:
        return std::numeric_limits<double>::infinity();
      case 2:
        return -std::numeric_limits<double>::infinity();
      case 3:
        return 0.0;
      case 4:
        return -hi;
      case 5:
        return hi * 1e12;
      default:
        return lo + unit * (hi - lo);
    }
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t position_ = 0;
};

bool finite(const HydraulicEstimate& e) {
  for (const auto& p : e.parameters) {
    if (!std::isfinite(p.value) || !std::isfinite(p.std)) return false;
  }
  return std::isfinite(e.equation_error_rms);
}

IdentificationConfig configFrom(Bytes& in) {
  IdentificationConfig c;
  const std::uint8_t effects = in.byte();
  const auto& library = libraryEffectNames();
  for (std::size_t i = 0; i < library.size(); ++i) {
    if (effects & (1u << i)) c.effects.push_back(library[i]);
  }
  static const char* kCustom[] = {
      "relief=max(p-140e5,0)", "bypass=p*y", "broken=p*(", "dp_term=dp", "=p", "x=", "nan=sqrt(-1)"};
  if (effects & 0x80) c.custom_effects.push_back(kCustom[in.byte() % 7]);
  const std::uint8_t tweaks = in.byte();
  if (tweaks & 1) c.forgetting_factor = in.number(0.9, 1.0);
  // Through the same door as ROS parameters and YAML, so that NaN and fractions are tried too.
  if (tweaks & 2) setNumericConfigValue(c, "moving_average_width", in.number(1, 61));
  if (tweaks & 4) setNumericConfigValue(c, "derivative_width", in.number(3, 61));
  if (tweaks & 8) c.geometry.piston_area = in.number(0.001, 1.0);
  if (tweaks & 16) c.min_pressure = in.number(-1e5, 50e5);
  if (tweaks & 32) c.regression_form = RegressionForm::kDerivative;
  if (tweaks & 64) c.resampler.max_gap = in.number(0.003, 0.1);
  if (tweaks & 128) c.initial_covariance = in.number(1.0, 1e9);
  return c;
}

// The next stamp of a stream whose newest is `last`: 1 ms on, or (as `op` says) 0, a duplicate, a step
// back, a gap or jump, NaN.
double hostileStamp(Bytes& in, std::uint8_t op, double last) {
  switch ((op >> 2) % 8) {
    case 1:
      return 0.0;
    case 2:
      return last;  // duplicate
    case 3:
      return last - in.number(0.0, 5.0);  // back
    case 4:
      return last + in.number(0.0, 5.0);  // gap or jump
    case 5:
      return std::numeric_limits<double>::quiet_NaN();
    default:
      return last + 0.001;
  }
}

// A plausible press signal of stream `s` at `stamp`, with hostile values from the bytes.
StreamSample pressSample(Bytes& in, int s, std::uint8_t op, double stamp) {
  const double phase = std::fmod(std::isfinite(stamp) ? stamp : 0.0, 2.6);
  StreamSample sample;
  sample.stamp = stamp;
  switch (s) {
    case 0:
      sample.first = in.number(0.0, 200e5) * 0.1 + 100e5 * std::sin(phase);
      sample.second = NAN;
      break;
    case 1:
      sample.first = 0.1 + 0.1 * std::sin(phase);
      sample.second = (op & 0x20) ? NAN : in.number(-0.3, 0.3);
      break;
    default:
      sample.first = in.number(-10.0, 10.0);
      sample.second = (op & 0x20) ? NAN : in.number(-1.0, 1.0);
      break;
  }
  return sample;
}

// Whatever came in: finite estimates, a verdict with an explanation for every candidate.
void checkResults(IdentificationPipeline& pipeline, OfflineAnalysis& offline,
                  const std::function<void(const std::string&)>& fail) {
  pipeline.flush();
  if (!finite(pipeline.identifier().estimate())) fail("a non-finite online estimate");
  const OfflineResult result = offline.finish();
  if (result.hydraulics && result.model.updates > 0 && !finite(result.model))
    fail("a non-finite offline fit");
  if (!std::isfinite(result.assessment.simulation_error_rms)) fail("a non-finite simulation error");
  for (const auto& c : result.ranking.candidates) {
    if (std::string(verdictName(c.verdict)) == "?") fail("bad verdict");
    if (c.explanation.empty()) fail("a verdict without an explanation");
  }
}

// A plausible press signal with hostile disturbances, in stamp order with deliberate exceptions.
void feedMessages(Bytes& in, const IdentificationConfig& config,
                  const std::function<void(const std::string&)>& fail) {
  std::unique_ptr<IdentificationPipeline> pipeline;
  std::unique_ptr<OfflineAnalysis> offline;
  try {
    pipeline = std::make_unique<IdentificationPipeline>(config);
    offline = std::make_unique<OfflineAnalysis>(config);
  } catch (const std::invalid_argument& e) {
    if (std::strlen(e.what()) == 0) fail("a refused configuration without a reason");
    if (config.validate().empty()) fail(std::string("a valid configuration refused: ") + e.what());
    return;
  }
  if (!config.validate().empty()) fail("an invalid configuration accepted");
  double t[kInputStreamCount] = {100.0, 100.0003, 100.0006};
  int silent = in.byte() % 4;  // 3: none silent
  for (int step = 0; step < 6000 && !in.empty(); ++step) {
    const std::uint8_t op = in.byte();
    const int s = op % 3;
    if (s == silent && (op & 0x40)) continue;
    const int burst = (op & 0x80) ? 1 + in.byte() % 16 : 1;
    for (int b = 0; b < burst; ++b) {
      const double stamp = hostileStamp(in, op, t[s]);
      const StreamSample sample = pressSample(in, s, op, stamp);
      pipeline->push(static_cast<InputStream>(s), sample);
      offline->push(static_cast<InputStream>(s), sample);
      if (std::isfinite(stamp) && stamp > t[s]) t[s] = stamp;
    }
  }
  checkResults(*pipeline, *offline, fail);
}

SweepLimits hostileLimits(Bytes& in) {
  SweepLimits limits;
  const std::uint8_t tweaks = in.byte();
  if (tweaks & 1) limits.max_amplitude = in.number(0.1, 5.0);
  if (tweaks & 2) limits.min_voltage = in.number(-10.0, 0.0);
  if (tweaks & 4) limits.max_voltage = in.number(0.0, 10.0);
  if (tweaks & 8) limits.command_period = in.number(1e-4, 0.01);
  if (tweaks & 16) limits.max_pressure = in.number(1e5, 200e5);
  if (tweaks & 32) limits.signal_timeout = in.number(0.001, 1.0);
  return limits;
}

SweepRequest hostileRequest(Bytes& in) {
  SweepRequest request;
  if (in.byte() & 1) {
    for (int k = 0; k < 5; ++k) request.frequencies.push_back(in.number(1.0, 200.0));
  } else {
    request.frequencies = {20.0, 40.0, 60.0, 80.0, 100.0};
  }
  request.amplitude = in.number(0.0, 2.0);
  request.offset = in.number(-2.0, 2.0);
  request.settle_periods = in.number(0.0, 5.0);
  request.integration_periods = in.number(1.0, 5.0);
  request.min_integration_time = in.number(0.0, 0.2);
  return request;
}

// A valve fit to hostile frequency-response points: it succeeds or says why.
void fitHostilePoints(Bytes& in, const std::function<void(const std::string&)>& fail) {
  std::vector<FrequencyResponsePoint> points;
  for (int i = 0; i < 8 && !in.empty(); ++i) {
    FrequencyResponsePoint p;
    p.frequency = in.number(1.0, 300.0);
    p.magnitude = in.number(0.0, 0.2);
    p.phase = in.number(-10.0, 0.0);
    p.magnitude_std = in.number(0.0, 0.01);
    p.phase_std = in.number(0.0, 0.1);
    points.push_back(p);
  }
  const ServoValveFit fit = fitServoValve(points);
  if (!fit.success && fit.message.empty()) fail("a failed valve fit without a reason");
}

void sweepAndValve(Bytes& in, const std::function<void(const std::string&)>& fail) {
  const SweepLimits limits = hostileLimits(in);
  std::unique_ptr<ValveSweep> sweep;
  try {
    sweep = std::make_unique<ValveSweep>(limits);
  } catch (const std::invalid_argument& e) {
    if (limits.validate().empty()) fail(std::string("valid sweep limits refused: ") + e.what());
    return;
  }
  const SweepRequest request = hostileRequest(in);
  PlantCondition plant;
  plant.pressure = in.number(0.0, 100e5);
  plant.velocity = in.number(-0.01, 0.01);
  plant.pressure_age = in.number(0.0, 0.1);
  plant.position_age = in.number(0.0, 0.1);
  plant.valve_age = plant.spool_age = in.number(0.0, 0.1);
  double now = 10.0;
  const std::string refusal = sweep->start(request, Instant::simulated(now), plant);
  if (!refusal.empty() && sweep->running()) fail("refused but running");
  std::vector<ValveSample> echo;
  for (int i = 0; i < 3000 && !in.empty(); ++i) {
    const std::uint8_t op = in.byte();
    now += (op & 1) ? in.number(0.0, 0.01) : limits.command_period;
    if (op & 2) plant.pressure = in.number(0.0, 150e5);
    if (op & 4) plant.spool_age = in.number(0.0, 0.2);
    sweep->supervise(Instant::simulated(now), plant);
    const auto u = sweep->command(now);
    if (u && !(std::isfinite(*u) && *u >= limits.min_voltage && *u <= limits.max_voltage)) {
      fail("a valve command outside the configured bounds: " + std::to_string(*u));
    }
    const double spool = (op & 8) ? in.number(-1.0, 1.0) : 0.05 * std::sin(now * 100.0);
    sweep->addValveSample(now, u.value_or(0.0), spool);
    if (op & 16) sweep->abort("fuzz");
    if (sweep->state() == ValveSweep::State::kAborted && sweep->abortReason().empty())
      fail("abort without reason");
    echo.push_back({now, u.value_or(0.0), spool});
  }
  const RecordedSweep recorded = analyzeRecordedSweep(echo);
  if (recorded.fit.success && !std::isfinite(recorded.fit.parameters.natural_frequency))
    fail("non-finite valve fit");
  fitHostilePoints(in, fail);
}

/// Everything that drives the valve, on hostile clocks and inputs (issue 45): the steady clock only ever
/// advances (it is monotonic), everything else may be anything. Invariants: every command within the
/// voltage limits and finite; the feed-forward never steps beyond its slew rate on the steady clock; no
/// experiment's command while the feed-forward is not at 0 V; every refusal and abort with a reason.
void supervisor(Bytes& in, const std::function<void(const std::string&)>& fail) {
  const SweepLimits limits = hostileLimits(in);
  FeedForwardOutputLimits ff;
  ff.max_voltage = std::max(1e-3, std::min(std::abs(limits.min_voltage), std::abs(limits.max_voltage)));
  if (!std::isfinite(ff.max_voltage)) ff.max_voltage = 1.0;
  ff.slew_rate = 1.0 + 100.0 * (in.byte() / 255.0);
  std::unique_ptr<ValveSupervisor> valve;
  try {
    valve = std::make_unique<ValveSupervisor>(limits, ff);
  } catch (const std::invalid_argument& e) {
    if (limits.validate().empty()) fail(std::string("valid limits refused: ") + e.what());
    return;
  }
  double steady = 10.0, clock = in.number(0.0, 1e9), last_ff = 0.0, last_ff_time = NAN;
  const auto check = [&](std::optional<double> u, bool feed_forward) {
    if (!u) return;
    if (!std::isfinite(*u)) fail("a non-finite command");
    if (feed_forward) {
      if (std::abs(*u) > ff.max_voltage + 1e-12) fail("a feed-forward beyond its limit");
      const double dt = std::isnan(last_ff_time) ? 0.0 : steady - last_ff_time;
      if (std::abs(*u - last_ff) > ff.slew_rate * std::min(dt, ff.max_step_interval) + 1e-9)
        fail("a feed-forward step beyond its slew rate");
      last_ff = *u;
      last_ff_time = steady;
    } else {
      if (*u < limits.min_voltage - 1e-12 || *u > limits.max_voltage + 1e-12)
        fail("a valve command outside its limits");
      if (last_ff != 0.0) fail("an experiment's command while the feed-forward adds a voltage");
    }
  };
  for (int i = 0; i < 2000 && !in.empty(); ++i) {
    const std::uint8_t op = in.byte();
    steady += (op & 1) ? std::max(0.0, std::min(in.number(0.0, 0.05), 10.0)) : 0.0005;
    clock = (op & 2) ? in.number(0.0, 1e9) : clock + 0.0005;
    const Instant now{steady, clock};
    const double stamp = (op & 4) ? in.number(0.0, 1e9) : clock;
    switch ((op >> 3) % 8) {
      case 0:
        valve->pressure(stamp, in.number(0.0, 100e5), now);
        break;
      case 1:
        valve->position(stamp, in.number(0.0, 0.3), now);
        break;
      case 2:
        valve->valve(stamp, in.number(-1.0, 1.0), in.number(-1.0, 1.0), now);
        break;
      case 3: {
        const std::string why = valve->startSweep(hostileRequest(in), now);
        if (!why.empty() && valve->experiments().lastRefusal().empty()) fail("a refusal not kept");
        break;
      }
      case 4: {
        StepTestRequest r;
        r.offset = in.number(-1.0, 1.0);
        r.step = in.number(-1.0, 1.0);
        r.duration = in.number(0.0, 2.0);
        r.settle = in.number(0.0, 1.0);
        valve->startStepTest(r, now);
        break;
      }
      case 5:
        valve->abortExperiment("fuzz", now);
        break;
      case 6:
        valve->enableFeedForward(in.byte() & 1, now);
        break;
      default:
        check(valve->feedForward(in.number(-20.0, 20.0), "fuzz", now), true);
        break;
    }
    check(valve->experimentCommand(now), false);
    const auto out = valve->watch(now);
    check(out.valve_command, false);
    check(out.feed_forward, true);
    if (valve->experiments().lastEnd().find("aborted: ") != std::string::npos &&
        valve->experiments().lastEnd().size() <= std::string("valve sweep aborted: ").size())
      fail("an abort without a reason");
  }
}

}  // namespace

void runCase(const std::uint8_t* data, std::size_t size,
             const std::function<void(const std::string&)>& fail) {
  Bytes in(data, size);
  const IdentificationConfig config = configFrom(in);
  const bool sweep_first = in.byte() & 1;
  if (sweep_first) sweepAndValve(in, fail);
  feedMessages(in, config, fail);
  if (!sweep_first) sweepAndValve(in, fail);
  supervisor(in, fail);
}

}  // namespace fuzz
}  // namespace die_cushion_ident
