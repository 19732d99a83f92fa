#include "bag/bag_stream_writer.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "output/output_files.h"

namespace die_cushion_ident {

namespace {
// Record op codes and sizes of the bag format 2.0 (http://wiki.ros.org/Bags/Format/2.0).
constexpr std::uint8_t kMessageData = 0x02, kBagHeader = 0x03, kIndexData = 0x04, kChunk = 0x05,
                       kChunkInfo = 0x06, kConnection = 0x07;
constexpr std::size_t kBagHeaderLength = 4096;   // the bag header record is padded to this, as rosbag does
constexpr std::size_t kChunkThreshold = 768 * 1024;  // rosbag's default chunk size
const char kMagic[] = "#ROSBAG V2.0\n";

void appendBytes(std::vector<std::uint8_t>* out, const void* data, std::size_t size) {
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  out->insert(out->end(), bytes, bytes + size);
}
void appendUint32(std::vector<std::uint8_t>* out, std::uint32_t value) {
  std::uint8_t bytes[4];
  for (int i = 0; i < 4; ++i) bytes[i] = static_cast<std::uint8_t>(value >> (8 * i));
  appendBytes(out, bytes, 4);
}
void appendTime(std::vector<std::uint8_t>* out, const ros::Time& time) {
  appendUint32(out, time.sec);
  appendUint32(out, time.nsec);
}

// A record header: name=value fields, each with its length in front.
class Fields {
 public:
  Fields& add(const std::string& name, const void* value, std::size_t size) {
    appendUint32(&bytes_, static_cast<std::uint32_t>(name.size() + 1 + size));
    appendBytes(&bytes_, name.data(), name.size());
    bytes_.push_back('=');
    appendBytes(&bytes_, value, size);
    return *this;
  }
  Fields& op(std::uint8_t code) { return add("op", &code, 1); }
  Fields& text(const std::string& name, const std::string& value) { return add(name, value.data(), value.size()); }
  Fields& uint32(const std::string& name, std::uint32_t value) {
    std::vector<std::uint8_t> v;
    appendUint32(&v, value);
    return add(name, v.data(), v.size());
  }
  Fields& uint64(const std::string& name, std::uint64_t value) {
    std::vector<std::uint8_t> v;
    appendUint32(&v, static_cast<std::uint32_t>(value));
    appendUint32(&v, static_cast<std::uint32_t>(value >> 32));
    return add(name, v.data(), v.size());
  }
  Fields& time(const std::string& name, const ros::Time& value) {
    std::vector<std::uint8_t> v;
    appendTime(&v, value);
    return add(name, v.data(), v.size());
  }
  const std::vector<std::uint8_t>& bytes() const { return bytes_; }

 private:
  std::vector<std::uint8_t> bytes_;
};

// One record (lengths, header, data) appended to `out`: a chunk's records are gathered in memory.
void appendRecord(std::vector<std::uint8_t>* out, const std::vector<std::uint8_t>& header,
                  const std::vector<std::uint8_t>& data) {
  appendUint32(out, static_cast<std::uint32_t>(header.size()));
  appendBytes(out, header.data(), header.size());
  appendUint32(out, static_cast<std::uint32_t>(data.size()));
  appendBytes(out, data.data(), data.size());
}
}  // namespace

BagStreamWriter::Record BagStreamWriter::connectionRecord(std::uint32_t id) const {
  const Connection& c = connections_[id];
  return {Fields().op(kConnection).uint32("conn", id).text("topic", c.topic).bytes(),
          Fields()
              .text("topic", c.topic)
              .text("type", c.datatype)
              .text("md5sum", c.md5sum)
              .text("message_definition", c.definition)
              .bytes()};
}

void BagStreamWriter::putBagHeader(std::uint64_t index_position) {
  const std::vector<std::uint8_t> header = Fields()
                                               .op(kBagHeader)
                                               .uint64("index_pos", index_position)
                                               .uint32("conn_count", static_cast<std::uint32_t>(connections_.size()))
                                               .uint32("chunk_count", static_cast<std::uint32_t>(chunks_.size()))
                                               .bytes();
  // Padded to a fixed length, so that close() can write it again in place with the index's position.
  const std::vector<std::uint8_t> padding(kBagHeaderLength - header.size() - 8, ' ');
  putRecord(header, padding.data(), padding.size());
}

BagStreamWriter::BagStreamWriter(const std::string& path) : path_(path), file_buffer_(1 << 20) {
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) throw WriteError("cannot write " + path + ": " + std::strerror(errno));
  std::setvbuf(file_, file_buffer_.data(), _IOFBF, file_buffer_.size());
  chunk_.reserve(kChunkThreshold + 64 * 1024);
  put(kMagic, sizeof(kMagic) - 1);
  putBagHeader(0);  // written again at close() with the index's position
}

BagStreamWriter::~BagStreamWriter() {
  if (!closed_) {
    try {
      close();
    } catch (const std::exception&) {
      // Destructors must not throw; the caller who wanted to know has called close().
    }
  }
  if (file_) std::fclose(file_);
}

std::uint32_t BagStreamWriter::connectionFor(const std::string& topic, const char* datatype, const char* md5sum,
                                             const char* definition) {
  const auto known = connection_of_topic_.find(topic);
  if (known != connection_of_topic_.end()) return known->second;
  const auto id = static_cast<std::uint32_t>(connections_.size());
  connections_.push_back({topic, datatype, md5sum, definition});
  connection_of_topic_[topic] = id;
  recorded_in_file_.push_back(false);
  return id;
}

