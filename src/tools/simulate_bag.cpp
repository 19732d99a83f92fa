// simulate_bag: records the built-in simulator into a bag with the contract's input topics, as a press would
// record it (press cycles, then optionally a valve sine sweep with the cushion at rest). For trying
// analyze_bag, for its tests and for the throughput benchmark; no roscore needed.
#include <rosbag/bag.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/JointState.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>

#include "command_line.h"
#include "die_cushion_ident/ValveSignal.h"
#include "die_cushion_ident/core/simulation/die_cushion_simulator.h"
#include "die_cushion_ident/core/valve/valve_sweep.h"
#include "die_cushion_ident/core/signal/velocity_from_position.h"

using namespace die_cushion_ident;

namespace {

const char* kUsage =
    "usage: simulate_bag OUT.bag [--cycles N] [--hours H] [--plant-effects a,b] [--custom-effect NAME=EXPR]\n"
    "                    [--set NAME=VALUE]... [--seed S] [--sweep] [--step-test VOLTAGE] [--epoch SECONDS]\n"
    "                    sensor configuration: [--no-velocity] [--no-spool] [--joints a,b,c] [--joint-name N]\n"
    "                    [--rates P,X,V] [--stamp-offsets P,X,V] [--continuous-command] [--start-offset S]\n"
    "  Press cycles of the simulated die cushion (2.62 s each) on /die_cushion/{pressure,position,valve};\n"
    "  --sweep appends the default valve sine sweep (10 ... 160 Hz, 0.5 V) with the cushion at rest;\n"
    "  --step-test V then a valve command step of V volts at rest (held 1.5 s), for the pressure's t63.\n"
    "  Sensor configurations a press may have:\n"
    "    --no-velocity         JointState with position only (a linear encoder)\n"
    "    --no-spool            spool position not measured (NaN)\n"
    "    --joints a,b,c        the position topic carries several joints (a cell's joint_states); the\n"
    "                          cushion is the one named by --joint-name (default 'cushion'), the others move\n"
    "                          with it (ram above it, blank holder at a tenth of its stroke)\n"
    "    --rates P,X,V         message rates [Hz] of pressure, position and valve (default 1000,1000,1000;\n"
    "                          the valve rate is at most the 1 kHz command rate)\n"
    "    --stamp-offsets P,X,V added to each topic's stamps [s] (a topic stamped late by another clock)\n"
    "    --continuous-command  the sweep's command comes from a continuous signal generator, sampled by the\n"
    "                          valve messages (not held by an amplifier): analyse with valve_command_hold: 0\n"
    "    --start-offset S      the recording starts S seconds into the press cycle (mid-stroke)\n";

// The three topics' names in the order of InputStream.
const char* const kTopics[kInputStreamCount] = {"/die_cushion/pressure", "/die_cushion/position",
                                                "/die_cushion/valve"};

/// How the press's sensors appear in the bag (beyond what the simulator's SensorConfig models).
struct Recording {
  std::vector<std::string> joints = {"cushion"};
  std::string cushion_joint = "cushion";
  double stamp_offsets[kInputStreamCount] = {0.0, 0.0, 0.0};
};

class BagRecorder {
 public:
  BagRecorder(const std::string& path, double epoch, const Recording& recording)
      : epoch_(epoch), recording_(recording) {
    bag_.open(path, rosbag::bagmode::Write);
  }
  ~BagRecorder() { bag_.close(); }

  void write(const SimulatedMeasurement& m, double offset) {
    const int s = static_cast<int>(m.stream);
    const ros::Time stamp(epoch_ + offset + m.sample.stamp + recording_.stamp_offsets[s]);
    switch (m.stream) {
      case InputStream::kPressure: {
        sensor_msgs::FluidPressure msg;
        msg.header.stamp = stamp;
        msg.fluid_pressure = m.sample.first;
        bag_.write(kTopics[s], stamp, msg);
        break;
      }
      case InputStream::kPosition: {
        sensor_msgs::JointState msg;
        msg.header.stamp = stamp;
        msg.name = recording_.joints;
        const bool velocity = std::isfinite(m.sample.second);
        for (const auto& joint : recording_.joints) {
          // The ram rides 0.3 m above the cushion; the blank holder follows at a tenth of its stroke.
          const double scale = joint == recording_.cushion_joint ? 1.0 : joint == "ram" ? 1.0 : 0.1;
          const double shift = joint == recording_.cushion_joint ? 0.0 : joint == "ram" ? -0.3 : 0.0;
          msg.position.push_back(scale * m.sample.first + shift);
          if (velocity) msg.velocity.push_back(scale * m.sample.second);
        }
        bag_.write(kTopics[s], stamp, msg);
        break;
      }
      case InputStream::kValve: {
        ValveSignal msg;
        msg.header.stamp = stamp;
        msg.voltage = m.sample.first;
        msg.spool_position = m.sample.second;
        bag_.write(kTopics[s], stamp, msg);
        break;
      }
    }
  }

