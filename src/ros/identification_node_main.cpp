// identification_node: the nodelet's code as a standalone node for `rosrun`.
#include <ros/ros.h>

#include <atomic>
#include <csignal>

#include "batched_spin.h"
#include "identification_node.h"

namespace {
// SIGINT and SIGTERM end the spin; the node is then destroyed while ROS still runs, so that its last
// commands (an experiment's offset, the feed-forward's ramp to 0 V) reach the valve. roscpp's own handler
// shuts ROS down at once, and a command published after that goes nowhere.
std::atomic<bool> stop_requested(false);
void requestStop(int) { stop_requested = true; }
}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "identification_node", ros::init_options::NoSigintHandler);
  std::signal(SIGINT, requestStop);
  std::signal(SIGTERM, requestStop);
  int status = 0;
  {
    ros::NodeHandle nh, pnh("~");
    try {
      die_cushion_ident::IdentificationNode node(nh, pnh);
      die_cushion_ident::spinBatched(
          *ros::getGlobalCallbackQueue(), [&node] { return node.valveExperimentRunning(); }, stop_requested);
    } catch (const std::exception& e) {
      ROS_FATAL("die_cushion_ident not started: %s", e.what());
      status = 2;
    }
  }
  ros::shutdown();
  return status;
}
