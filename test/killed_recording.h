#pragma once
// A recording killed as `rosbag record` is killed by SIGKILL (issue 45): rosbag::Bag, the recorder's own
// writer, writes in a child process that then kills itself, so the file is what the recorder's writes had
// reached: the file header still without index (index_pos 0), the chunks closed so far, the open chunk's
// header with size 0 and its records after it, cut wherever the last flush of the recorder's stdio buffer
// ended; no index records and no chunk infos. And what such a file holds, walked record by record without
// BagStreamReader, for the tests to compare the reading with.
#include <rosbag/bag.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <functional>
#include <string>

namespace die_cushion_ident {
namespace testing {

/// Writes `path` with `write` in a child process that kills itself with SIGKILL before closing the bag;
/// true when the child died so.
inline bool writeKilledRecording(const std::string& path, const std::function<void(rosbag::Bag&)>& write) {
  const pid_t child = ::fork();
  if (child < 0) return false;
  if (child == 0) {
    {
      rosbag::Bag bag(path, rosbag::bagmode::Write);
      write(bag);
      ::raise(SIGKILL);
    }
    ::_exit(1);  // not reached
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  return WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL;
}

/// What a killed recording holds: its whole message records (in closed chunks, and after the open
/// chunk's header), and whether the file ends inside a record (the one the kill cut).
struct KilledRecordingContents {
  std::uint64_t messages = 0;
  std::uint64_t open_chunk_messages = 0;
  bool ends_inside_a_record = false;
  bool open_chunk = false;  // a chunk header with size 0 was found
};

/// Walks the records of `bytes` (a bag file, format 2.0) from after the magic line.
inline KilledRecordingContents walkKilledRecording(const std::string& bytes) {
  const auto u32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = v << 8 | static_cast<unsigned char>(bytes[at + i]);
    return v;
  };
  // The op of the record header [at, at + length): its fields are "len name=value".
  const auto opOf = [&](std::size_t at, std::size_t length) {
    for (std::size_t f = at; f + 4 <= at + length;) {
      const std::uint32_t field = u32(f);
      if (field >= 4 && bytes.compare(f + 4, 3, "op=") == 0)
        return static_cast<int>(static_cast<unsigned char>(bytes[f + 7]));
      f += 4 + field;
    }
    return -1;
  };
  // The records in [at, end): a closed chunk's are all whole.
  const auto messagesIn = [&](std::size_t at, std::size_t end) {
    std::uint64_t n = 0;
    while (at + 8 <= end) {
      const std::uint32_t h = u32(at);
      if (opOf(at + 4, h) == 2) ++n;
      at += 8 + h + u32(at + 4 + h);
    }
    return n;
  };
  KilledRecordingContents c;
  const std::size_t size = bytes.size();
  std::size_t at = std::strlen("#ROSBAG V2.0\n");
  while (at < size) {
    if (size - at < 4 || u32(at) > size - at - 4 || size - at - 4 - u32(at) < 4) {
      c.ends_inside_a_record = true;
      break;
    }
    const std::uint32_t h = u32(at), d = u32(at + 4 + h);
    if (d > size - at - 8 - h) {
      c.ends_inside_a_record = true;
      break;
    }
    const int op = opOf(at + 4, h);
    if (op == 5 && d > 0) c.messages += messagesIn(at + 8 + h, at + 8 + h + d);
    if (op == 5 && d == 0) c.open_chunk = true;
    if (op == 2) {
      ++c.messages;
      ++c.open_chunk_messages;
    }
    at += 8 + h + d;
  }
  return c;
}

}  // namespace testing
}  // namespace die_cushion_ident
