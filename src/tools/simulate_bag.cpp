// simulate_bag: records the built-in simulator into a bag with the contract's input topics, as a press would
// record it (press cycles, then optionally a valve sine sweep with the cushion at rest). For trying
// analyze_bag, for its tests and for the throughput benchmark; no roscore needed.
#include <rosbag/bag.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/JointState.h>

#include <cmath>
#include <iostream>
#include <sstream>

#include "command_line.h"
#include "die_cushion_ident/ValveSignal.h"
#include "die_cushion_ident/core/die_cushion_simulator.h"
#include "die_cushion_ident/core/valve_sweep.h"

using namespace die_cushion_ident;

namespace {

const char* kUsage =
    "usage: simulate_bag OUT.bag [--cycles N] [--hours H] [--plant-effects a,b] [--custom-effect NAME=EXPR]\n"
    "                    [--set NAME=VALUE]... [--seed S] [--sweep] [--no-spool] [--epoch SECONDS]\n"
    "  Press cycles of the simulated die cushion (2.62 s each) on /die_cushion/{pressure,position,valve};\n"
    "  --sweep appends the default valve sine sweep (10 ... 160 Hz, 0.5 V) with the cushion at rest.\n";

class BagRecorder {
 public:
  BagRecorder(const std::string& path, double epoch) : epoch_(epoch) {
    bag_.open(path, rosbag::bagmode::Write);
  }
  ~BagRecorder() { bag_.close(); }

  void write(const SimulatedMeasurement& m, double offset) {
    const ros::Time stamp(epoch_ + offset + m.sample.stamp);
    switch (m.stream) {
      case InputStream::kPressure: {
        sensor_msgs::FluidPressure msg;
        msg.header.stamp = stamp;
        msg.fluid_pressure = m.sample.first;
        bag_.write("/die_cushion/pressure", stamp, msg);
        break;
      }
      case InputStream::kPosition: {
        sensor_msgs::JointState msg;
        msg.header.stamp = stamp;
        msg.name = {"cushion"};
        msg.position = {m.sample.first};
        if (std::isfinite(m.sample.second)) msg.velocity = {m.sample.second};
        bag_.write("/die_cushion/position", stamp, msg);
        break;
      }
      case InputStream::kValve: {
        ValveSignal msg;
        msg.header.stamp = stamp;
        msg.voltage = m.sample.first;
        msg.spool_position = m.sample.second;
        bag_.write("/die_cushion/valve", stamp, msg);
        break;
      }
    }
  }

 private:
  rosbag::Bag bag_;
  double epoch_;
};

}  // namespace

int main(int argc, char** argv) {
  std::string out;
  double cycles = 6, hours = 0.0, epoch = 1.7e9;
  bool sweep = false;
  SimulatorConfig plant;
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
      } else if (a == "--no-spool") {
        plant.sensors.measure_spool = false;
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
  try {
    BagRecorder recorder(out, epoch);
    DieCushionSimulator press(plant);
    const double duration = hours > 0.0 ? hours * 3600.0 : cycles * press.program().cycleDuration();
    std::vector<SimulatedMeasurement> messages;
    while (press.state().t < duration) {
      messages.clear();
      press.step(&messages);
      for (const auto& m : messages) recorder.write(m, 0.0);
    }
    if (sweep) {
      // The same cushion standing at rest two seconds later, swept as ValveSweep sweeps it live.
      SimulatorConfig at_rest = plant;
      at_rest.cycle.rest_time = 1e9;
      DieCushionSimulator cushion(at_rest);
      ValveSweep valve_sweep{SweepLimits()};
      const double offset = press.state().t + 2.0;
      PlantCondition condition;
      double spool_stamp = -1e9, pressure_stamp = -1e9;
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
        if (const auto u = valve_sweep.command(now)) cushion.setValveCommandOverride(*u);
        messages.clear();
        cushion.step(&messages);
        for (const auto& m : messages) {
          recorder.write(m, offset);
          if (m.stream == InputStream::kPressure) {
            condition.pressure = m.sample.first;
            pressure_stamp = m.sample.stamp;
          } else if (m.stream == InputStream::kPosition) {
            condition.velocity = m.sample.second;
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
      for (int i = 0; i < 500; ++i) {  // half a second at rest after the sweep
        messages.clear();
        cushion.setValveCommandOverride(valve_sweep.command(cushion.state().t).value_or(request.offset));
        cushion.step(&messages);
        for (const auto& m : messages) recorder.write(m, offset);
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "simulate_bag: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
