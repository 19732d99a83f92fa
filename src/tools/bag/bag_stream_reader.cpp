#include "bag/bag_stream_reader.h"

#include <bzlib.h>
#include <roslz4/lz4s.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string_view>

namespace die_cushion_ident {

namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr std::size_t kMagicSize = sizeof(kMagic) - 1;
// Far beyond any real record (rosbag's chunks are 768 kB by default): a larger length is damage.
constexpr std::uint32_t kMaxRecord = 512u << 20;
constexpr std::uint8_t kOpMessageData = 0x02, kOpFileHeader = 0x03, kOpIndexData = 0x04, kOpChunk = 0x05,
                       kOpChunkInfo = 0x06, kOpConnection = 0x07;

std::uint32_t readU32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

// A little-endian 8-byte field (index_pos, chunk_pos).
std::uint64_t u64Field(const std::string& value) {
  const auto* b = reinterpret_cast<const std::uint8_t*>(value.data());
  return readU32(b) | static_cast<std::uint64_t>(readU32(b + 4)) << 32;
}

// Calls field(name, value) for each "len name=value" field of a record header (or of a connection's data),
// the views pointing into `data`; false when the fields do not fit or field() returns false.
template <typename Field>
bool forEachField(const std::uint8_t* data, std::size_t size, const Field& field) {
  std::size_t at = 0;
  while (at < size) {
    if (size - at < 4) return false;
    const std::uint32_t length = readU32(data + at);
    at += 4;
    if (length > size - at) return false;
    const char* text = reinterpret_cast<const char*>(data + at);
    const void* equals = std::memchr(text, '=', length);
    if (!equals) return false;
    const std::size_t name_length = static_cast<const char*>(equals) - text;
    if (!field(std::string_view(text, name_length),
               std::string_view(text + name_length + 1, length - name_length - 1)))
      return false;
    at += length;
  }
  return true;
}

bool parseFields(const std::uint8_t* data, std::size_t size, std::map<std::string, std::string>* fields) {
  return forEachField(data, size, [&](std::string_view name, std::string_view value) {
    (*fields)[std::string(name)] = std::string(value);
    return true;
  });
}

// The start of the first record header in bytes[lowest, size) whose "op=" field (4 bytes, its length 4 before
// it), searched from `search_from` on, holds an op that wanted(op) accepts, whose fields parse, and which
// accept(start, header_length, fields) admits; `size` where there is none. The header begins a few fields
// before its op (rosbag writes the fields in name order: compression, op, size; conn, op, time).
template <typename Wanted, typename Accept>
std::size_t findRecordHeader(const std::uint8_t* bytes, std::size_t size, std::size_t search_from,
                             std::size_t lowest, const Wanted& wanted, const Accept& accept) {
  constexpr std::size_t kBefore = 64;
  static const std::string kOp("\x04\x00\x00\x00op=", 7);
  const std::string_view view(reinterpret_cast<const char*>(bytes), size);
  for (std::size_t q = view.find(kOp, search_from); q != std::string_view::npos; q = view.find(kOp, q + 1)) {
    if (q + 8 > size || !wanted(bytes[q + 7])) continue;
    for (std::size_t back = 4; back <= std::min(q, kBefore); ++back) {
      const std::size_t s = q - back;
      if (s < lowest) continue;
      const std::uint32_t header_length = readU32(bytes + s);
      if (header_length < back || header_length > size - s - 4) continue;
      std::map<std::string, std::string> fields;
      if (parseFields(bytes + s + 4, header_length, &fields) && fields["op"].size() == 1 &&
          static_cast<std::uint8_t>(fields["op"][0]) == bytes[q + 7] && accept(s, header_length, fields)) {
        return s;
      }
    }
  }
  return size;
}

// Calls record(fields, data) for every record of the index, from `index` [byte] to the end of the file (a
// damaged length ends the walk); `with_data` false leaves data empty (skipped, not read).
template <typename Record>
void forEachIndexRecord(const std::string& path, std::uint64_t index, std::uint64_t file_size, bool with_data,
                        const Record& record) {
  std::ifstream file(path, std::ios::binary);
  file.seekg(static_cast<std::streamoff>(index));
  std::uint64_t at = index;
  std::vector<std::uint8_t> header, data;
  while (at + 8 <= file_size) {
    std::uint8_t length[4];
    file.read(reinterpret_cast<char*>(length), 4);
    const std::uint32_t h = readU32(length);
    if (!file || h > kMaxRecord || at + 8 + h > file_size) break;
    header.resize(h);
    file.read(reinterpret_cast<char*>(header.data()), h);
    file.read(reinterpret_cast<char*>(length), 4);
    const std::uint32_t d = readU32(length);
    if (!file || d > kMaxRecord || at + 8 + h + d > file_size) break;
    if (with_data) {
      data.resize(d);
      file.read(reinterpret_cast<char*>(data.data()), d);
    } else {
      file.seekg(d, std::ios::cur);
    }
    at += 8 + h + d;
    std::map<std::string, std::string> fields;
    if (parseFields(header.data(), h, &fields) && fields["op"].size() == 1) record(fields, data);
  }
}

// The same fields without copying them into a map: a message record's header (op, conn, time) is parsed
// ten million times an hour, and the map's allocations were a tenth of the reading.
struct FieldViews {
  static constexpr int kMax = 8;
  std::string_view names[kMax], values[kMax];
  int count = 0;
  std::string_view operator[](std::string_view name) const {
    for (int i = 0; i < count; ++i) {
      if (names[i] == name) return values[i];
    }
    return {};
  }
};

// False when the fields do not fit, or there are more than a message record has any need for.
bool parseFieldViews(const std::uint8_t* data, std::size_t size, FieldViews* fields) {
  fields->count = 0;
  return forEachField(data, size, [&](std::string_view name, std::string_view value) {
    if (fields->count == FieldViews::kMax) return false;
    fields->names[fields->count] = name;
    fields->values[fields->count] = value;
    ++fields->count;
    return true;
  });
}

// Little-endian fields of a serialised message, every read checked against its size.
class Cursor {
 public:
  Cursor(const std::uint8_t* data, std::uint32_t size) : data_(data), size_(size) {}
  bool u32(std::uint32_t* v) {
    if (size_ - at_ < 4) return false;
    *v = readU32(data_ + at_);
    at_ += 4;
    return true;
  }
  bool f64(double* v) {
    if (size_ - at_ < 8) return false;
    std::memcpy(v, data_ + at_, 8);
    at_ += 8;
    return true;
  }
  bool text(std::string* s) {
    std::uint32_t length = 0;
    if (!u32(&length) || length > size_ - at_) return false;
    if (s) s->assign(reinterpret_cast<const char*>(data_ + at_), length);
    at_ += length;
    return true;
  }
  bool doubles(std::vector<double>* v) {
    std::uint32_t count = 0;
    if (!u32(&count) || count > (size_ - at_) / 8) return false;
    v->resize(count);
    if (count > 0) std::memcpy(v->data(), data_ + at_, 8 * static_cast<std::size_t>(count));
    at_ += 8 * count;
    return true;
  }
  // std_msgs/Header: seq, stamp (sec, nsec), frame_id.
  bool header(double* stamp) {
    std::uint32_t seq = 0, sec = 0, nsec = 0;
    if (!u32(&seq) || !u32(&sec) || !u32(&nsec) || !text(nullptr)) return false;
    *stamp = sec + 1e-9 * nsec;
    return true;
  }

