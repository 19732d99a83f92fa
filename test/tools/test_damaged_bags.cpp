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

#include "bag/bag_stream_reader.h"
#include "die_cushion_ident/ValveSignal.h"
#include "killed_recording.h"

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

// A recording killed with SIGKILL (`rosbag record` leaves NAME.bag.active, issue 45): the open chunk's
// header has size 0 and its records follow it up to where the recorder's last write ended. Every whole
// message the file holds is read, in order and none skipped; the record the end of the file cuts is
// counted as not readable; the reading says the recording was not closed. Five kills at different points,
// each also cut 1 to 60 bytes shorter, so that the end falls in every part of a record (its lengths, its
// header, its data) as well as after a whole one.
void expectReadAsItHolds(const std::string& bag, int samples) {
  const testing::KilledRecordingContents holds = testing::walkKilledRecording(fileBytes(bag));
  ASSERT_TRUE(holds.open_chunk) << "rosbag's layout of a killed recording";
  // At 2 x 1 kHz and about 80 bytes a record, 768 kB chunks: two closed, the third open.
  ASSERT_GT(holds.open_chunk_messages, 1000u);
  BagStreamReader reader(bag);
  std::uint64_t delivered = 0, pressures = 0;
  bool consecutive = true;
  const bool complete = reader.read([&](const BagStreamReader::Message& m) {
    ++delivered;
    double stamp = 0.0, pressure = 0.0;
    if (m.connection->topic != "/die_cushion/pressure") return;
    ASSERT_TRUE(decodeFluidPressure(m.data, m.size, &stamp, &pressure));
    consecutive = consecutive && pressure == 1e6 + static_cast<double>(pressures);
    ++pressures;
  });
  EXPECT_EQ(delivered, holds.messages) << "exactly the whole messages the file holds";
  EXPECT_EQ(reader.messages(), holds.messages);
  EXPECT_TRUE(consecutive) << "in order, none skipped";
  // The recorder's unwritten buffer (at most 8 kB, records of at least 70 bytes) and the cut are all lost.
  EXPECT_LE(2u * samples - delivered, 8192u / 70u + 2u);
  EXPECT_EQ(reader.recordsUnreadable(), holds.ends_inside_a_record ? 1u : 0u);
  EXPECT_TRUE(reader.damage().empty()) << reader.damage().front().what;
  EXPECT_TRUE(reader.unclosed());
  EXPECT_FALSE(complete) << "a recording that was not closed is not complete";
  EXPECT_TRUE(reader.cutOff());
  EXPECT_EQ(reader.dataLost(), holds.ends_inside_a_record);
  EXPECT_NE(reader.error().find("not closed"), std::string::npos) << reader.error();
}

TEST(DamagedBags, AKilledRecordingIsReadToItsLastWholeMessage) {
  int cut_inside = 0;
  for (const int samples : {6500, 6731, 7000, 7333, 7919}) {
    SCOPED_TRACE(std::to_string(samples) + " samples written before the kill");
    const std::string bag = temporaryPath("killed.bag.active");
    ASSERT_TRUE(testing::writeKilledRecording(bag, [&](rosbag::Bag& b) {
      for (int k = 0; k < samples; ++k) {
        const ros::Time t(1700000000.0 + 1e-3 * k);
        sensor_msgs::FluidPressure p;
        p.header.stamp = t;
        p.fluid_pressure = 1e6 + k;
        b.write("/die_cushion/pressure", t, p);
        ValveSignal u;
        u.header.stamp = t;
        u.voltage = 1e-4 * k;
        b.write("/die_cushion/valve", t, u);
      }
    }));
    expectReadAsItHolds(bag, samples);
    const std::string bytes = fileBytes(bag);
    for (const std::size_t shorter : {1, 2, 3, 4, 5, 9, 17, 30, 41, 60}) {
      SCOPED_TRACE(std::to_string(shorter) + " bytes shorter");
      std::ofstream(bag, std::ios::binary) << bytes.substr(0, bytes.size() - shorter);
      cut_inside +=
          testing::walkKilledRecording(bytes.substr(0, bytes.size() - shorter)).ends_inside_a_record;
      expectReadAsItHolds(bag, samples);
    }
    std::remove(bag.c_str());
  }
  EXPECT_GE(cut_inside, 40) << "most of the shortened copies end inside a record";
}

// Killed while recording compressed (`rosbag record --lz4` / `--bz2`): the open chunk's records are one
// compressed stream after its header, which cannot be expanded without its end. The closed chunks are read,
// the rest is named as not read, and it is no damage.
TEST(DamagedBags, AKilledCompressedRecordingSaysItsOpenChunkIsNotRead) {
  for (const auto compression : {rosbag::compression::LZ4, rosbag::compression::BZ2}) {
    const std::string bag = temporaryPath("killed_compressed.bag.active");
    constexpr int kSamples = 20000;
    ASSERT_TRUE(testing::writeKilledRecording(bag, [&](rosbag::Bag& b) {
      b.setCompression(compression);
      for (int k = 0; k < kSamples; ++k) {
        const ros::Time t(1700000000.0 + 1e-3 * k);
        sensor_msgs::FluidPressure p;
        p.header.stamp = t;
        p.fluid_pressure = 1e6 + k;
        b.write("/die_cushion/pressure", t, p);
      }
    }));
    BagStreamReader reader(bag);
    std::uint64_t delivered = 0;
    EXPECT_FALSE(reader.read([&](const BagStreamReader::Message&) { ++delivered; }));
    // 768 kB of uncompressed records (about 78 bytes each) a chunk: the closed ones (about 10 000 messages
    // each), not the open one.
    EXPECT_GT(delivered, 9000u);
    EXPECT_LT(delivered, static_cast<std::uint64_t>(kSamples));
    EXPECT_TRUE(reader.unclosed());
    EXPECT_TRUE(reader.dataLost());
    EXPECT_TRUE(reader.damage().empty()) << reader.damage().front().what;
    EXPECT_NE(reader.error().find("cannot be expanded"), std::string::npos) << reader.error();
    std::remove(bag.c_str());
  }
}

}  // namespace
}  // namespace die_cushion_ident
