// simulator_node: the core DieCushionSimulator on ROS topics, so that the whole loop runs without hardware.
// Publishes `pressure`, `position` and `valve` (the contract's input topics) in its namespace, follows
// `valve_command` while a sweep sends it, and publishes its true parameters on ~truth and ~valve_truth.
// Under /use_sim_time it is the clock: it publishes /clock and runs ~realtime_factor times faster than
// real time (0 = as fast as possible). ~inject_fault plays a dead bus, a stopped /clock or drives whose
// clocks are off, for trying a cell's supervision (the fault-injection rostests).
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/JointState.h>

#include <atomic>
#include <cmath>
#include <mutex>
#include <pluginlib/class_list_macros.hpp>
#include <thread>

#include "die_cushion_ident/InjectFault.h"
#include "die_cushion_ident/ParameterEstimate.h"
#include "die_cushion_ident/ValveModel.h"
#include "die_cushion_ident/ValveSignal.h"
#include "die_cushion_ident/core/simulation/die_cushion_simulator.h"
#include "message_conversions.h"
#include "ros_parameters.h"

namespace die_cushion_ident {
namespace {

std::vector<std::string> stringList(const ros::NodeHandle& pnh, const std::string& key) {
  std::vector<std::string> out, problems;
  readStrings(pnh, key, &out, &problems);
  if (!problems.empty()) throw std::invalid_argument(problems.front());
  return out;
}

double number(const ros::NodeHandle& pnh, const std::string& key, double fallback) {
  double value = fallback;
  pnh.param(key, value, fallback);
  if (!std::isfinite(value)) throw std::invalid_argument("~" + key + " must be finite");
  return value;
}

SimulatorConfig loadSimulatorConfig(const ros::NodeHandle& pnh) {
  SimulatorConfig c;
  pnh.param("piston_area", c.geometry.piston_area, c.geometry.piston_area);
  pnh.param("stroke_length", c.geometry.stroke_length, c.geometry.stroke_length);
  pnh.param("supply_pressure", c.geometry.supply_pressure, c.geometry.supply_pressure);
  c.effects = stringList(pnh, "effects");
  c.custom_effects = stringList(pnh, "custom_effects");
  XmlRpc::XmlRpcValue truth;
  if (pnh.getParam("true_parameters", truth)) {
    if (truth.getType() != XmlRpc::XmlRpcValue::TypeStruct)
      throw std::invalid_argument("~true_parameters must be a dictionary name: value");
    for (auto it = truth.begin(); it != truth.end(); ++it) {
      XmlRpc::XmlRpcValue& v = it->second;
      const double value =
          v.getType() == XmlRpc::XmlRpcValue::TypeInt ? static_cast<int>(v) : static_cast<double>(v);
      c.parameters[it->first] = value;
    }
  }
  c.valve.natural_frequency = number(pnh, "valve_natural_frequency", c.valve.natural_frequency);
  c.valve.damping = number(pnh, "valve_damping", c.valve.damping);
  c.valve.gain = number(pnh, "valve_gain", c.valve.gain);
  c.valve.dead_time = number(pnh, "valve_dead_time", c.valve.dead_time);
  const double vmax = number(pnh, "valve_max_spool_velocity", 0.0);
  if (vmax > 0.0) c.valve.max_spool_velocity = vmax;
  bool noise = true, at_rest = false;
  pnh.param("noise", noise, true);
  if (!noise) {
    c.sensors.pressure_noise = c.sensors.position_noise = c.sensors.velocity_noise = c.sensors.spool_noise =
        0.0;
    c.sensors.jitter = 0.0;
  }
  pnh.param("measure_spool", c.sensors.measure_spool, true);
  pnh.param("publish_velocity", c.sensors.publish_velocity, true);
  pnh.param("at_rest", at_rest, false);
  c.cycle.rest_time = at_rest ? 1e9 : number(pnh, "rest_time", c.cycle.rest_time);
  c.integration_step = number(pnh, "integration_step", c.integration_step);
  int seed = 1;
  pnh.param("seed", seed, 1);
  c.seed = static_cast<std::uint64_t>(seed);
  return c;
}

class SimulatorNode {
 public:
  SimulatorNode(ros::NodeHandle nh, ros::NodeHandle pnh)
      : nh_(nh), pnh_(pnh), sim_(loadSimulatorConfig(pnh)) {
    realtime_factor_ = number(pnh, "realtime_factor", 1.0);
    command_timeout_ = number(pnh, "command_timeout", 0.05);
    duration_ = number(pnh, "duration", 0.0);
    pnh.param("/use_sim_time", sim_time_, false);
    if (!sim_time_ && !(realtime_factor_ > 0.0))
      throw std::invalid_argument("~realtime_factor must be > 0 unless /use_sim_time is set");
    pressure_pub_ = nh_.advertise<sensor_msgs::FluidPressure>("pressure", 1000);
    position_pub_ = nh_.advertise<sensor_msgs::JointState>("position", 1000);
    valve_pub_ = nh_.advertise<ValveSignal>("valve", 1000);
    truth_pub_ = pnh_.advertise<ParameterEstimate>("truth", 1, true);
    valve_truth_pub_ = pnh_.advertise<ValveModel>("valve_truth", 1, true);
    if (sim_time_) clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 10);
    command_sub_ = nh_.subscribe("valve_command", 100, &SimulatorNode::onCommand, this,
                                 ros::TransportHints().tcpNoDelay());
    fault_srv_ = pnh_.advertiseService("inject_fault", &SimulatorNode::injectFault, this);
    publishTruth();
  }