 private:
  const std::uint8_t* data_;
  std::uint32_t size_;
  std::uint32_t at_ = 0;
};

}  // namespace

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
  char where[64];
  std::snprintf(where, sizeof(where), " at byte %llu of %llu", static_cast<unsigned long long>(position),
                static_cast<unsigned long long>(file_size_));
  return where;
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

namespace {

// The record at `at` in a chunk's records: its header and data, `at` moved past it; the damage where it
// does not hold together, nullptr where it does.
const char* nextRecordInChunk(const std::uint8_t* data, std::size_t size, std::size_t* at,
                              const std::uint8_t** header, std::uint32_t* header_length,
                              const std::uint8_t** body, std::uint32_t* data_length) {
  if (size - *at < 4) return "a chunk ends inside a record";
  *header_length = readU32(data + *at);
  if (*header_length > size - *at - 4) return "a record inside a chunk runs past the chunk";
  *header = data + *at + 4;
  *at += 4 + *header_length;
  if (size - *at < 4) return "a chunk ends inside a record";
  *data_length = readU32(data + *at);
  if (*data_length > size - *at - 4) return "a record inside a chunk runs past the chunk";
  *body = data + *at + 4;
  *at += 4 + *data_length;
  return nullptr;
}

// A chunk record's op from its header's views, or (a header with more fields than a message record's)
// from the header parsed in full, as the other records are; -1 where it has none.
int recordOp(const std::uint8_t* header, std::uint32_t header_length, bool parsed, FieldViews& views,
             std::map<std::string, std::string>* fields) {
  if (parsed && views["op"].size() == 1) return static_cast<std::uint8_t>(views["op"][0]);
  if (!parsed && parseFields(header, header_length, fields) && (*fields)["op"].size() == 1) {
    return static_cast<std::uint8_t>((*fields)["op"][0]);
  }
  return -1;
}

}  // namespace

