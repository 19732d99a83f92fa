#include "bag_fuzz.h"

#include <unistd.h>

#include <cstdio>
#include <exception>
#include <fstream>
#include <vector>

#include "bag/bag_stream_reader.h"

namespace die_cushion_ident {
namespace fuzz {

namespace {

void u32(std::string* out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}

void field(std::string* header, const std::string& name, const std::string& value) {
  u32(header, static_cast<std::uint32_t>(name.size() + 1 + value.size()));
  *header += name + "=" + value;
}

std::string record(const std::string& header, const std::string& data) {
  std::string out;
  u32(&out, static_cast<std::uint32_t>(header.size()));
  out += header;
  u32(&out, static_cast<std::uint32_t>(data.size()));
  return out + data;
}

std::string binary(std::uint32_t v) {
  std::string s;
  u32(&s, v);
  return s;
}

// A bag file built from the bytes: each byte picks the next record, the following ones its contents.
std::string bagFromBytes(const std::uint8_t* data, std::size_t size) {
  std::string bag = "#ROSBAG V2.0\n";
  static const char* const kTopics[] = {"/die_cushion/pressure", "/die_cushion/position", "/die_cushion/valve"};
  static const char* const kTypes[] = {"sensor_msgs/FluidPressure", "sensor_msgs/JointState",
                                       "die_cushion_ident/ValveSignal"};
  std::string chunk;
  std::size_t i = 0;
  const auto next = [&]() -> std::uint8_t { return i < size ? data[i++] : 0; };
  while (i < size) {
    const std::uint8_t op = next();
    std::string header;
    switch (op % 6) {
      case 0: {  // a connection
        const int s = next() % 3;
        field(&header, "op", std::string(1, '\x07'));
        field(&header, "conn", binary(next() % 4));
        field(&header, "topic", kTopics[s]);
        std::string details;
        field(&details, "type", kTypes[s]);
        field(&details, "md5sum", "*");
        chunk += record(header, details);
        break;
      }
      case 1:
      case 2: {  // a message with bytes from the input (hostile lengths included)
        field(&header, "op", std::string(1, '\x02'));
        field(&header, "conn", binary(next() % 4));
        field(&header, "time", binary(next()) + binary(0));
        const std::size_t length = next();
        std::string body;
        for (std::size_t k = 0; k < length && i < size; ++k) body.push_back(static_cast<char>(next()));
        chunk += record(header, body);
        break;
      }
      case 3: {  // close the chunk, uncompressed (sometimes with a lying size)
        field(&header, "op", std::string(1, '\x05'));
        field(&header, "compression", next() % 8 == 0 ? "lz4" : "none");
        field(&header, "size", binary(next() % 4 == 0 ? next() : static_cast<std::uint32_t>(chunk.size())));
        bag += record(header, chunk);
        chunk.clear();
        break;
      }
      case 4: {  // a raw length field: damage
        u32(&bag, static_cast<std::uint32_t>(next()) << (8 * (next() % 4)));
        break;
      }
      default:  // cut the file here
        if (next() % 4 == 0) i = size;
        break;
    }
  }
  return bag;
}

// The bag read as analyze_bag reads it, every message decoded as each input type.
void readHostileBag(const std::string& path, const std::function<void(const std::string&)>& fail) {
  try {
    BagStreamReader reader(path);
    std::vector<std::string> names;
    std::vector<double> position, velocity;
    const bool complete = reader.read([&](const BagStreamReader::Message& m) {
      double stamp = 0.0, a = 0.0, b = 0.0;
      decodeFluidPressure(m.data, m.size, &stamp, &a);
      decodeValveSignal(m.data, m.size, &stamp, &a, &b);
      if (decodeJointState(m.data, m.size, &stamp, &names, &position, &velocity) &&
          (position.size() * 8 > m.size || velocity.size() * 8 > m.size)) {
        fail("a decoded JointState holds more values than its bytes");
      }
    });
    if (!complete && reader.error().empty()) fail("a read that stopped without a reason");
  } catch (const std::exception& e) {
    fail(std::string("an exception escaped BagStreamReader: ") + e.what());
  }
}

}  // namespace

void runBagCase(const std::uint8_t* data, std::size_t size,
                const std::function<void(const std::string&)>& fail) {
  const std::string bag = bagFromBytes(data, size);
  char path[] = "/tmp/die_cushion_ident_bag_fuzz_XXXXXX";
  const int fd = mkstemp(path);
  if (fd < 0) return;
  close(fd);
  std::ofstream(path, std::ios::binary) << bag;
  readHostileBag(path, fail);
  std::remove(path);
}

}  // namespace fuzz
}  // namespace die_cushion_ident