  void stop() { stop_ = true; }
  /// Integrates and publishes until shutdown, stop() or ~duration.
  void run() {
    // Sim time starts at 1000 s: ROS treats time zero as "not set".
    const double epoch = sim_time_ ? 1000.0 : ros::WallTime::now().toSec();
    const ros::WallTime wall_start = ros::WallTime::now();
    std::vector<SimulatedMeasurement> out;
    while (ros::ok() && !stop_ && (duration_ <= 0.0 || sim_.state().t < duration_)) {
      const double now = epoch + sim_.state().t;
      {
        std::lock_guard<std::mutex> lock(command_mutex_);
        const bool fresh =
            received_command_ && now - command_time_ < command_timeout_ && now >= command_time_ - 1.0;
        sim_.setValveCommandOverride(fresh ? std::optional<double>(command_) : std::nullopt);
      }
      out.clear();
      sim_.step(&out);
      if (!silence_inputs_) {
        for (const auto& m : out) publish(m, epoch + stamp_offset_);
      }
      if (sim_time_ && !stop_clock_) {
        rosgraph_msgs::Clock clock;
        clock.clock = ros::Time(epoch + sim_.state().t);
        clock_pub_.publish(clock);
      }
      if (realtime_factor_ > 0.0) {
        const ros::WallTime due = wall_start + ros::WallDuration(sim_.state().t / realtime_factor_);
        const ros::WallDuration wait = due - ros::WallTime::now();
        if (wait > ros::WallDuration(0)) wait.sleep();
      }
    }
  }

 private:
  bool injectFault(InjectFault::Request& req, InjectFault::Response& res) {
    if (!std::isfinite(req.stamp_offset)) {
      res.success = false;
      res.message = "stamp_offset must be finite";
      return true;
    }
    silence_inputs_ = req.silence_inputs;
    stop_clock_ = req.stop_clock;
    stamp_offset_ = req.stamp_offset;
    res.success = true;
    res.message = std::string(req.silence_inputs ? "inputs silent" : "inputs published") +
                  (req.stop_clock ? ", /clock stopped" : "") + ", stamps offset by " +
                  std::to_string(req.stamp_offset) + " s";
    ROS_WARN("simulator: fault injected: %s", res.message.c_str());
    return true;
  }

  void onCommand(const ValveSignal::ConstPtr& msg) {
    if (!std::isfinite(msg->voltage)) {
      ROS_WARN_THROTTLE(5.0, "simulator: non-finite valve_command ignored");
      return;
    }
    std::lock_guard<std::mutex> lock(command_mutex_);
    command_ = msg->voltage;
    command_time_ = sim_time_ ? ros::Time::now().toSec() : ros::WallTime::now().toSec();
    received_command_ = true;
  }

