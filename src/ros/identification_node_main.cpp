// identification_node: the nodelet's code as a standalone node for `rosrun`.
#include <ros/ros.h>
#include <ros/xmlrpc_manager.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <thread>

#include "batched_spin.h"
#include "identification_node.h"

namespace {
// SIGINT, SIGTERM and the master's shutdown call (`rosnode kill`) end the spin; the node is then destroyed
// while ROS still runs, so that its last commands (an experiment's offset, the feed-forward's ramp to 0 V)
// reach the valve. roscpp's own handlers shut ROS down at once, and a command published after that goes
// nowhere (rosnode kill mid-sweep left the valve off its offset in 3 of 3 stops).
std::atomic<bool> stop_requested(false);
void requestStop(int) { stop_requested = true; }

void onMasterShutdown(XmlRpc::XmlRpcValue& params, XmlRpc::XmlRpcValue& result) {
  if (params.getType() == XmlRpc::XmlRpcValue::TypeArray && params.size() > 1) {
    ROS_WARN("die_cushion_ident: shutdown requested (%s): the valve is handed back first",
             static_cast<std::string>(params[1]).c_str());
    stop_requested = true;
  }
  result = ros::xmlrpc::responseInt(1, "", 0);
}

// XMLRPCManager unbinds in its own server thread: the name stays taken until it has (a bind right after
// the unbind failed, and rosnode kill went on shutting ROS down under the node).
void replaceMasterShutdown() {
  auto xmlrpc = ros::XMLRPCManager::instance();
  xmlrpc->unbind("shutdown");
  for (int attempt = 0; attempt < 2000; ++attempt) {
    if (xmlrpc->bind("shutdown", onMasterShutdown)) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ROS_WARN(
      "die_cushion_ident: the master's shutdown call could not be taken over: rosnode kill stops the node "
      "without handing the valve back first");
}
}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "identification_node", ros::init_options::NoSigintHandler);
  std::signal(SIGINT, requestStop);
  std::signal(SIGTERM, requestStop);
  int status = 0;
  {
    ros::NodeHandle nh, pnh("~");  // starts the node: roscpp's "shutdown" call is bound now, replaced here
    replaceMasterShutdown();
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
