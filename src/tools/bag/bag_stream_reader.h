#pragma once

#include <cstdint>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace die_cushion_ident {

/// Reads a ROS bag (format 2.0) from front to back, chunk by chunk, without loading its index:
/// - memory does not grow with the recording's length (rosbag::View keeps an index entry of about 64 bytes
///   per message in memory: 0.7 GB for an hour of three 1 kHz topics);
/// - every length is checked against what is there, so a damaged or cut-off part ends the reading with a
///   reason (error()) instead of a crash, and everything before it is delivered;
/// - a bag cut off while recording (no index) needs no repair: its chunks are read as they are;
/// - a recording killed before it was closed (`rosbag record`'s NAME.bag.active after SIGKILL) is read to
///   its last whole message: the records after the open chunk's header (size 0) are that chunk's messages.
/// Chunks may be uncompressed, bz2 or lz4. Messages come in the order they were recorded.
class BagStreamReader {
 public:
  struct Connection {
    std::string topic, datatype, md5sum;
  };
  struct Message {
    const Connection* connection = nullptr;
    double time = 0.0;  ///< [s] when it was recorded (not its header stamp)
    const std::uint8_t* data = nullptr;
    std::uint32_t size = 0;
  };

  /// Opens `path`; throws std::runtime_error saying why when it cannot be read or is no version 2.0 bag.
  explicit BagStreamReader(const std::string& path);

  /// Calls `on_message` for every message in file order, `on_connection` for every connection when first
  /// seen. Returns false when the reading ended early (error() says where and why).
  bool read(const std::function<void(const Message&)>& on_message,
            const std::function<void(const Connection&)>& on_connection = {});

  /// [s] the recording's span from the index at the end of the file (chunk start and end times), without
  /// reading the messages; NaN when the bag has no (readable) index. A hint for reserving memory.
  double indexedSpan() const;

  /// A part of the file that failed its checks: where it begins, and what was wrong.
  struct Damage {
    std::uint64_t position = 0;  ///< [byte]
    std::string what;
    bool in_messages = false;  ///< in a chunk or a record's length (messages after it lost), not in the index
  };
  /// Every damaged part found (the reading went on after each, at the next chunk that holds together);
  /// read() returns false when there is any. Messages of a damaged chunk before the damage are delivered,
  /// those after it are lost.
  const std::vector<Damage>& damage() const { return damage_; }
  /// Messages the index at the end lists but the chunks did not deliver (damaged or lost).
  std::uint64_t messagesMissing() const { return messages_missing_; }

  const std::string& error() const { return error_; }
  /// True when the bag ended inside a record (cut off while recording or copying); dataLost() when that
  /// record was a chunk (messages lost), not the index at the end.
  bool cutOff() const { return cut_off_; }
  bool dataLost() const { return data_lost_; }
  /// True when the last chunk was still open: its header says size 0 (rosbag fills the size in when it closes
  /// the chunk) and its records follow it to where the file ends; the recorder was killed before it could
  /// close the bag. cutOff() is then true as well; dataLost() where a record could not be read.
  bool unclosed() const { return open_chunk_seen_; }
  /// Message records (or parts of one) the file holds that could not be delivered: the record the end of
  /// the file cuts (a recording killed or cut off mid-record), a damaged one in an open chunk, one outside
  /// any chunk. Messages lost inside damaged closed chunks are counted by messagesMissing().
  std::uint64_t recordsUnreadable() const { return records_unreadable_; }
  std::uint64_t bytesRead() const { return position_; }
  std::uint64_t fileSize() const { return file_size_; }
  std::uint64_t messages() const { return messages_; }

