// BagStreamWriter against the well-kept readers: rosbag::View (through the index, by time) and our
// BagStreamReader (front to back) read back every message as written, topics, types and stamps included,
// also when a topic's messages come a little out of time order.
#include <gtest/gtest.h>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/JointState.h>

#include <cstdio>
#include <string>
#include <unistd.h>

#include "bag/bag_stream_reader.h"
#include "bag/bag_stream_writer.h"
#include "die_cushion_ident/ValveSignal.h"

namespace die_cushion_ident {
namespace {

std::string temporaryPath(const std::string& name) {
  return "/tmp/test_bag_stream_writer_" + std::to_string(::getpid()) + "_" + name;
}

// Pressure and position every ms, the valve every second ms, the position stamped 8 ms late.
void writeThreeTopics(const std::string& path, int samples) {
  BagStreamWriter bag(path);
  for (int k = 0; k < samples; ++k) {
    const ros::Time t(1700000000.0 + 1e-3 * k);
    sensor_msgs::FluidPressure p;
    p.header.stamp = t;
    p.fluid_pressure = 1e6 + k;
    bag.write("/die_cushion/pressure", t, p);
    sensor_msgs::JointState x;
    x.header.stamp = t;
    x.name = {"ram", "cushion"};
    x.position = {0.1, 1e-6 * k};
    // The position topic stamped 8 ms late by another clock: its messages lag the others in the file.
    const ros::Time late(1700000000.0 + 1e-3 * k - 0.008);
    bag.write("/die_cushion/position", late, x);
    if (k % 2 == 0) {
      ValveSignal u;
      u.header.stamp = t;
      u.voltage = 1e-4 * k;
      u.spool_position = -0.5;
      bag.write("/die_cushion/valve", t, u);
    }
  }
  bag.close();
}

TEST(BagStreamWriter, RosbagAndOurReaderReadBackEveryMessage) {
  const std::string path = temporaryPath("three_topics.bag");
  const int samples = 20000;  // several chunks (768 KB each)
  writeThreeTopics(path, samples);
  rosbag::Bag in(path);
  rosbag::View view(in);
  int pressures = 0, positions = 0, valves = 0;
  ros::Time previous;
  for (const rosbag::MessageInstance& m : view) {
    EXPECT_GE(m.getTime(), previous) << "rosbag's View yields the messages in time order";
    previous = m.getTime();
    if (const auto p = m.instantiate<sensor_msgs::FluidPressure>()) {
      EXPECT_EQ(p->fluid_pressure, 1e6 + pressures);
      EXPECT_EQ(m.getTopic(), "/die_cushion/pressure");
      EXPECT_EQ(m.getTime(), p->header.stamp);
      ++pressures;
    } else if (const auto x = m.instantiate<sensor_msgs::JointState>()) {
      ASSERT_EQ(x->position.size(), 2u);
      EXPECT_DOUBLE_EQ(x->position[1], 1e-6 * positions);
      EXPECT_EQ(x->name[1], "cushion");
      ++positions;
    } else if (const auto u = m.instantiate<ValveSignal>()) {
      EXPECT_DOUBLE_EQ(u->voltage, 1e-4 * 2 * valves);
      ++valves;
    } else {
      ADD_FAILURE() << "unexpected message type " << m.getDataType();
    }
  }
  EXPECT_EQ(pressures, samples);
  EXPECT_EQ(positions, samples);
  EXPECT_EQ(valves, samples / 2);
  EXPECT_EQ(view.getConnections().size(), 3u);
  EXPECT_EQ(view.getBeginTime(), ros::Time(1700000000.0 - 0.008));
  EXPECT_EQ(view.getEndTime(), ros::Time(1700000000.0 + 1e-3 * (samples - 1)));
  in.close();

  BagStreamReader reader(path);
  long read = 0;
  EXPECT_TRUE(reader.read([&](const BagStreamReader::Message&) { ++read; })) << reader.error();
  EXPECT_EQ(read, 2L * samples + samples / 2);
  EXPECT_FALSE(reader.cutOff());
  std::remove(path.c_str());
}

TEST(BagStreamWriter, AnEmptyBagIsValidAndAnUnwritablePathIsAnError) {
  const std::string path = temporaryPath("empty.bag");
  {
    BagStreamWriter bag(path);
    bag.close();
  }
  rosbag::Bag in(path);
  rosbag::View view(in);
  EXPECT_EQ(view.size(), 0u);
  in.close();
  std::remove(path.c_str());
  EXPECT_THROW(BagStreamWriter("/nonexistent_directory/out.bag"), std::runtime_error);
}

}  // namespace
}  // namespace die_cushion_ident
