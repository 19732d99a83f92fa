// The floor of analyze_bag's speed, for scripts/benchmark: reads a bag with rosbag::View and deserializes
// every message of the three input topics, doing nothing else. Prints messages and seconds.
// Usage: bag_read_floor BAG [pressure position valve]
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/JointState.h>

#include <chrono>
#include <cstdio>

#include "die_cushion_ident/ValveSignal.h"

int main(int argc, char** argv) {
  if (argc != 2 && argc != 5) {
    std::fprintf(stderr, "usage: bag_read_floor BAG [PRESSURE POSITION VALVE]\n");
    return 2;
  }
  const std::string pressure = argc == 5 ? argv[2] : "/die_cushion/pressure";
  const std::string position = argc == 5 ? argv[3] : "/die_cushion/position";
  const std::string valve = argc == 5 ? argv[4] : "/die_cushion/valve";
  const auto start = std::chrono::steady_clock::now();
  rosbag::Bag bag(argv[1], rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery({pressure, position, valve}));
  std::uint64_t messages = 0;
  double sum = 0.0;  // keeps the deserialization from being optimised away
  for (const rosbag::MessageInstance& m : view) {
    if (m.getTopic() == pressure) {
      if (auto p = m.instantiate<sensor_msgs::FluidPressure>()) sum += p->fluid_pressure;
    } else if (m.getTopic() == position) {
      if (auto j = m.instantiate<sensor_msgs::JointState>()) sum += j->position.empty() ? 0.0 : j->position[0];
    } else if (auto v = m.instantiate<die_cushion_ident::ValveSignal>()) {
      sum += v->voltage;
    }
    ++messages;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("%llu messages in %.3f s (checksum %.6g)\n", static_cast<unsigned long long>(messages), seconds, sum);
  return 0;
}
