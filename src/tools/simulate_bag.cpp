// simulate_bag: records the built-in simulator into a bag with the contract's input topics, as a press would
// record it (press cycles, then optionally a valve sine sweep with the cushion at rest). For trying
// analyze_bag, for its tests and for the throughput benchmark; no roscore needed. The bag, the config and
// the truth are written whole or not at all (OutputFiles): exit 4 when one cannot be written.

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

#include "argument_parser.h"
#include "bag/bag_stream_writer.h"
#include "command_line.h"
#include "die_cushion_ident/core/simulation/die_cushion_simulator.h"
#include "die_cushion_ident/core/simulation/press_class.h"
#include "die_cushion_ident/core/valve/plant_signals.h"
#include "die_cushion_ident/core/valve/valve_sweep.h"
#include "message_conversions.h"
#include "output/output_files.h"

using namespace die_cushion_ident;

namespace {

const char* kUsage =
    "usage: simulate_bag OUT.bag [--cycles N] [--hours H] [--plant-effects a,b] [--custom-effect NAME=EXPR]\n"
    "                    [--set NAME=VALUE]... [--seed S] [--sweep] [--step-test VOLTAGE] [--epoch SECONDS]\n"
    "                    [--press CLASS] [--variation N] [--ram-speed V] [--write-config FILE.yaml] "
    "[--write-truth FILE.yaml]\n"
    "                    sensor configuration: [--no-velocity] [--no-spool] [--joints a,b,c] [--joint-name "
    "N]\n"
    "                    [--rates P,X,V] [--stamp-offsets P,X,V] [--continuous-command] [--start-offset S]\n"
    "                    [--effects-from-cycle K] [--oil-temperature START[,END]] [--oil-law ALPHA,BETA]\n"
    "  Press cycles of the simulated die cushion on /die_cushion/{pressure,position,valve};\n"
    "  --press CLASS          the kind of press: slow_hydraulic (the paper's, default; 2.62 s cycles),\n"
    "                         fast_mechanical (crank, 0.5 m/s, 4 ms impact), small_stiff (0.02 m^2, 1 l),\n"
    "                         large_soft (0.2 m^2, 20 l); --variation N draws another press of the class\n"
    "                         (0: the class's nominal one); --write-config FILE writes its geometry for\n"
    "                         analyze_bag --config; --write-truth FILE its true parameters (YAML);\n"
    "  --ram-speed V          the ram's speed [m/s] as it meets the cushion, instead of the class's (a\n"
    "                         faster crank: the drawing shorter, the impact as long, the flow A V larger);\n"
    "  --sweep appends the default valve sine sweep (10 ... 160 Hz, 0.5 V) with the cushion at rest;\n"
    "  --step-test V then a valve command step of V volts at rest (held 1.5 s), for the pressure's t63.\n"
    "  --effects-from-cycle K the plant effects act only from press cycle K on (0: the first; before it "
    "their\n"
    "                         parameters are 0): a leak or air that starts while the press is recorded;\n"
    "                         --write-truth then adds effects_from_cycle and effects_from_time [s].\n"
    "  --oil-temperature START[,END] the oil's temperature [degC] at the recording's start and its end "
    "(linear\n"
    "                         warming over the press cycles; default END = START), recorded on\n"
    "                         /die_cushion/oil_temperature (sensor_msgs/Temperature, 2 Hz, 0.05 K noise); "
    "the\n"
    "                         plant follows it (effect oil_temperature: its true parameters hold at 40 "
    "degC);\n"
    "  --oil-law ALPHA,BETA    the plant oil's bulk-modulus and leakage temperature coefficients [1/K]\n"
    "                         (default -0.004,0.045); --write-truth adds them and the temperatures.\n"
    "  Sensor configurations a press may have:\n"
    "    --no-velocity         JointState with position only (a linear encoder)\n"
    "    --no-spool            spool position not measured (NaN)\n"
    "    --joints a,b,c        the position topic carries several joints (a cell's joint_states); the\n"
    "                          cushion is the one named by --joint-name (default 'cushion'), the others "
    "move\n"
    "                          with it (ram above it, blank holder at a tenth of its stroke)\n"
    "    --rates P,X,V         message rates [Hz] of pressure, position and valve (default 1000,1000,1000;\n"
    "                          the valve rate is at most the 1 kHz command rate)\n"
    "    --stamp-offsets P,X,V added to each topic's stamps [s] (a topic stamped late by another clock)\n"
    "    --continuous-command  the sweep's command comes from a continuous signal generator, sampled by the\n"
    "                          valve messages (not held by an amplifier): analyse with valve_command_hold: "
    "0\n"
    "    --start-offset S      the recording starts S seconds into the press cycle (mid-stroke)\n"
    "  Exit 0; 1 the simulation failed; 2 bad arguments; 4 an output cannot be written (nothing is left "
    "under\n"
    "  its name: the bag, config and truth are renamed from temporary names when all are whole).\n";

// The three topics' names in the order of InputStream.
const char* const kTopics[kInputStreamCount] = {"/die_cushion/pressure", "/die_cushion/position",
                                                "/die_cushion/valve"};
const char* const kOilTemperatureTopic = "/die_cushion/oil_temperature";

/// How the press's sensors appear in the bag (beyond what the simulator's SensorConfig models).
struct Recording {
  std::vector<std::string> joints = {"cushion"};
  std::string cushion_joint = "cushion";
  double stamp_offsets[kInputStreamCount] = {0.0, 0.0, 0.0};
};

class BagRecorder {
 public:
  BagRecorder(const std::string& path, double epoch, const Recording& recording)
      : bag_(path), epoch_(epoch), recording_(recording) {
    joints_.names = recording.joints;
    joints_.cushion = recording.cushion_joint;
  }
  /// Completes the bag (its index); throws when the disk refused it.
  void close() { bag_.close(); }

