#pragma once

#include <dynamic_reconfigure/server.h>
#include <ros/node_handle.h>

#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "die_cushion_ident/LiveThresholdsConfig.h"
#include "ros_parameters.h"

namespace die_cushion_ident {

/// The requested live thresholds into `settings` if the node accepts them (liveThresholdProblems, the checks
/// of start-up); `config` is left holding what applies, so that a refused request shows the values that stay.
/// Returns the problems, empty when applied.
std::vector<std::string> applyLiveThresholds(LiveThresholdsConfig* config, NodeSettings* settings);

/// The identification's live thresholds as a dynamic_reconfigure server in the node's private namespace
/// (cfg/LiveThresholds.cfg: adequacy_warn_error, adequacy_error_error [Pa], effect_ranking_window,
/// effect_ranking_period [s]; rqt_reconfigure, dynparam). A request is applied under the node's mutex and
/// `changed` runs, under it too, after each accepted change. It starts from the private parameters the node
/// read. The limits of what drives the valve are not among them: they are read once at start-up.
class LiveThresholds {
 public:
  LiveThresholds(const ros::NodeHandle& pnh, std::mutex& mutex, NodeSettings* settings,
                 std::function<void()> changed);

 private:
  dynamic_reconfigure::Server<LiveThresholdsConfig> server_;
};

}  // namespace die_cushion_ident
