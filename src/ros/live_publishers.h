#pragma once

#include <ros/ros.h>

#include <cstdint>
#include <string>

#include "die_cushion_ident/core/monitoring/live_identification.h"

namespace die_cushion_ident {

/// What the live identification shows: ~estimate (every identification step), ~model_comparison, ~markers
/// (rviz, at most 10 Hz) and ~effect_ranking (latched, after each ranking). A topic nobody subscribes to
/// costs nothing: the estimate is only built when one is wanted.
class LivePublishers {
 public:
  explicit LivePublishers(ros::NodeHandle pnh);
  /// After an identification step of `live`.
  void identificationStep(const LiveIdentification& live, const HydraulicIdentifier& identifier);
  /// A finished ranking, stamped with the newest grid sample's time.
  void ranking(const LiveRanking& ranking, double stamp);

 private:
  ros::Publisher estimate_pub_, comparison_pub_, markers_pub_, ranking_pub_;
  std::string frame_id_ = "die_cushion";
  std::uint64_t steps_since_markers_ = 0;
};

}  // namespace die_cushion_ident