  void write(const SimulatedMeasurement& m, double offset) {
    const int s = static_cast<int>(m.stream);
    const ros::Time stamp(epoch_ + offset + m.sample.stamp + recording_.stamp_offsets[s]);
    switch (m.stream) {
      case InputStream::kPressure:
        bag_.write(kTopics[s], stamp, toFluidPressureMsg(m.sample, stamp));
        break;
      case InputStream::kPosition:
        bag_.write(kTopics[s], stamp, toJointStateMsg(m.sample, stamp, joints_));
        break;
      case InputStream::kValve:
        bag_.write(kTopics[s], stamp, toValveSignalMsg(m.sample, stamp));
        break;
    }
  }
  /// The oil temperature messages a simulator sent since the last call.
  void writeOilTemperature(DieCushionSimulator& simulator, double offset) {
    oil_.clear();
    simulator.takeOilTemperature(&oil_);
    for (const StreamSample& sample : oil_) {
      const ros::Time stamp(epoch_ + offset + sample.stamp);
      bag_.write(kOilTemperatureTopic, stamp, toTemperatureMsg(sample, stamp));
    }
  }

 private:
  BagStreamWriter bag_;  // rosbag::Bag::write costs four system calls a message (bag_stream_writer.h)
  double epoch_;
  Recording recording_;
  SimulatedJoints joints_;
  std::vector<StreamSample> oil_;
};

// "a,b,c" -> three numbers.
void threeNumbers(const std::string& text, double out[kInputStreamCount]) {
  const auto items = splitList(text);
  if (items.size() != kInputStreamCount)
    throw std::invalid_argument("'" + text + "' must be three numbers P,X,V");
  for (int s = 0; s < kInputStreamCount; ++s) {
    std::size_t used = 0;
    out[s] = std::stod(items[s], &used);
    if (used != items[s].size() || !std::isfinite(out[s]))
      throw std::invalid_argument("'" + items[s] + "' is not a number");
  }
}

}  // namespace

/// What the command line asks for. The plant's sensors, effects and true parameters as given; the plant
/// itself is the press class's, built after parsing (buildPlant).
struct Options {
  std::string out;
  double cycles = 6, hours = 0.0, epoch = 1.7e9, start_offset = 0.0;
  bool sweep = false, continuous_command = false;
  double step_test = 0.0;
  double effects_from_cycle = 0.0;
  SimulatorConfig plant;
  PressClass press = PressClass::kSlowHydraulic;
  double variation = 0.0;
  double ram_speed = 0.0;  // [m/s]; 0: the class's
  std::string config_out, truth_out;
  Recording recording;
  double oil_start = std::numeric_limits<double>::quiet_NaN();  // [degC]; NaN: no temperature
  double oil_end = std::numeric_limits<double>::quiet_NaN();
};

