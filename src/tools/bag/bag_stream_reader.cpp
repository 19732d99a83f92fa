#include "bag/bag_stream_reader.h"

#include <bzlib.h>
#include <roslz4/lz4s.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string_view>

#include "bag/bag_record_format.h"
#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

using namespace bag_format;

BagStreamReader::BagStreamReader(const std::string& path) : path_(path), file_(path, std::ios::binary) {
  if (!file_) throw std::runtime_error("cannot open '" + path + "'");
  file_.seekg(0, std::ios::end);
  file_size_ = static_cast<std::uint64_t>(file_.tellg());
  file_.seekg(0);
  char magic[kMagicSize] = {};
  file_.read(magic, kMagicSize);
  if (!file_ || std::memcmp(magic, kMagic, kMagicSize) != 0) {
    throw std::runtime_error("'" + path +
                             "' is not a ROS bag (a version 2.0 bag begins with '#ROSBAG V2.0')");
  }
  position_ = kMagicSize;
}

double BagStreamReader::indexedSpan() const {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::ifstream file(path_, std::ios::binary);
  std::vector<std::uint8_t> buffer(4096 + 64);
  file.seekg(static_cast<std::streamoff>(kMagicSize));
  file.read(reinterpret_cast<char*>(buffer.data()), static_cast<std::streamsize>(buffer.size()));
  if (file.gcount() < 8) return kNaN;
  const std::uint32_t header_length = readU32(buffer.data());
  Fields header;
  if (header_length + 4u > static_cast<std::uint32_t>(file.gcount()) ||
      !parseFields(buffer.data() + 4, header_length, &header) || header["index_pos"].size() != 8) {
    return kNaN;
  }
  const std::uint64_t index = u64Field(header["index_pos"]);
  if (index == 0 || index >= file_size_) return kNaN;
  // The index: connection, index data and chunk info records to the end of the file.
  double first = kNaN, last = kNaN;
  forEachIndexRecord(path_, index, file_size_, false, [&](Fields& fields, const std::vector<std::uint8_t>&) {
    if (static_cast<std::uint8_t>(fields["op"][0]) != kOpChunkInfo) return;
    const std::string& start = fields["start_time"];
    const std::string& end = fields["end_time"];
    if (start.size() != 8 || end.size() != 8) return;
    const auto* s = reinterpret_cast<const std::uint8_t*>(start.data());
    const auto* e = reinterpret_cast<const std::uint8_t*>(end.data());
    const double t0 = readU32(s) + 1e-9 * readU32(s + 4), t1 = readU32(e) + 1e-9 * readU32(e + 4);
    first = std::isnan(first) ? t0 : std::min(first, t0);
    last = std::isnan(last) ? t1 : std::max(last, t1);
  });
  return last - first;
}

std::string BagStreamReader::atByte(std::uint64_t position) const {
  return formatted(FMT_STRING(" at byte {} of {}"), position, file_size_);
}

bool BagStreamReader::fail(const std::string& why) {
  error_ = why + atByte(position_);
  return false;
}

BagStreamReader::RecordRead BagStreamReader::readRecord(std::vector<std::uint8_t>* header,
                                                        std::vector<std::uint8_t>* data, bool* truncated,
                                                        std::string* what) {
  *truncated = false;
  std::uint8_t length[4];
  const auto remaining = [&] { return file_size_ - position_; };
  if (remaining() < 4) return RecordRead::kEnd;
  file_.read(reinterpret_cast<char*>(length), 4);
  const std::uint32_t header_length = readU32(length);
  if (header_length > kMaxRecord) {
    *what = "a record's header length is damaged";
    return RecordRead::kDamaged;
  }
  // A plausible record that runs past the end of the file is where the file was cut (unless a chunk
  // follows: then its length is damaged, which read() finds out).
  if (header_length > remaining() - 4 || remaining() - 4 - header_length < 4) return RecordRead::kCut;
  header->resize(header_length);
  file_.read(reinterpret_cast<char*>(header->data()), header_length);
  file_.read(reinterpret_cast<char*>(length), 4);
  const std::uint32_t data_length = readU32(length);
  if (data_length > kMaxRecord) {
    *what = "a record's data length is damaged";
    return RecordRead::kDamaged;
  }
  const std::uint64_t available = remaining() - 8 - header_length;
  const std::uint32_t wanted = static_cast<std::uint32_t>(std::min<std::uint64_t>(data_length, available));
  data->resize(wanted);
  file_.read(reinterpret_cast<char*>(data->data()), wanted);
  if (!file_) {
    *what = "the file could not be read";
    return RecordRead::kDamaged;
  }
  position_ += 8 + header_length + wanted;
  *truncated = wanted < data_length;
  return RecordRead::kRecord;
}

