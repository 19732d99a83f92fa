#pragma once

#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <ros/message_traits.h>
#include <ros/serialization.h>
#include <ros/time.h>

namespace die_cushion_ident {

/// Writes a ROS bag (format 2.0, uncompressed chunks, with its index) front to back in large buffered
/// writes, for the tools that write hundreds of thousands of messages. rosbag::Bag::write seeks to the
/// end of the file before every message (in case the previous operation was a read), which flushes the
/// stdio buffer and costs four system calls per message: 720 000 messages took 4.8-5.4 s, 3.7-4.1 s of it
/// in the kernel (analyze_bag's analysis.bag for an hour). The result is read by rosbag (C++ and Python),
/// `rosbag info` and our BagStreamReader alike (test_bag_stream_writer).
///
/// Errors (cannot open, disk full) throw WriteError (output_files.h) naming the file; close() must be called
/// to complete the bag (the destructor closes quietly, without throwing). It writes to the name it is given:
/// the tools give it a temporary one (OutputFiles) and rename the bag when it is whole.
class BagStreamWriter {
 public:
  explicit BagStreamWriter(const std::string& path);
  ~BagStreamWriter();
  BagStreamWriter(const BagStreamWriter&) = delete;
  BagStreamWriter& operator=(const BagStreamWriter&) = delete;

  template <class M>
  void write(const std::string& topic, const ros::Time& time, const M& message) {
    const std::uint32_t connection = connectionFor(topic, ros::message_traits::datatype(message),
                                                   ros::message_traits::md5sum(message),
                                                   ros::message_traits::definition(message));
    const std::uint32_t size = ros::serialization::serializationLength(message);
    std::uint8_t* data = beginMessage(connection, time, size);
    ros::serialization::OStream stream(data, size);
    ros::serialization::serialize(stream, message);
    endMessage();
  }

  /// Writes the last chunk and the index, and completes the header. Throws when the disk refused it.
  void close();

 private:
  struct Connection {
    std::string topic, datatype, md5sum, definition;
  };
  struct Record {
    std::vector<std::uint8_t> header, data;
  };
  struct IndexEntry {
    ros::Time time;
    std::uint32_t offset;  // of the message record within the chunk's data
  };
  struct ChunkInfo {
    std::uint64_t position;
    ros::Time start, end;
    std::map<std::uint32_t, std::uint32_t> counts;  // connection -> messages in the chunk
  };

  std::uint32_t connectionFor(const std::string& topic, const char* datatype, const char* md5sum,
                              const char* definition);
  std::uint8_t* beginMessage(std::uint32_t connection, const ros::Time& time, std::uint32_t size);
  void endMessage();
  void writeChunk();
  /// The connection's record, written into the chunk where it first appears and again into the index.
  Record connectionRecord(std::uint32_t id) const;
  void putBagHeader(std::uint64_t index_position);
  void put(const void* data, std::size_t size);
  void putRecord(const std::vector<std::uint8_t>& header, const void* data, std::size_t size);

  std::string path_;
  std::FILE* file_ = nullptr;
  std::vector<char> file_buffer_;
  std::vector<Connection> connections_;
  std::map<std::string, std::uint32_t> connection_of_topic_;
  std::vector<bool> recorded_in_file_;  // a connection record has been written into some chunk
  std::vector<std::uint8_t> chunk_;     // the open chunk's records
  std::map<std::uint32_t, std::vector<IndexEntry>> chunk_index_;
  ros::Time chunk_start_, chunk_end_;
  std::vector<ChunkInfo> chunks_;
  std::uint64_t position_ = 0;
  bool closed_ = false;
};

}  // namespace die_cushion_ident
