#pragma once

namespace die_cushion_ident {

/// One moment as the valve's supervision sees it, on two clocks [s]:
///  - `steady`: monotonic and never stopped or set (std::chrono::steady_clock in the node). Timeouts, the
///    duration limits and the feed-forward's slew rate are measured on it: the valve answers in real time.
///  - `clock`: the time the messages' stamps are compared with (ROS time: the wall clock, or /clock under
///    /use_sim_time, which may stop, jump back on `rosbag play --loop` or run faster than real time). The
///    sweep's sine and the step test's timing run on it.
/// In a simulation without real time (simulate_bag, the tests' rigs) both are the simulated time.
struct Instant {
  double steady = 0.0;
  double clock = 0.0;

  /// The same moment on both clocks: a simulated time.
  static Instant simulated(double t) { return {t, t}; }
};

}  // namespace die_cushion_ident
