#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <atomic>
#include <functional>

namespace die_cushion_ident {

/// Takes a queue's callbacks in batches every 5 ms (at most 20 ms of ROS time when a simulation runs faster
/// than real time; every 0.2 ms while `fine` says so, as while a sweep commands the valve) until `stop` or
/// shutdown, instead of waking up for each of the 3000 messages per second: the estimates run on stamps, so
/// batching costs nothing but saves most of roscpp's per-message thread hand-overs.
void spinBatched(ros::CallbackQueue& queue, const std::function<bool()>& fine, const std::atomic<bool>& stop);

}  // namespace die_cushion_ident