// "a" or "a,b" -> one or two finite numbers.
std::vector<double> numbers(const std::string& text, std::size_t most) {
  const auto items = splitList(text);
  if (items.empty() || items.size() > most)
    throw std::invalid_argument("'" + text + "': wrong count of numbers");
  std::vector<double> out;
  for (const auto& item : items) {
    const auto value = numberIn(item, -1e300, 1e300);
    if (!value) throw std::invalid_argument("'" + item + "' is not a finite number");
    out.push_back(*value);
  }
  return out;
}

void addPressOptions(ArgumentParser& arguments, Options& o) {
  arguments.number("--cycles", 0.0, 1e6, &o.cycles)
      .number("--hours", 0.0, 1e4, &o.hours)
      .option("--press",
              [&o](const std::string& v) {
                if (!parsePressClass(v, &o.press)) {
                  std::string known;
                  for (PressClass c : allPressClasses())
                    known += std::string(known.empty() ? "" : ", ") + pressClassName(c);
                  throw std::invalid_argument("--press '" + v + "' is not a press class (" + known + ")");
                }
              })
      .number("--variation", 0.0, 1e9, &o.variation)
      .number("--ram-speed", 0.01, 20.0, &o.ram_speed)
      .option("--write-config", [&o](const std::string& v) { o.config_out = v; })
      .option("--write-truth", [&o](const std::string& v) { o.truth_out = v; })
      .option("--plant-effects", [&o](const std::string& v) { o.plant.effects = splitList(v); })
      .option("--custom-effect", [&o](const std::string& v) { o.plant.custom_effects.push_back(v); })
      .option(
          "--set",
          [&o](const std::string& kv) {
            const auto eq = kv.find('=');
            const auto value =
                eq == std::string::npos ? std::nullopt : numberIn(kv.substr(eq + 1), -1e300, 1e300);
            if (!value)
              throw std::invalid_argument("--set needs NAME=VALUE with a finite number, got '" + kv + "'");
            o.plant.parameters[kv.substr(0, eq)] = *value;
          })
      .option("--seed",
              [&o](const std::string& v) {
                const auto seed = wholeNumberIn(v, 0, std::numeric_limits<long>::max());
                if (!seed) throw std::invalid_argument("--seed needs a whole number >= 0, got '" + v + "'");
                o.plant.seed = static_cast<std::uint64_t>(*seed);
              })
      .flag("--sweep", [&o] { o.sweep = true; })
      .option("--step-test",
              [&o](const std::string& v) {
                const auto step = numberIn(v, -10.0, 10.0);
                if (!step || *step == 0.0) {
                  throw std::invalid_argument(
                      "--step-test needs a voltage step in [-10, 10] V, not 0, got '" + v + "'");
                }
                o.step_test = *step;
              })
      .number("--effects-from-cycle", 0.0, 1e6, &o.effects_from_cycle)
      .option("--oil-temperature",
              [&o](const std::string& v) {
                const auto t = numbers(v, 2);
                for (double x : t) {
                  if (!(x >= -30.0 && x <= 150.0))
                    throw std::invalid_argument(
                        "--oil-temperature needs START[,END] in [-30, 150] degC, got '" + v + "'");
                }
                o.oil_start = t[0];
                o.oil_end = t.size() > 1 ? t[1] : t[0];
              })
      .option("--oil-law",
              [&o](const std::string& v) {
                const auto c = numbers(v, 2);
                if (c.size() != 2 || !(c[0] >= -0.02 && c[0] <= 0.0) || !(c[1] >= 0.0 && c[1] <= 0.1))
                  throw std::invalid_argument(
                      "--oil-law needs ALPHA,BETA with ALPHA in [-0.02, 0] and BETA in "
                      "[0, 0.1] 1/K, got '" +
                      v + "'");
                o.plant.oil.bulk_modulus_coefficient = c[0];
                o.plant.oil.leakage_coefficient = c[1];
              })
      .number("--epoch", 0.0, 4e9, &o.epoch)
      .positional("output bag", 1, [&o](const std::string& v) { o.out = v; });
}