const BagStreamReader::Connection* BagStreamReader::knownConnection(std::uint32_t id,
                                                                    const OnConnection& on_connection) {
  auto c = connections_.find(id);
  // Its connection record damaged (in the first chunk): the copy in the index at the end stands in.
  if (c == connections_.end() && connectionFromIndex(id, on_connection)) c = connections_.find(id);
  return c == connections_.end() ? nullptr : &c->second;
}

bool BagStreamReader::parseRecords(const std::uint8_t* data, std::size_t size, const OnMessage& on_message,
                                   const OnConnection& on_connection, std::size_t start, bool cut_off,
                                   std::size_t* damaged_at, std::string* what) {
  std::size_t at = start;
  // A message is delivered once the record after it holds together: damage that begins in a message's
  // bytes shows only where it reaches the next record's header, and that message is then dropped with it.
  Message pending;
  IndexedMessage pending_index{};
  const auto deliver = [&] {
    if (!pending.connection) return;
    ++messages_;
    chunk_messages_.push_back(pending_index);
    on_message(pending);
    pending.connection = nullptr;
  };
  const auto damaged = [&](std::size_t record, const char* why) {
    if (cut_off) deliver();  // the broken record is the cut, not damage: the one before it is whole
    *damaged_at = record;
    *what = why;
    return false;
  };
  while (at < size) {
    const std::size_t record = at;
    const std::uint8_t *header = nullptr, *body = nullptr;
    std::uint32_t header_length = 0, data_length = 0;
    const char* broken = nextRecordInChunk(data, size, &at, &header, &header_length, &body, &data_length);
    if (broken) return damaged(record, broken);
    FieldViews views;
    const bool parsed = parseFieldViews(header, header_length, &views);
    Fields fields;
    const int op = recordOp(header, header_length, parsed, views, &fields);
    if (op < 0) return damaged(record, "a damaged record header inside a chunk");
    if (op == kOpConnection) {
      deliver();
      if (fields.empty()) parseFields(header, header_length, &fields);
      if (!addConnection(fields, body, data_length, on_connection))
        return damaged(record, "a damaged connection record");
    } else if (op == kOpMessageData) {
      const std::string_view conn = views["conn"], time = views["time"];
      if (!parsed || conn.size() != 4 || time.size() != 8) return damaged(record, "a damaged message record");
      const std::uint32_t id = readU32(reinterpret_cast<const std::uint8_t*>(conn.data()));
      const Connection* connection = knownConnection(id, on_connection);
      if (!connection) return damaged(record, "a message of an unknown connection");
      const auto* t = reinterpret_cast<const std::uint8_t*>(time.data());
      deliver();
      pending.connection = connection;
      pending.time = readU32(t) + 1e-9 * readU32(t + 4);
      pending.data = body;
      pending.size = data_length;
      pending_index = {id, static_cast<std::uint64_t>(readU32(t)) * 1000000000ull + readU32(t + 4),
                       static_cast<std::uint32_t>(record)};
    } else {
      // A chunk holds messages and connections only: another record here is damage (or a length that
      // ran into the records after the chunk).
      return damaged(record, "a record that does not belong inside a chunk");
    }
  }
  deliver();
  return true;
}