std::uint64_t BagStreamReader::findChunkHeader(std::uint64_t from) {
  constexpr std::size_t kBlock = 1 << 20, kBefore = 64, kOverlap = 8;
  std::ifstream file(path_, std::ios::binary);
  std::vector<char> block(kBlock + kBefore + kOverlap);
  for (std::uint64_t start = from; start < file_size_; start += kBlock) {
    const std::uint64_t first = start >= kBefore ? start - kBefore : 0;
    file.clear();
    file.seekg(static_cast<std::streamoff>(first));
    file.read(block.data(), static_cast<std::streamsize>(block.size()));
    const std::size_t got = static_cast<std::size_t>(file.gcount());
    const std::size_t found = findRecordHeader(
        reinterpret_cast<const std::uint8_t*>(block.data()), got, start - first,
        from > first ? from - first : 0, [](std::uint8_t op) { return op == kOpChunk; },
        [](std::size_t, std::uint32_t header_length, std::map<std::string, std::string>& fields) {
          return header_length <= 256 && fields["size"].size() == 4;
        });
    if (found < got) return first + found;
  }
  return 0;
}

std::size_t BagStreamReader::findRecordInChunk(const std::uint8_t* data, std::size_t size,
                                               std::size_t from) const {
  return findRecordHeader(
      data, size, from, from, [](std::uint8_t op) { return op == kOpMessageData || op == kOpConnection; },
      [&](std::size_t s, std::uint32_t header_length, const std::map<std::string, std::string>&) {
        // Its data too must lie within the chunk.
        if (size - s - 4 - header_length < 4) return false;
        return readU32(data + s + 4 + header_length) <= size - s - 8 - header_length;
      });
}

bool BagStreamReader::connectionFromIndex(std::uint32_t conn,
                                          const std::function<void(const Connection&)>& on_connection) {
  if (!index_connections_read_) {
    index_connections_read_ = true;
    if (index_position_ == 0 || index_position_ >= file_size_) return false;
    const auto keep = [&](Fields& fields, const std::vector<std::uint8_t>& data) {
      if (static_cast<std::uint8_t>(fields["op"][0]) != kOpConnection || fields["conn"].size() != 4) return;
      const std::uint32_t id = readU32(reinterpret_cast<const std::uint8_t*>(fields["conn"].data()));
      index_connections_[id] = {fields, std::string(data.begin(), data.end())};
    };
    forEachIndexRecord(path_, index_position_, file_size_, true, keep);
  }
  const auto copy = index_connections_.find(conn);
  if (copy == index_connections_.end()) return false;
  const std::string& data = copy->second.second;
  return addConnection(copy->second.first, reinterpret_cast<const std::uint8_t*>(data.data()), data.size(),
                       on_connection);
}

void BagStreamReader::chunkDamaged(std::uint64_t at, const std::string& what) {
  damaged_chunks_.insert(chunk_position_);
  damage_.push_back({at, what, true});
  chunk_damaged_ = true;
}

bool BagStreamReader::recover(std::uint64_t at, const std::string& what, std::uint64_t resume_from) {
  damage_.push_back({at, what, true});
  chunk_damaged_ = true;
  const std::uint64_t next = findChunkHeader(resume_from);
  if (next == 0) {
    position_ = file_size_;
    return false;
  }
  position_ = next;
  file_.clear();
  file_.seekg(static_cast<std::streamoff>(next));
  return true;
}