void addSensorOptions(ArgumentParser& arguments, Options& o) {
  arguments.flag("--no-spool", [&o] { o.plant.sensors.measure_spool = false; })
      .flag("--no-velocity", [&o] { o.plant.sensors.publish_velocity = false; })
      .option("--joints", [&o](const std::string& v) { o.recording.joints = splitList(v); })
      .option("--joint-name", [&o](const std::string& v) { o.recording.cushion_joint = v; })
      .option("--rates",
              [&o](const std::string& v) {
                double rates[kInputStreamCount];
                threeNumbers(v, rates);
                for (double rate : rates) {
                  if (!(rate > 0.0))
                    throw std::invalid_argument("--rates needs three rates above 0 Hz, got '" + v + "'");
                }
                o.plant.sensors.pressure_rate = rates[0];
                o.plant.sensors.position_rate = rates[1];
                o.plant.sensors.valve_rate = rates[2];
              })
      .option("--stamp-offsets", [&o](const std::string& v) { threeNumbers(v, o.recording.stamp_offsets); })
      .flag("--continuous-command", [&o] { o.continuous_command = true; })
      .number("--start-offset", 0.0, 1e6, &o.start_offset);
}

/// What the parser cannot check option by option; "" when consistent.
std::string inconsistency(const Options& o) {
  if (o.out.empty()) return std::string("no output bag given\n") + kUsage;
  const auto& joints = o.recording.joints;
  if (std::find(joints.begin(), joints.end(), o.recording.cushion_joint) == joints.end()) {
    return "--joint-name '" + o.recording.cushion_joint + "' is not among --joints";
  }
  if (o.variation != std::floor(o.variation)) {
    std::ostringstream text;
    text << "--variation needs a whole number, got " << o.variation;
    return text.str();
  }
  return "";
}

// The class's press with the options' sensors, effects and true parameters on top.
SimulatorConfig buildPlant(const Options& o) {
  SimulatorConfig built =
      pressClassPlant(o.press, static_cast<std::uint64_t>(o.variation), o.plant.effects, o.plant.seed);
  built.sensors = o.plant.sensors;
  built.custom_effects = o.plant.custom_effects;
  built.oil = o.plant.oil;
  if (std::isfinite(o.oil_start)) {
    // The plant follows its oil's temperature: the effect, its coefficient the law's unless --set.
    if (std::find(built.effects.begin(), built.effects.end(), "oil_temperature") == built.effects.end())
      built.effects.push_back("oil_temperature");
    built.parameters.emplace("bulk_modulus_temperature_coefficient", built.oil.bulk_modulus_coefficient);
    built.oil_temperature.start = o.oil_start;
  }
  for (const auto& [name, value] : o.plant.parameters) built.parameters[name] = value;
  if (o.ram_speed > 0.0) built.cycle.drawing_speed = o.ram_speed;
  return built;
}

void writeConfig(const Options& o, const SimulatorConfig& plant, const std::string& path) {
  std::ofstream file(path);
  file << "# The press simulate_bag recorded (" << pressClassName(o.press) << ", variation " << o.variation
       << "): its geometry for analyze_bag --config.\n"
       << "piston_area: " << plant.geometry.piston_area << "\nstroke_length: " << plant.geometry.stroke_length
       << "\nsupply_pressure: " << plant.geometry.supply_pressure << "\n";
  // Several joints on the position topic: the cushion's name, as its user would configure it.
  if (o.recording.joints.size() > 1) file << "joint_name: " << o.recording.cushion_joint << "\n";
  closeChecked(file, o.config_out);
}

// The plant's true parameters, by name (every one the simulated model has, effects included), and its valve.
void writeTruth(const Options& o, const SimulatorConfig& plant, const std::string& path) {
  const DieCushionSimulator probe(plant);
  std::ofstream file(path);
  file.precision(10);
  file << "# The true parameters of the press simulate_bag recorded (" << pressClassName(o.press)
       << ", variation " << o.variation << ").\n";
  const auto& infos = probe.model().parameterInfos();
  for (std::size_t i = 0; i < infos.size(); ++i)
    file << infos[i].name << ": " << probe.trueParameters()(i) << "\n";
  file << "valve_natural_frequency: " << plant.valve.natural_frequency
       << "\nvalve_damping: " << plant.valve.damping << "\nvalve_gain: " << plant.valve.gain
       << "\nvalve_dead_time: " << plant.valve.dead_time << "\n";
  if (std::isfinite(o.oil_start)) {
    file << "# The parameters above hold at reference_temperature [degC]; the coefficients are per kelvin.\n"
         << "reference_temperature: " << plant.oil.reference_temperature
         << "\nleakage_temperature_coefficient: " << plant.oil.leakage_coefficient
         << "\noil_temperature_start: " << o.oil_start << "\noil_temperature_end: " << o.oil_end << "\n";
  }
  if (o.effects_from_cycle > 0.0) {
    file << "effects_from_cycle: " << o.effects_from_cycle
         << "\neffects_from_time: " << o.effects_from_cycle * probe.program().cycleDuration() - o.start_offset
         << "\n";
  }
  closeChecked(file, o.truth_out);
}