 private:
  using Fields = std::map<std::string, std::string>;
  enum class RecordRead { kRecord, kEnd, kCut, kDamaged };
  // The next record; kDamaged with `what` set where a length cannot be right.
  RecordRead readRecord(std::vector<std::uint8_t>* header, std::vector<std::uint8_t>* data, bool* truncated,
                        std::string* what);
  // A chunk's records from `start` on; false at the first damaged one, with its offset in `data` and what
  // was wrong (`cut_off`: the chunk was cut while recording, its broken last record is the cut).
  bool parseRecords(const std::uint8_t* data, std::size_t size,
                    const std::function<void(const Message&)>& on_message,
                    const std::function<void(const Connection&)>& on_connection, std::size_t start,
                    bool cut_off, std::size_t* damaged_at, std::string* what);
  // The offset of the next message or connection record that holds together in a chunk's records, from
  // `from` on; `size` where there is none.
  std::size_t findRecordInChunk(const std::uint8_t* data, std::size_t size, std::size_t from) const;
  bool addConnection(const Fields& header, const std::uint8_t* data, std::size_t size,
                     const std::function<void(const Connection&)>& on_connection);
  bool fail(const std::string& why);
  using OnMessage = std::function<void(const Message&)>;
  using OnConnection = std::function<void(const Connection&)>;
  // What read() does after a record: go on, stop reading, or stop with fail() called.
  enum class Next { kRecord, kStop, kFailed };
  // A record that is not a chunk (file header, index, connection); nullopt for a chunk.
  std::optional<Next> readOtherRecord(std::uint8_t op, Fields& fields, const std::vector<std::uint8_t>& data,
                                      std::uint64_t record_start, bool truncated,
                                      const OnConnection& on_connection);
  // A chunk record: its messages, read as they come; `chunk` is the buffer a compressed one expands into.
  Next readChunk(Fields& fields, std::size_t header_size, std::vector<std::uint8_t>& data,
                 std::vector<std::uint8_t>& chunk, std::uint64_t record_start, bool truncated,
                 const OnMessage& on_message, const OnConnection& on_connection);
  // A record after the open chunk's header (a message or a connection): delivered as the chunk's.
  Next readOpenChunkRecord(std::uint8_t op, Fields& fields, const std::vector<std::uint8_t>& data,
                           std::uint64_t record_start, bool truncated, const OnMessage& on_message,
                           const OnConnection& on_connection);
  // The end of the file inside the open chunk's record at `record_start`: that record is not read.
  void openChunkCut(std::uint64_t record_start) {
    ++records_unreadable_;
    data_lost_ = cut_off_ = true;
    position_ = record_start;  // read up to the record, for the error's "at byte"
  }
  // A compressed chunk's records, expanded; false where they do not expand.
  Next readCompressedChunk(const std::string& compression, std::uint32_t size,
                           std::vector<std::uint8_t>& data, std::vector<std::uint8_t>& chunk,
                           std::uint64_t record_start, const OnMessage& on_message,
                           const OnConnection& on_connection);
  // The connection a message names; nullptr where neither its record nor the index's copy is known.
  const Connection* knownConnection(std::uint32_t id, const OnConnection& on_connection);
  // How read() ends: the damage found, or the file cut off.
  bool finishRead(bool truncated);
  std::string atByte(std::uint64_t position) const;  // " at byte N of SIZE"
  // Damage inside the chunk being read: noted, the chunk's index records then count what was lost.
  void chunkDamaged(std::uint64_t at, const std::string& what);
  // Damage at `at`: noted (the first also in error()); the reading resumes at the next chunk header found
  // from `resume_from` on. False when none is found (the rest of the file is lost).
  bool recover(std::uint64_t at, const std::string& what, std::uint64_t resume_from);
  std::uint64_t findChunkHeader(std::uint64_t from);
  // A connection whose record in the chunks was damaged, from its copy in the index at the end.
  bool connectionFromIndex(std::uint32_t conn, const std::function<void(const Connection&)>& on_connection);
  // The index records after each chunk and at the end, checked against what the chunks held.
  void checkIndexData(const Fields& header, const std::vector<std::uint8_t>& data, std::uint64_t at);
  void checkChunkInfo(const Fields& header, const std::vector<std::uint8_t>& data, std::uint64_t at);
  void checkConnectionCopy(std::uint32_t conn, const Fields& header, const std::uint8_t* data,
                           std::size_t size, std::uint64_t at);

  std::string path_;
  std::ifstream file_;
  std::uint64_t file_size_ = 0;
  std::uint64_t position_ = 0;
  std::uint64_t messages_ = 0;
  std::map<std::uint32_t, Connection> connections_;
  std::string error_;
  bool cut_off_ = false;
  bool data_lost_ = false;
  std::uint64_t index_position_ = 0;  // from the file header: where the index begins (0: none written)
  std::uint32_t chunk_count_ = 0, chunk_infos_ = 0;
  std::vector<Damage> damage_;
  std::uint64_t messages_missing_ = 0;
  std::uint64_t records_unreadable_ = 0;
  // The last chunk was still open (header size 0): its records are read as they come (in_open_chunk_) up
  // to the first record that cannot belong to a chunk; compressed, its bytes cannot be expanded.
  bool in_open_chunk_ = false, open_chunk_seen_ = false;
  std::string open_chunk_compression_;
  // Of the chunk being read (and after it, for its index records): where it began, and each message's
  // (connection, time in ns, offset in the chunk's records) in file order.
  struct IndexedMessage {
    std::uint32_t conn;
    std::uint64_t time;
    std::uint32_t offset;
  };
  std::uint64_t chunk_position_ = 0;
  std::vector<IndexedMessage> chunk_messages_;
  bool chunk_damaged_ = false;
  std::set<std::uint64_t> damaged_chunks_;
  bool index_connections_read_ = false;
  std::map<std::uint32_t, std::pair<Fields, std::string>> index_connections_;  // header fields, data
  // Per chunk read whole: its position and its messages per connection (for the chunk info records).
  std::map<std::uint64_t, std::map<std::uint32_t, std::uint32_t>> chunk_counts_;
  std::map<std::uint32_t, std::string>
      connection_bytes_;  // header topic + data of each connection's first copy
};

/// Bounds-checked decoding of the serialised messages analyze_bag reads; false for a damaged message (a
/// length that does not fit), never an exception or a huge allocation.
bool decodeFluidPressure(const std::uint8_t* data, std::uint32_t size, double* stamp, double* pressure);
/// sensor_msgs/Temperature: stamp and temperature [degC].
bool decodeTemperature(const std::uint8_t* data, std::uint32_t size, double* stamp, double* celsius);
bool decodeValveSignal(const std::uint8_t* data, std::uint32_t size, double* stamp, double* voltage,
                       double* spool);
/// JointState: stamp, names, positions and velocities (efforts skipped).
bool decodeJointState(const std::uint8_t* data, std::uint32_t size, double* stamp,
                      std::vector<std::string>* names, std::vector<double>* position,
                      std::vector<double>* velocity);

}  // namespace die_cushion_ident