  void publish(const SimulatedMeasurement& m, double epoch) {
    const ros::Time stamp(epoch + m.sample.stamp);
    switch (m.stream) {
      // Shared pointers: inside a nodelet manager the messages reach the identification without copies.
      case InputStream::kPressure:
        pressure_pub_.publish(
            boost::make_shared<sensor_msgs::FluidPressure>(toFluidPressureMsg(m.sample, stamp)));
        break;
      case InputStream::kPosition:
        position_pub_.publish(boost::make_shared<sensor_msgs::JointState>(toJointStateMsg(m.sample, stamp)));
        break;
      case InputStream::kValve:
        valve_pub_.publish(boost::make_shared<ValveSignal>(toValveSignalMsg(m.sample, stamp)));
        break;
    }
  }

  void publishTruth() {
    const auto& truth_values = sim_.trueParameters();
    const ParameterEstimate truth = toParameterEstimateMsg(
        sim_.model(), std::vector<double>(truth_values.data(), truth_values.data() + truth_values.size()),
        std::vector<double>(truth_values.size(), 0.0), ros::Time::now());
    truth_pub_.publish(truth);
    ValveModel valve;
    valve.header.stamp = truth.header.stamp;
    valve.success = true;
    valve.message = "simulator truth";
    const auto& v = sim_.config().valve;
    valve.natural_frequency = v.natural_frequency;
    valve.damping = v.damping;
    valve.gain = v.gain;
    valve.dead_time = v.dead_time;
    valve_truth_pub_.publish(valve);
  }

  ros::NodeHandle nh_, pnh_;
  DieCushionSimulator sim_;
  double realtime_factor_ = 1.0, command_timeout_ = 0.05, duration_ = 0.0;
  bool sim_time_ = false;
  std::atomic<bool> stop_{false};
  std::atomic<bool> silence_inputs_{false}, stop_clock_{false};
  std::atomic<double> stamp_offset_{0.0};
  std::mutex command_mutex_;
  double command_ = 0.0, command_time_ = -1e18;
  bool received_command_ = false;
  ros::Publisher pressure_pub_, position_pub_, valve_pub_, truth_pub_, valve_truth_pub_, clock_pub_;
  ros::Subscriber command_sub_;
  ros::ServiceServer fault_srv_;
};

}  // namespace

/// The simulator inside a nodelet manager (die_cushion_ident/SimulatorNodelet): same parameters, run in its
/// own thread; together with IdentificationNodelet in one manager no message is serialised.
class SimulatorNodelet : public nodelet::Nodelet {
 public:
  ~SimulatorNodelet() override {
    if (node_) node_->stop();
    if (thread_.joinable()) thread_.join();
  }

 private:
  void onInit() override {
    try {
      node_ = std::make_unique<SimulatorNode>(getNodeHandle(), getPrivateNodeHandle());
      thread_ = std::thread([this] { node_->run(); });
    } catch (const std::exception& e) {
      NODELET_FATAL("simulator not started: %s", e.what());
    }
  }

  std::unique_ptr<SimulatorNode> node_;
  std::thread thread_;
};

}  // namespace die_cushion_ident

PLUGINLIB_EXPORT_CLASS(die_cushion_ident::SimulatorNodelet, nodelet::Nodelet)

#ifndef DIE_CUSHION_IDENT_NODELET_ONLY
int main(int argc, char** argv) {
  ros::init(argc, argv, "simulator_node");
  ros::NodeHandle nh, pnh("~");
  try {
    die_cushion_ident::SimulatorNode node(nh, pnh);
    ros::AsyncSpinner spinner(1);  // valve_command arrives while run() integrates
    spinner.start();
    node.run();
  } catch (const std::exception& e) {
    ROS_FATAL("simulator_node not started: %s", e.what());
    return 2;
  }
  return 0;
}
#endif
