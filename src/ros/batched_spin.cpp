#include "batched_spin.h"

#include <algorithm>
#include <chrono>
#include <thread>

namespace die_cushion_ident {

void spinBatched(ros::CallbackQueue& queue, const std::function<bool()>& fine,
                 const std::atomic<bool>& stop) {
  // Batches are 5 ms of wall time, but at most 20 ms of ROS time: when a simulation runs 40x faster than
  // real time under /use_sim_time, 5 ms of wall time are 200 ms of stamps and the inputs would look stale.
  double speed = 1.0;  // ROS time per wall time, smoothed
  double last_ros = ros::Time::now().toSec();
  auto last_wall = std::chrono::steady_clock::now();
  while (ros::ok() && !stop) {
    queue.callAvailable();
    const auto wall = std::chrono::steady_clock::now();
    const double ros_now = ros::Time::now().toSec();
    const double elapsed = std::chrono::duration<double>(wall - last_wall).count();
    if (elapsed > 0.05) {
      speed += 0.5 * (std::max(ros_now - last_ros, 0.0) / elapsed - speed);
      last_ros = ros_now;
      last_wall = wall;
    }
    const double batch = fine() ? 2e-4 : std::clamp(0.02 / std::max(speed, 1e-3), 2e-4, 5e-3);
    std::this_thread::sleep_for(std::chrono::duration<double>(batch));
  }
}

}  // namespace die_cushion_ident