void BagStreamReader::checkIndexData(const Fields& header, const std::vector<std::uint8_t>& data,
                                     std::uint64_t at) {
  const auto conn = header.find("conn");
  const auto count = header.find("count");
  if (conn == header.end() || count == header.end() || conn->second.size() != 4 ||
      count->second.size() != 4) {
    damage_.push_back({at, "a damaged index record after a chunk"});
    damaged_chunks_.insert(chunk_position_);
    return;
  }
  const std::uint32_t id = readU32(reinterpret_cast<const std::uint8_t*>(conn->second.data()));
  const std::uint32_t entries = readU32(reinterpret_cast<const std::uint8_t*>(count->second.data()));
  if (static_cast<std::uint64_t>(entries) * 12 != data.size()) {
    damage_.push_back({at, "a damaged index record after a chunk (its count does not match its entries)"});
    damaged_chunks_.insert(chunk_position_);
    return;
  }
  for (std::uint32_t e = 0; e < entries; ++e) {
    const std::uint8_t* entry = data.data() + 12 * static_cast<std::size_t>(e);
    const std::uint64_t time =
        static_cast<std::uint64_t>(readU32(entry)) * 1000000000ull + readU32(entry + 4);
    const std::uint32_t offset = readU32(entry + 8);
    const auto found =
        std::lower_bound(chunk_messages_.begin(), chunk_messages_.end(), offset,
                         [](const IndexedMessage& m, std::uint32_t o) { return m.offset < o; });
    const bool delivered = found != chunk_messages_.end() && found->offset == offset;
    if (chunk_damaged_) {
      // Its messages after the damage were lost: counted, the damage itself is already reported.
      if (!delivered) ++messages_missing_;
      continue;
    }
    if (!delivered || found->conn != id || found->time != time) {
      damage_.push_back({at, "an index record after a chunk disagrees with the chunk's messages"});
      damaged_chunks_.insert(chunk_position_);
      return;
    }
  }
  chunk_counts_[chunk_position_][id] += entries;
}

void BagStreamReader::checkChunkInfo(const Fields& header, const std::vector<std::uint8_t>& data,
                                     std::uint64_t at) {
  const auto position = header.find("chunk_pos");
  const auto count = header.find("count");
  if (position == header.end() || count == header.end() || position->second.size() != 8 ||
      count->second.size() != 4) {
    damage_.push_back({at, "a damaged chunk info record in the index"});
    return;
  }
  const std::uint64_t chunk = u64Field(position->second);
  const std::uint32_t connections = readU32(reinterpret_cast<const std::uint8_t*>(count->second.data()));
  if (static_cast<std::uint64_t>(connections) * 8 != data.size()) {
    damage_.push_back(
        {at, "a damaged chunk info record in the index (its count does not match its entries)"});
    return;
  }
  if (damaged_chunks_.count(chunk)) return;  // reported where it was found
  const auto counted = chunk_counts_.find(chunk);
  if (counted == chunk_counts_.end()) {
    damage_.push_back(
        {at, "the index lists a chunk that is not where it says (damage in the index or the chunks)"});
    return;
  }
  for (std::uint32_t c = 0; c < connections; ++c) {
    const std::uint32_t id = readU32(data.data() + 8 * c), messages = readU32(data.data() + 8 * c + 4);
    const auto found = counted->second.find(id);
    if (found == counted->second.end() || found->second != messages) {
      damage_.push_back({at, "a chunk info record disagrees with its chunk's messages"});
      return;
    }
  }
}

