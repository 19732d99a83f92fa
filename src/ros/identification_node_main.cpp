// identification_node: the nodelet's code as a standalone node for `rosrun`.
#include <ros/ros.h>

#include <atomic>

#include "batched_spin.h"
#include "identification_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "identification_node");
  ros::NodeHandle nh, pnh("~");
  try {
    die_cushion_ident::IdentificationNode node(nh, pnh);
    const std::atomic<bool> never(false);
    die_cushion_ident::spinBatched(*ros::getGlobalCallbackQueue(), [&node] { return node.valveExperimentRunning(); },
                                   never);
  } catch (const std::exception& e) {
    ROS_FATAL("die_cushion_ident not started: %s", e.what());
    return 2;
  }
  return 0;
}
