// The cost floor of the identification's inputs, for scripts/measure_node_cpu: the three input topics
// subscribed with empty callbacks, as a separate roscpp node (input_floor_node) and as a nodelet in the
// simulator's manager (die_cushion_ident/InputFloorNodelet). Whatever the identification costs beyond these
// is its own work; below them it cannot go with roscpp's transport.
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/JointState.h>

#include <atomic>
#include <pluginlib/class_list_macros.hpp>

#include "die_cushion_ident/ValveSignal.h"

namespace die_cushion_ident {

/// Subscribes to pressure, position and valve with the identification's queue sizes and only counts.
class InputFloor {
 public:
  explicit InputFloor(ros::NodeHandle nh) {
    pressure_ = nh.subscribe("pressure", 1000, &InputFloor::onPressure, this);
    position_ = nh.subscribe("position", 1000, &InputFloor::onPosition, this);
    valve_ = nh.subscribe("valve", 1000, &InputFloor::onValve, this, ros::TransportHints().tcpNoDelay());
  }

 private:
  void onPressure(const sensor_msgs::FluidPressure::ConstPtr&) { ++received_; }
  void onPosition(const sensor_msgs::JointState::ConstPtr&) { ++received_; }
  void onValve(const ValveSignal::ConstPtr&) { ++received_; }

  ros::Subscriber pressure_, position_, valve_;
  std::atomic<std::uint64_t> received_{0};
};

class InputFloorNodelet : public nodelet::Nodelet {
 private:
  void onInit() override { floor_ = std::make_unique<InputFloor>(getNodeHandle()); }
  std::unique_ptr<InputFloor> floor_;
};

}  // namespace die_cushion_ident

#ifdef DIE_CUSHION_IDENT_FLOOR_NODE
int main(int argc, char** argv) {
  ros::init(argc, argv, "input_floor");
  die_cushion_ident::InputFloor floor{ros::NodeHandle()};
  ros::spin();
  return 0;
}
#else
PLUGINLIB_EXPORT_CLASS(die_cushion_ident::InputFloorNodelet, nodelet::Nodelet)
#endif