std::optional<BagStreamReader::Next> BagStreamReader::readOtherRecord(std::uint8_t op, Fields& fields,
                                                                      const std::vector<std::uint8_t>& data,
                                                                      std::uint64_t record_start,
                                                                      bool truncated,
                                                                      const OnConnection& on_connection) {
  if (op == kOpFileHeader) {
    const std::string& index = fields["index_pos"];
    const std::string& chunks = fields["chunk_count"];
    if (index.size() == 8) index_position_ = u64Field(index);
    if (chunks.size() == 4) chunk_count_ = readU32(reinterpret_cast<const std::uint8_t*>(chunks.data()));
    // rosbag pads the file header to 4 kB with spaces: anything else there is damage.
    if (std::any_of(data.begin(), data.end(), [](std::uint8_t b) { return b != ' '; })) {
      damage_.push_back({record_start, "the file header's padding is damaged"});
    }
    return Next::kRecord;
  }
  if (op == kOpChunkInfo) {
    ++chunk_infos_;
    if (!truncated) checkChunkInfo(fields, data, record_start);
    return Next::kRecord;
  }
  if (op == kOpIndexData) {
    if (!truncated) checkIndexData(fields, data, record_start);
    return Next::kRecord;
  }
  if (op != kOpChunk && truncated)
    return Next::kStop;  // the index at the end, cut short: every message was read
  if (op == kOpConnection) {
    if (!addConnection(fields, data.data(), data.size(), on_connection)) {
      damage_.push_back({record_start, "a damaged connection record (its copies differ)"});
    }
    return Next::kRecord;
  }
  if (op == kOpMessageData) {
    // Outside any chunk (and not after an open chunk's header): damage, and a message not delivered.
    damage_.push_back({record_start, "a message record outside any chunk", true});
    ++records_unreadable_;
    return Next::kRecord;
  }
  if (op != kOpChunk) {
    damage_.push_back({record_start, "a record of an unknown kind"});
    return Next::kRecord;
  }
  return std::nullopt;
}

BagStreamReader::Next BagStreamReader::readOpenChunkRecord(std::uint8_t op, Fields& fields,
                                                           const std::vector<std::uint8_t>& data,
                                                           std::uint64_t record_start, bool truncated,
                                                           const OnMessage& on_message,
                                                           const OnConnection& on_connection) {
  if (truncated) {  // the record the end of the file cuts: where the recorder's last write ended
    openChunkCut(record_start);
    return Next::kStop;
  }
  if (op == kOpConnection) {
    if (!addConnection(fields, data.data(), data.size(), on_connection)) {
      chunkDamaged(record_start, "a damaged connection record (in the open chunk)");
    }
    return Next::kRecord;
  }
  const std::string& conn = fields["conn"];
  const std::string& time = fields["time"];
  const Connection* connection =
      conn.size() == 4 && time.size() == 8
          ? knownConnection(readU32(reinterpret_cast<const std::uint8_t*>(conn.data())), on_connection)
          : nullptr;
  if (!connection) {
    chunkDamaged(record_start, conn.size() == 4 && time.size() == 8
                                   ? "a message of an unknown connection (in the open chunk)"
                                   : "a damaged message record (in the open chunk)");
    ++records_unreadable_;
    return Next::kRecord;
  }
  const auto* t = reinterpret_cast<const std::uint8_t*>(time.data());
  Message message;
  message.connection = connection;
  message.time = readU32(t) + 1e-9 * readU32(t + 4);
  message.data = data.data();
  message.size = static_cast<std::uint32_t>(data.size());
  ++messages_;
  on_message(message);
  return Next::kRecord;
}

BagStreamReader::Next BagStreamReader::readCompressedChunk(const std::string& compression, std::uint32_t size,
                                                           std::vector<std::uint8_t>& data,
                                                           std::vector<std::uint8_t>& chunk,
                                                           std::uint64_t record_start,
                                                           const OnMessage& on_message,
                                                           const OnConnection& on_connection) {
  chunk.resize(size);
  unsigned int produced = size;
  int status = -1;
  if (compression == "bz2") {
    status = BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(chunk.data()), &produced,
                                        reinterpret_cast<char*>(data.data()),
                                        static_cast<unsigned int>(data.size()), 0, 0) == BZ_OK
                 ? 0
                 : -1;
  } else if (compression == "lz4") {
    status = roslz4_buffToBuffDecompress(reinterpret_cast<char*>(data.data()),
                                         static_cast<unsigned int>(data.size()),
                                         reinterpret_cast<char*>(chunk.data()), &produced) == ROSLZ4_OK
                 ? 0
                 : -1;
  } else {
    fail("a chunk compressed with '" + compression + "', which this reader does not know");
    return Next::kFailed;
  }
  if (status != 0 || produced != size) {
    chunkDamaged(record_start, "a " + compression + " chunk that does not expand");
    return Next::kRecord;
  }
  std::size_t damaged_at = 0;
  std::string what;
  if (!parseRecords(chunk.data(), chunk.size(), on_message, on_connection, 0, false, &damaged_at, &what)) {
    chunkDamaged(record_start, what + " (in a " + compression + " chunk)");
  }
  return Next::kRecord;
}