std::uint8_t* BagStreamWriter::beginMessage(std::uint32_t connection, const ros::Time& time, std::uint32_t size) {
  if (closed_) throw std::runtime_error("write to " + path_ + " after close()");
  if (!recorded_in_file_[connection]) {
    // The connection record goes into the chunk where the connection first appears (as rosbag does), and
    // again into the index at the end.
    const Record record = connectionRecord(connection);
    appendRecord(&chunk_, record.header, record.data);
    recorded_in_file_[connection] = true;
  }
  if (chunk_index_.empty()) {
    chunk_start_ = time;
    chunk_end_ = time;
  }
  chunk_start_ = std::min(chunk_start_, time);
  chunk_end_ = std::max(chunk_end_, time);
  chunk_index_[connection].push_back({time, static_cast<std::uint32_t>(chunk_.size())});
  const std::vector<std::uint8_t> header =
      Fields().op(kMessageData).uint32("conn", connection).time("time", time).bytes();
  appendUint32(&chunk_, static_cast<std::uint32_t>(header.size()));
  appendBytes(&chunk_, header.data(), header.size());
  appendUint32(&chunk_, size);
  const std::size_t at = chunk_.size();
  chunk_.resize(at + size);
  return chunk_.data() + at;  // serialised in place
}

void BagStreamWriter::endMessage() {
  if (chunk_.size() >= kChunkThreshold) writeChunk();
}

void BagStreamWriter::writeChunk() {
  if (chunk_.empty()) return;
  ChunkInfo info;
  info.position = position_;
  info.start = chunk_start_;
  info.end = chunk_end_;
  const std::vector<std::uint8_t> header = Fields()
                                               .op(kChunk)
                                               .text("compression", "none")
                                               .uint32("size", static_cast<std::uint32_t>(chunk_.size()))
                                               .bytes();
  putRecord(header, chunk_.data(), chunk_.size());
  for (auto& [connection, entries] : chunk_index_) {
    // Readers merge the connections' indexes assuming each is in time order; messages may come a little
    // out of it (a topic stamped late).
    std::stable_sort(entries.begin(), entries.end(),
                     [](const IndexEntry& a, const IndexEntry& b) { return a.time < b.time; });
    std::vector<std::uint8_t> data;
    data.reserve(entries.size() * 12);
    for (const IndexEntry& e : entries) {
      appendTime(&data, e.time);
      appendUint32(&data, e.offset);
    }
    const std::vector<std::uint8_t> index_header = Fields()
                                                       .op(kIndexData)
                                                       .uint32("ver", 1)
                                                       .uint32("conn", connection)
                                                       .uint32("count", static_cast<std::uint32_t>(entries.size()))
                                                       .bytes();
    putRecord(index_header, data.data(), data.size());
    info.counts[connection] = static_cast<std::uint32_t>(entries.size());
  }
  chunks_.push_back(std::move(info));
  chunk_.clear();
  chunk_index_.clear();
}

void BagStreamWriter::close() {
  if (closed_) return;
  closed_ = true;
  writeChunk();
  const std::uint64_t index_position = position_;
  for (std::uint32_t id = 0; id < connections_.size(); ++id) {
    const Record record = connectionRecord(id);
    putRecord(record.header, record.data.data(), record.data.size());
  }
  for (const ChunkInfo& chunk : chunks_) {
    std::vector<std::uint8_t> data;
    for (const auto& [connection, count] : chunk.counts) {
      appendUint32(&data, connection);
      appendUint32(&data, count);
    }
    const std::vector<std::uint8_t> header = Fields()
                                                 .op(kChunkInfo)
                                                 .uint32("ver", 1)
                                                 .uint64("chunk_pos", chunk.position)
                                                 .time("start_time", chunk.start)
                                                 .time("end_time", chunk.end)
                                                 .uint32("count", static_cast<std::uint32_t>(chunk.counts.size()))
                                                 .bytes();
    putRecord(header, data.data(), data.size());
  }
  // The header again, now with the index's position, over the placeholder.
  if (std::fseek(file_, static_cast<long>(sizeof(kMagic) - 1), SEEK_SET) != 0) {
    throw WriteError("cannot write " + path_ + " (completing it): " + std::strerror(errno));
  }
  putBagHeader(index_position);
  const bool written = std::fflush(file_) == 0 && !std::ferror(file_);
  const int error = errno;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!written || !closed)
    throw WriteError("cannot write " + path_ + ": " + std::strerror(written ? errno : error));
}

void BagStreamWriter::put(const void* data, std::size_t size) {
  if (size > 0 && std::fwrite(data, 1, size, file_) != size) {
    throw WriteError("cannot write " + path_ + ": " + std::strerror(errno));
  }
  position_ += size;
}

void BagStreamWriter::putRecord(const std::vector<std::uint8_t>& header, const void* data, std::size_t size) {
  std::vector<std::uint8_t> lengths;
  appendUint32(&lengths, static_cast<std::uint32_t>(header.size()));
  put(lengths.data(), 4);
  put(header.data(), header.size());
  lengths.clear();
  appendUint32(&lengths, static_cast<std::uint32_t>(size));
  put(lengths.data(), 4);
  put(data, size);
}

}  // namespace die_cushion_ident