bool BagStreamReader::addConnection(const Fields& header, const std::uint8_t* data, std::size_t size,
                                    const std::function<void(const Connection&)>& on_connection) {
  const auto id = header.find("conn");
  const auto topic = header.find("topic");
  if (id == header.end() || id->second.size() != 4 || topic == header.end()) return false;
  const std::uint32_t conn = readU32(reinterpret_cast<const std::uint8_t*>(id->second.data()));
  const std::string bytes = topic->second + '\0' + std::string(reinterpret_cast<const char*>(data), size);
  const auto known = connection_bytes_.find(conn);
  if (known != connection_bytes_.end()) {
    // The index repeats every connection at the end: the same bytes, or one copy is damaged.
    return known->second == bytes;
  }
  Fields details;
  if (!parseFields(data, size, &details)) return false;
  connection_bytes_[conn] = bytes;
  Connection& c = connections_[conn];
  c.topic = topic->second;
  c.datatype = details["type"];
  c.md5sum = details["md5sum"];
  if (on_connection) on_connection(c);
  return true;
}

bool BagStreamReader::finishRead(bool truncated) {
  if (!damage_.empty()) {
    if (error_.empty()) error_ = damage_[0].what + atByte(damage_[0].position);
    return false;
  }
  // Cut off: inside a record, or short of the index the header promised (chunk info records missing), or
  // never closed.
  cut_off_ =
      cut_off_ || truncated || position_ < file_size_ || chunk_infos_ < chunk_count_ || open_chunk_seen_;
  if (!cut_off_) return true;
  if (open_chunk_seen_) {
    const std::string unclosed =
        "the recording was not closed (killed while recording: its last chunk still open, no index)";
    if (!open_chunk_compression_.empty()) {
      return fail(unclosed + "; that chunk is " + open_chunk_compression_ +
                  "-compressed and cannot be expanded without its end: its " +
                  std::to_string(file_size_ - position_) + " bytes are not read");
    }
    return fail(unclosed + (data_lost_ ? ", and the file ends inside the record"
                                       : ", and the file ends after a whole record"));
  }
  // Before the index (or with none: cut while recording) messages were lost; inside it, none were.
  data_lost_ = data_lost_ || index_position_ == 0 || position_ < index_position_;
  return fail(data_lost_ ? "the bag ends inside its messages (cut off while recording or copying)"
                         : "the bag ends inside its index (cut off after the last message)");
}

bool BagStreamReader::read(const std::function<void(const Message&)>& on_message,
                           const std::function<void(const Connection&)>& on_connection) {
  std::vector<std::uint8_t> header, data, chunk;
  bool truncated = false;
  for (;;) {
    const std::uint64_t record_start = position_;
    std::string what;
    const RecordRead result = readRecord(&header, &data, &truncated, &what);
    if (result == RecordRead::kEnd) {
      if (in_open_chunk_ && position_ < file_size_) openChunkCut(record_start);  // 1-3 bytes of a length
      break;
    }
    if (result == RecordRead::kCut) {
      // Where a chunk follows, the length was damaged, not the file cut.
      if (findChunkHeader(record_start + 1) != 0 &&
          recover(record_start, "a record's length is damaged", record_start + 1)) {
        continue;
      }
      cut_off_ = true;
      if (in_open_chunk_) openChunkCut(record_start);
      break;
    }
    if (result == RecordRead::kDamaged) {
      if (recover(record_start, what, record_start + 1)) continue;
      break;
    }
    Fields fields;
    if (!parseFields(header.data(), header.size(), &fields) || fields["op"].size() != 1) {
      if (recover(record_start, "a damaged record header", record_start + 1)) continue;
      break;
    }
    const auto op = static_cast<std::uint8_t>(fields["op"][0]);
    if (in_open_chunk_) {
      if (op == kOpMessageData || op == kOpConnection) {
        const Next next =
            readOpenChunkRecord(op, fields, data, record_start, truncated, on_message, on_connection);
        if (next == Next::kStop) break;
        continue;
      }
      in_open_chunk_ = false;  // a record no chunk holds: the open chunk ended before it
    }
    std::optional<Next> next = readOtherRecord(op, fields, data, record_start, truncated, on_connection);
    if (!next) {
      next =
          readChunk(fields, header.size(), data, chunk, record_start, truncated, on_message, on_connection);
    }
    if (*next == Next::kFailed) return false;
    if (*next == Next::kStop) break;
  }
  return finishRead(truncated);
}

}  // namespace die_cushion_ident