BagStreamReader::Next BagStreamReader::readChunk(Fields& fields, std::size_t header_size,
                                                 std::vector<std::uint8_t>& data,
                                                 std::vector<std::uint8_t>& chunk, std::uint64_t record_start,
                                                 bool truncated, const OnMessage& on_message,
                                                 const OnConnection& on_connection) {
  data_lost_ = truncated;
  chunk_position_ = record_start;
  chunk_messages_.clear();
  chunk_damaged_ = false;
  const std::uint64_t chunk_data = record_start + 8 + header_size;
  const std::string compression = fields["compression"];
  const std::string& size_field = fields["size"];
  const std::uint32_t size =
      size_field.size() == 4 ? readU32(reinterpret_cast<const std::uint8_t*>(size_field.data())) : 0;
  if (size_field.size() == 4 && size == 0 && data.empty() && !truncated) {
    // rosbag writes a chunk's header with size 0 when it opens the chunk, writes the records after it as
    // they come and fills the size in when it closes the chunk: this one was still open when the recorder
    // was killed. Uncompressed, its records are read one by one as they follow; compressed, they are one
    // stream that cannot be expanded without its end.
    open_chunk_seen_ = true;
    if (compression == "none") {
      in_open_chunk_ = true;
      return Next::kRecord;
    }
    open_chunk_compression_ = compression;
    data_lost_ = cut_off_ = true;
    return Next::kStop;
  }
  if (size_field.size() != 4 || size > kMaxRecord ||
      (compression == "none" && !truncated && size != data.size())) {
    damaged_chunks_.insert(record_start);
    return recover(record_start, "a damaged chunk header", record_start + 1) ? Next::kRecord : Next::kStop;
  }
  if (compression != "none") {
    if (truncated) return Next::kStop;  // a compressed chunk cut short cannot be expanded
    return readCompressedChunk(compression, size, data, chunk, record_start, on_message, on_connection);
  }
  // A chunk cut off while recording: its complete records are still good, the broken last one is the cut.
  // After damage inside the chunk, the reading resumes at the next record that holds together in it;
  // the chunk's own length holds (its size agrees), so the records after the chunk are read as they
  // come, and its index records count what was lost.
  std::size_t damaged_at = 0;
  std::string what;
  for (std::size_t start = 0; start < data.size();) {
    if (parseRecords(data.data(), data.size(), on_message, on_connection, start, truncated, &damaged_at,
                     &what))
      break;
    if (truncated) {  // the chunk cut off while recording: its last record is the cut, not read
      ++records_unreadable_;
      break;
    }
    chunkDamaged(chunk_data + damaged_at, what);
    start = findRecordInChunk(data.data(), data.size(), damaged_at + 1);
  }
  return truncated ? Next::kStop : Next::kRecord;
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

bool decodeFluidPressure(const std::uint8_t* data, std::uint32_t size, double* stamp, double* pressure) {
  Cursor c(data, size);
  double variance = 0.0;
  return c.header(stamp) && c.f64(pressure) && c.f64(&variance);
}

bool decodeTemperature(const std::uint8_t* data, std::uint32_t size, double* stamp, double* celsius) {
  Cursor c(data, size);
  double variance = 0.0;
  return c.header(stamp) && c.f64(celsius) && c.f64(&variance);
}

bool decodeValveSignal(const std::uint8_t* data, std::uint32_t size, double* stamp, double* voltage,
                       double* spool) {
  Cursor c(data, size);
  return c.header(stamp) && c.f64(voltage) && c.f64(spool);
}

bool decodeJointState(const std::uint8_t* data, std::uint32_t size, double* stamp,
                      std::vector<std::string>* names, std::vector<double>* position,
                      std::vector<double>* velocity) {
  Cursor c(data, size);
  std::uint32_t count = 0;
  if (!c.header(stamp) || !c.u32(&count) || count > size / 4) return false;
  names->resize(count);
  for (auto& name : *names) {
    if (!c.text(&name)) return false;
  }
  return c.doubles(position) && c.doubles(velocity);
}

}  // namespace die_cushion_ident
