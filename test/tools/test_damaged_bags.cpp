// Damage anywhere in a recording is found and named, and the reading goes on after it: 200 random bytes
// written at random positions of bags written by rosbag itself (uncompressed, lz4, bz2). A ROS bag holds no
// checksums; what gives damage away is its structure (every length, every record header), the index after
// each chunk (each message's time and offset) and at the end (each chunk's position and counts), the
// connection records' two copies and the file header's padding.
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/JointState.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "bag_stream_reader.h"
#include "die_cushion_ident/ValveSignal.h"

namespace die_cushion_ident {
namespace {

std::string temporaryPath(const std::string& name) {
  return "/tmp/test_damaged_bags_" + std::to_string(::getpid()) + "_" + name;
}

// Three 1 kHz topics for `seconds`, as a cell records them.
void writeRecording(const std::string& path, rosbag::compression::CompressionType compression, int samples) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  bag.setCompression(compression);
  for (int k = 0; k < samples; ++k) {
    const ros::Time t(1700000000.0 + 1e-3 * k);
    sensor_msgs::FluidPressure p;
    p.header.stamp = t;
    p.fluid_pressure = 1e6 + k;
    bag.write("/die_cushion/pressure", t, p);
    sensor_msgs::JointState x;
    x.header.stamp = t;
    x.name = {"ram", "cushion", "holder"};
    x.position = {0.1, 1e-6 * k, 0.01};
    bag.write("/die_cushion/position", t, x);
    ValveSignal u;
    u.header.stamp = t;
    u.voltage = 1e-4 * k;
    u.spool_position = 0.1;
    bag.write("/die_cushion/valve", t, u);
  }
  bag.close();
}

std::string fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

struct Reading {
  bool complete = false;
  std::uint64_t messages = 0;
  std::vector<BagStreamReader::Damage> damage;
  bool in_order = true;
};

Reading readBag(const std::string& path) {
  Reading r;
  BagStreamReader reader(path);
  double previous = 0.0;
  r.complete = reader.read([&](const BagStreamReader::Message& m) {
    ++r.messages;
    r.in_order = r.in_order && m.time >= previous;
    previous = m.time;
  });
  r.damage = reader.damage();
  return r;
}

// Losses of `copies` damaged copies of `bag` (200 random bytes each at a random position after the magic).
std::vector<std::uint64_t> damageAndRead(const std::string& bag, int copies, unsigned seed) {
  const std::string bytes = fileBytes(bag);
  const Reading whole = readBag(bag);
  EXPECT_TRUE(whole.complete);
  EXPECT_TRUE(whole.damage.empty()) << whole.damage.front().what;
  std::mt19937 random(seed);
  std::uniform_int_distribution<std::size_t> where(13, bytes.size() - 201);
  std::uniform_int_distribution<int> byte(0, 255);
  std::vector<std::uint64_t> lost;
  const std::string path = bag + ".damaged";
  for (int k = 0; k < copies; ++k) {
    std::string damaged = bytes;
    const std::size_t at = where(random);
    for (std::size_t i = 0; i < 200; ++i) damaged[at + i] = static_cast<char>(byte(random));
    std::ofstream(path, std::ios::binary) << damaged;
    SCOPED_TRACE("200 bytes at " + std::to_string(at) + " of " + std::to_string(bytes.size()));
    const Reading r = readBag(path);
    EXPECT_FALSE(r.complete) << "damage is never silent";
    EXPECT_FALSE(r.damage.empty());
    if (!r.damage.empty()) {
      EXPECT_LE(r.damage.front().position, at + 200) << "named where it is: " << r.damage.front().what;
    }
    EXPECT_TRUE(r.in_order);
    EXPECT_LE(r.messages, whole.messages);
    lost.push_back(whole.messages - r.messages);
  }
  std::remove(path.c_str());
  std::sort(lost.begin(), lost.end());
  return lost;
}

TEST(DamagedBags, DamageAtAHundredRandomPositionsIsNamedAndTheRestIsRead) {
  const std::string bag = temporaryPath("plain.bag");
  writeRecording(bag, rosbag::compression::Uncompressed, 6000);
  const std::vector<std::uint64_t> lost = damageAndRead(bag, 100, 1);
  std::printf("messages lost of %d: median %llu, 90th percentile %llu, most %llu\n", 3 * 6000,
              static_cast<unsigned long long>(lost[50]), static_cast<unsigned long long>(lost[90]),
              static_cast<unsigned long long>(lost.back()));
  // 200 bytes cover two or three records: those, and the one before (whose bytes may be damaged too).
  EXPECT_LE(lost[50], 5u);
  // A damaged chunk header loses its chunk (about 6000 messages); 200 bytes in 100 copies rarely meet one.
  EXPECT_LE(std::count_if(lost.begin(), lost.end(), [](std::uint64_t n) { return n > 20; }), 3);
  std::remove(bag.c_str());
}

TEST(DamagedBags, DamageInCompressedChunksIsNamed) {
  for (const auto compression : {rosbag::compression::LZ4, rosbag::compression::BZ2}) {
    const std::string bag = temporaryPath("compressed.bag");
    writeRecording(bag, compression, 6000);
    // A damaged compressed chunk cannot be resynchronised inside: it is lost, the others are read.
    const std::vector<std::uint64_t> lost = damageAndRead(bag, 20, 2);
    EXPECT_LT(lost[10], 3u * 6000u) << "the chunks after the damaged one are read";
    std::remove(bag.c_str());
  }
}

}  // namespace
}  // namespace die_cushion_ident