 private:
  rosbag::Bag bag_;
  double epoch_;
  Recording recording_;
};

// "a,b,c" -> three numbers.
void threeNumbers(const std::string& text, double out[kInputStreamCount]) {
  const auto items = splitList(text);
  if (items.size() != kInputStreamCount) throw std::invalid_argument("'" + text + "' must be three numbers P,X,V");
  for (int s = 0; s < kInputStreamCount; ++s) {
    std::size_t used = 0;
    out[s] = std::stod(items[s], &used);
    if (used != items[s].size() || !std::isfinite(out[s])) throw std::invalid_argument("'" + items[s] + "' is not a number");
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string out;
  double cycles = 6, hours = 0.0, epoch = 1.7e9, start_offset = 0.0;
  bool sweep = false, continuous_command = false;
  double step_test = 0.0;
  SimulatorConfig plant;
  Recording recording;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "simulate_bag: " << a << " needs a value\n" << kUsage;
        std::exit(2);
      }
      return argv[++i];
    };
    try {
      if (a == "--help" || a == "-h") {
        std::cout << kUsage;
        return 0;
      } else if (a == "--cycles") {
        cycles = std::stod(value());
      } else if (a == "--hours") {
        hours = std::stod(value());
      } else if (a == "--plant-effects") {
        plant.effects = splitList(value());
      } else if (a == "--custom-effect") {
        plant.custom_effects.push_back(value());
      } else if (a == "--set") {
        const std::string kv = value();
        const auto eq = kv.find('=');
        if (eq == std::string::npos) throw std::invalid_argument("--set needs NAME=VALUE");
        plant.parameters[kv.substr(0, eq)] = std::stod(kv.substr(eq + 1));
      } else if (a == "--seed") {
        plant.seed = std::stoull(value());
      } else if (a == "--sweep") {
        sweep = true;
      } else if (a == "--step-test") {
        step_test = std::stod(value());
        if (!std::isfinite(step_test) || step_test == 0.0 || std::abs(step_test) > 10.0) {
          throw std::invalid_argument("--step-test needs a voltage step in [-10, 10] V, not 0");
        }
      } else if (a == "--no-spool") {
        plant.sensors.measure_spool = false;
      } else if (a == "--no-velocity") {
        plant.sensors.publish_velocity = false;
      } else if (a == "--joints") {
        recording.joints = splitList(value());
      } else if (a == "--joint-name") {
        recording.cushion_joint = value();
      } else if (a == "--rates") {
        double rates[kInputStreamCount];
        threeNumbers(value(), rates);
        plant.sensors.pressure_rate = rates[0];
        plant.sensors.position_rate = rates[1];
        plant.sensors.valve_rate = rates[2];
      } else if (a == "--stamp-offsets") {
        threeNumbers(value(), recording.stamp_offsets);
      } else if (a == "--continuous-command") {
        continuous_command = true;
      } else if (a == "--start-offset") {
        start_offset = std::stod(value());
      } else if (a == "--epoch") {
        epoch = std::stod(value());
      } else if (!a.empty() && a[0] != '-' && out.empty()) {
        out = a;
      } else {
        throw std::invalid_argument("unexpected argument " + a);
      }
    } catch (const std::exception& e) {
      std::cerr << "simulate_bag: " << e.what() << "\n" << kUsage;
      return 2;
    }
  }
  if (out.empty()) {
    std::cerr << "simulate_bag: no output bag given\n" << kUsage;
    return 2;
  }
  if (std::find(recording.joints.begin(), recording.joints.end(), recording.cushion_joint) ==
      recording.joints.end()) {
    std::cerr << "simulate_bag: --joint-name '" << recording.cushion_joint << "' is not among --joints\n";
    return 2;
  }
  if (!(plant.sensors.valve_rate <= 1.0 / plant.control_period + 1e-9)) {
    std::cerr << "simulate_bag: the valve rate cannot exceed the 1000 Hz command rate\n";
    return 2;
  }
  try {
    BagRecorder recorder(out, epoch, recording);
    DieCushionSimulator press(plant);
    const double duration = hours > 0.0 ? hours * 3600.0 : cycles * press.program().cycleDuration();
    std::vector<SimulatedMeasurement> messages;
    while (press.state().t < duration + start_offset) {
      messages.clear();
      press.step(&messages);
      if (press.state().t < start_offset) continue;  // not recorded yet: the recording starts mid-stroke
      for (const auto& m : messages) recorder.write(m, -start_offset);
    }
    double next_block = press.state().t - start_offset + 2.0;  // [s] where an appended test starts
    if (sweep) {
      // The same cushion standing at rest two seconds later, swept as ValveSweep sweeps it live.
      SimulatorConfig at_rest = plant;
      at_rest.cycle.rest_time = 1e9;
      DieCushionSimulator cushion(at_rest);
      ValveSweep valve_sweep{SweepLimits()};
      const double offset = press.state().t - start_offset + 2.0;
      PlantCondition condition;
      double spool_stamp = -1e9, pressure_stamp = -1e9;
      CausalVelocity position_rate;
      SweepRequest request;
      request.offset = 0.1;
      bool started = false;
      while (cushion.state().t < 600.0) {
        const double now = cushion.state().t;
        condition.pressure_age = now - pressure_stamp;
        condition.spool_age = now - spool_stamp;
        if (!started && now > 0.2) {
          const std::string refusal = valve_sweep.start(request, now, condition);
          if (!refusal.empty()) throw std::runtime_error("sweep refused: " + refusal);
          started = true;
        }
        valve_sweep.supervise(now, condition);
        const auto u = valve_sweep.command(now);
        if (continuous_command && started) {
          cushion.setValveCommandSignal([&valve_sweep](double t) { return valve_sweep.commandAt(t); });
        } else if (u) {
          cushion.setValveCommandOverride(*u);
        }
        messages.clear();
        cushion.step(&messages);
        for (const auto& m : messages) {
          recorder.write(m, offset);
          if (m.stream == InputStream::kPressure) {
            condition.pressure = m.sample.first;
            pressure_stamp = m.sample.stamp;
          } else if (m.stream == InputStream::kPosition) {
            // Without a velocity channel the safety check uses the node's causal slope of the positions.
            position_rate.push(m.sample.stamp, m.sample.first);
            condition.velocity = std::isfinite(m.sample.second) ? m.sample.second : position_rate.velocity();
          } else {
            if (std::isfinite(m.sample.second)) spool_stamp = m.sample.stamp;
            valve_sweep.addValveSample(m.sample.stamp, m.sample.first, m.sample.second);
          }
        }
        if (started && !valve_sweep.running()) break;
      }
      if (valve_sweep.state() != ValveSweep::State::kFinished) {
        throw std::runtime_error("sweep did not finish: " + valve_sweep.abortReason());
      }
      cushion.setValveCommandSignal({});
      for (int i = 0; i < 500; ++i) {  // half a second at rest after the sweep
        messages.clear();
        cushion.setValveCommandOverride(valve_sweep.command(cushion.state().t).value_or(request.offset));
        cushion.step(&messages);
        for (const auto& m : messages) recorder.write(m, offset);
      }
      next_block = offset + cushion.state().t + 2.0;
    }
    if (step_test != 0.0) {
      // The cushion at rest under its controller, then the command held at its last value for 0.3 s (as
      // ~start_step_test holds the offset), stepped by step_test for 1.5 s, and back to the controller.
      SimulatorConfig at_rest = plant;
      at_rest.cycle.rest_time = 1e9;
      DieCushionSimulator cushion(at_rest);
      const auto run = [&](double until) {
        while (cushion.state().t < until - 1e-12) {
          messages.clear();
          cushion.step(&messages);
          for (const auto& m : messages) recorder.write(m, next_block);
        }
      };
      run(0.7);
      const double offset = cushion.state().u;
      cushion.setValveCommandOverride(offset);
      run(1.0);
      cushion.setValveCommandOverride(offset + step_test);
      run(2.5);
      cushion.setValveCommandOverride(std::nullopt);
      run(3.0);
    }
  } catch (const std::exception& e) {
    std::cerr << "simulate_bag: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