/// The press cycles; returns where an appended test starts [s of the recording].
double recordPressCycles(const Options& o, SimulatorConfig plant, BagRecorder& recorder) {
  const double duration =
      o.hours > 0.0 ? o.hours * 3600.0 : o.cycles * PressCycleProgram(plant.cycle).cycleDuration();
  if (plant.oil_temperature.recorded() && duration > 0.0) {
    // From START at the recording's start to END at its end; the lead-in before a mid-stroke start is as warm
    // as the start.
    plant.oil_temperature.warming_rate = (o.oil_end - o.oil_start) / duration;
    plant.oil_temperature.start = o.oil_start - plant.oil_temperature.warming_rate * o.start_offset;
  }
  DieCushionSimulator press(plant);
  std::vector<SimulatedMeasurement> messages;
  // The effects' own parameters (after the base model's three) held at 0 until their cycle.
  const ParameterVector effect_truth = press.trueParameters();
  const auto& infos = press.model().parameterInfos();
  const double effects_from = o.effects_from_cycle * press.program().cycleDuration();
  bool effects_acting = !(effects_from > 0.0);
  const auto setEffects = [&](bool acting) {
    for (std::size_t i = HydraulicModel::kDeadVolume + 1; i < infos.size(); ++i) {
      if (static_cast<int>(i) == press.model().oilStateParameter()) continue;  // the oil is there throughout
      press.setTrueParameter(infos[i].name, acting ? effect_truth(static_cast<Eigen::Index>(i)) : 0.0);
    }
  };
  if (!effects_acting) setEffects(false);
  while (press.state().t < duration + o.start_offset) {
    if (!effects_acting && press.state().t >= effects_from) {
      setEffects(true);
      effects_acting = true;
    }
    messages.clear();
    press.step(&messages);
    if (press.state().t < o.start_offset) {  // not recorded yet: the recording starts mid-stroke
      std::vector<StreamSample> unrecorded;
      press.takeOilTemperature(&unrecorded);
      continue;
    }
    for (const auto& m : messages) recorder.write(m, -o.start_offset);
    recorder.writeOilTemperature(press, -o.start_offset);
  }
  return press.state().t - o.start_offset + 2.0;
}

// What a live sweep's safety check sees of the cushion, from its messages (arriving as they are stamped).
struct SweepWatch {
  PlantSignals signals;

  void see(const SimulatedMeasurement& m, ValveSweep& valve_sweep) {
    const Instant arrival = Instant::simulated(m.sample.stamp);
    if (m.stream == InputStream::kPressure) {
      signals.pressure(m.sample.stamp, m.sample.first, arrival);
    } else if (m.stream == InputStream::kPosition) {
      // Without a velocity channel the safety check uses the node's causal slope of the positions.
      signals.position(m.sample.stamp, m.sample.first, arrival);
    } else {
      signals.valve(m.sample.stamp, m.sample.second, arrival);
      valve_sweep.addValveSample(m.sample.stamp, m.sample.first, m.sample.second);
    }
  }
};

/// The same cushion standing at rest from `offset` on, swept as ValveSweep sweeps it live; returns where
/// the next appended test starts.
// The plant at rest for an appended test: its oil as warm as at the recording's end, held.
SimulatorConfig atRest(const Options& o, const SimulatorConfig& plant) {
  SimulatorConfig at_rest = plant;
  at_rest.cycle.rest_time = 1e9;
  if (at_rest.oil_temperature.recorded()) {
    at_rest.oil_temperature.start = o.oil_end;
    at_rest.oil_temperature.warming_rate = 0.0;
  }
  return at_rest;
}

double recordSweep(const Options& o, const SimulatorConfig& plant, double offset, BagRecorder& recorder) {
  const SimulatorConfig at_rest = atRest(o, plant);
  DieCushionSimulator cushion(at_rest);
  ValveSweep valve_sweep{SweepLimits()};
  SweepWatch watch;
  SweepRequest request;
  request.offset = 0.1;
  bool started = false;
  std::vector<SimulatedMeasurement> messages;
  while (cushion.state().t < 600.0) {
    const double now = cushion.state().t;
    const PlantCondition condition = watch.signals.at(Instant::simulated(now));
    if (!started && now > 0.2) {
      const std::string refusal = valve_sweep.start(request, Instant::simulated(now), condition);
      if (!refusal.empty()) throw std::runtime_error("sweep refused: " + refusal);
      started = true;
    }
    valve_sweep.supervise(Instant::simulated(now), condition);
    const auto u = valve_sweep.command(now);
    if (o.continuous_command && started) {
      cushion.setValveCommandSignal([&valve_sweep](double t) { return valve_sweep.commandAt(t); });
    } else if (u) {
      cushion.setValveCommandOverride(*u);
    }
    messages.clear();
    cushion.step(&messages);
    for (const auto& m : messages) {
      recorder.write(m, offset);
      watch.see(m, valve_sweep);
    }
    recorder.writeOilTemperature(cushion, offset);
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
    recorder.writeOilTemperature(cushion, offset);
  }
  return offset + cushion.state().t + 2.0;
}

// The cushion at rest under its controller, then the command held at its last value for 0.3 s (as
// ~start_step_test holds the offset), stepped by step_test for 1.5 s, and back to the controller.
void recordStepTest(const Options& o, const SimulatorConfig& plant, double offset, BagRecorder& recorder) {
  const SimulatorConfig at_rest = atRest(o, plant);
  DieCushionSimulator cushion(at_rest);
  std::vector<SimulatedMeasurement> messages;
  const auto run = [&](double until) {
    while (cushion.state().t < until - 1e-12) {
      messages.clear();
      cushion.step(&messages);
      for (const auto& m : messages) recorder.write(m, offset);
      recorder.writeOilTemperature(cushion, offset);
    }
  };
  run(0.7);
  const double held = cushion.state().u;
  cushion.setValveCommandOverride(held);
  run(1.0);
  cushion.setValveCommandOverride(held + o.step_test);
  run(2.5);
  cushion.setValveCommandOverride(std::nullopt);
  run(3.0);
}

int run(int argc, char** argv) {
  Options o;
  ArgumentParser arguments;
  addPressOptions(arguments, o);
  addSensorOptions(arguments, o);
  arguments.parseOrExit(argc, argv, "simulate_bag", kUsage);
  if (const std::string problem = inconsistency(o); !problem.empty()) {
    std::cerr << "simulate_bag: " << problem << (problem.back() == '\n' ? "" : "\n");
    return 2;
  }
  const SimulatorConfig plant = buildPlant(o);
  if (!(plant.sensors.valve_rate <= 1.0 / plant.control_period + 1e-9)) {
    std::cerr << "simulate_bag: the valve rate cannot exceed the 1000 Hz command rate\n";
    return 2;
  }
  try {
    // A bag cut by a full disk reads as a valid, shorter recording: nothing takes its final name before
    // everything is whole; a failure removes the temporary files (OutputFiles' destructor).
    OutputFiles files;
    if (!o.config_out.empty()) writeConfig(o, plant, files.add(o.config_out));
    if (!o.truth_out.empty()) writeTruth(o, plant, files.add(o.truth_out));
    {
      BagRecorder recorder(files.add(o.out), o.epoch, o.recording);
      double next_block = recordPressCycles(o, plant, recorder);
      if (o.sweep) next_block = recordSweep(o, plant, next_block, recorder);
      if (o.step_test != 0.0) recordStepTest(o, plant, next_block, recorder);
      recorder.close();
    }
    files.commit();
  } catch (const WriteError& e) {
    std::cerr << "simulate_bag: " << e.what() << "\n";
    return 4;
  } catch (const std::exception& e) {
    std::cerr << "simulate_bag: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

int main(int argc, char** argv) { return run(argc, argv); }
