#include "bag_stream_reader.h"

#include <bzlib.h>
#include <roslz4/lz4s.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string_view>
#include <limits>
#include <stdexcept>

namespace die_cushion_ident {

namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr std::size_t kMagicSize = sizeof(kMagic) - 1;
// Far beyond any real record (rosbag's chunks are 768 kB by default): a larger length is damage.
constexpr std::uint32_t kMaxRecord = 512u << 20;
constexpr std::uint8_t kOpMessageData = 0x02, kOpFileHeader = 0x03, kOpChunk = 0x05, kOpChunkInfo = 0x06,
                        kOpConnection = 0x07;

std::uint32_t readU32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
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
    if (!field(std::string_view(text, name_length), std::string_view(text + name_length + 1, length - name_length - 1)))
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
    throw std::runtime_error("'" + path + "' is not a ROS bag (a version 2.0 bag begins with '#ROSBAG V2.0')");
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
  const auto* b = reinterpret_cast<const std::uint8_t*>(header["index_pos"].data());
  const std::uint64_t index = readU32(b) | static_cast<std::uint64_t>(readU32(b + 4)) << 32;
  if (index == 0 || index >= file_size_) return kNaN;
  // The index: connection, index data and chunk info records to the end of the file.
  file.clear();
  file.seekg(static_cast<std::streamoff>(index));
  double first = kNaN, last = kNaN;
  std::uint64_t at = index;
  std::vector<std::uint8_t> record;
  while (at + 8 <= file_size_) {
    std::uint8_t length[4];
    file.read(reinterpret_cast<char*>(length), 4);
    const std::uint32_t h = readU32(length);
    if (!file || h > kMaxRecord || at + 8 + h > file_size_) break;
    record.resize(h);
    file.read(reinterpret_cast<char*>(record.data()), h);
    file.read(reinterpret_cast<char*>(length), 4);
    const std::uint32_t d = readU32(length);
    if (!file || d > kMaxRecord || at + 8 + h + d > file_size_) break;
    file.seekg(d, std::ios::cur);
    at += 8 + h + d;
    Fields fields;
    if (!parseFields(record.data(), h, &fields) || fields["op"].size() != 1 ||
        static_cast<std::uint8_t>(fields["op"][0]) != kOpChunkInfo) {
      continue;
    }
    const std::string& start = fields["start_time"];
    const std::string& end = fields["end_time"];
    if (start.size() != 8 || end.size() != 8) continue;
    const auto* s = reinterpret_cast<const std::uint8_t*>(start.data());
    const auto* e = reinterpret_cast<const std::uint8_t*>(end.data());
    const double t0 = readU32(s) + 1e-9 * readU32(s + 4), t1 = readU32(e) + 1e-9 * readU32(e + 4);
    first = std::isnan(first) ? t0 : std::min(first, t0);
    last = std::isnan(last) ? t1 : std::max(last, t1);
  }
  return last - first;
}

bool BagStreamReader::fail(const std::string& why) {
  char where[64];
  std::snprintf(where, sizeof(where), " at byte %llu of %llu", static_cast<unsigned long long>(position_),
                static_cast<unsigned long long>(file_size_));
  error_ = why + where;
  return false;
}

bool BagStreamReader::readRecord(std::vector<std::uint8_t>* header, std::vector<std::uint8_t>* data,
                                 bool* truncated) {
  *truncated = false;
  std::uint8_t length[4];
  const auto remaining = [&] { return file_size_ - position_; };
  if (remaining() < 4) return false;
  file_.read(reinterpret_cast<char*>(length), 4);
  const std::uint32_t header_length = readU32(length);
  if (header_length > kMaxRecord) return fail("a record's header length is damaged");
  // A plausible record that runs past the end of the file is where the file was cut.
  if (header_length > remaining() - 4 || remaining() - 4 - header_length < 4) {
    cut_off_ = true;
    return false;
  }
  header->resize(header_length);
  file_.read(reinterpret_cast<char*>(header->data()), header_length);
  file_.read(reinterpret_cast<char*>(length), 4);
  const std::uint32_t data_length = readU32(length);
  if (data_length > kMaxRecord) return fail("a record's data length is damaged");
  const std::uint64_t available = remaining() - 8 - header_length;
  const std::uint32_t wanted = static_cast<std::uint32_t>(std::min<std::uint64_t>(data_length, available));
  data->resize(wanted);
  file_.read(reinterpret_cast<char*>(data->data()), wanted);
  if (!file_) return fail("the file could not be read");
  position_ += 8 + header_length + wanted;
  *truncated = wanted < data_length;
  return true;
}

bool BagStreamReader::addConnection(const Fields& header, const std::uint8_t* data, std::size_t size,
                                    const std::function<void(const Connection&)>& on_connection) {
  const auto id = header.find("conn");
  const auto topic = header.find("topic");
  if (id == header.end() || id->second.size() != 4 || topic == header.end()) return fail("a damaged connection record");
  const std::uint32_t conn = readU32(reinterpret_cast<const std::uint8_t*>(id->second.data()));
  if (connections_.count(conn)) return true;  // the index repeats every connection at the end
  Fields details;
  if (!parseFields(data, size, &details)) return fail("a damaged connection header");
  Connection& c = connections_[conn];
  c.topic = topic->second;
  c.datatype = details["type"];
  c.md5sum = details["md5sum"];
  if (on_connection) on_connection(c);
  return true;
}

bool BagStreamReader::parseRecords(const std::uint8_t* data, std::size_t size,
                                   const std::function<void(const Message&)>& on_message,
                                   const std::function<void(const Connection&)>& on_connection) {
  std::size_t at = 0;
  while (at < size) {
    if (size - at < 4) return fail("a chunk ends inside a record");
    const std::uint32_t header_length = readU32(data + at);
    if (header_length > size - at - 4) return fail("a record inside a chunk runs past the chunk");
    const std::uint8_t* header = data + at + 4;
    at += 4 + header_length;
    if (size - at < 4) return fail("a chunk ends inside a record");
    const std::uint32_t data_length = readU32(data + at);
    if (data_length > size - at - 4) return fail("a record inside a chunk runs past the chunk");
    const std::uint8_t* body = data + at + 4;
    at += 4 + data_length;
    FieldViews views;
    const bool parsed = parseFieldViews(header, header_length, &views);
    if (!parsed || views["op"].size() != 1) {
      // A header with more fields than a message record's: parsed in full, as the other records are.
      Fields fields;
      if (parsed || !parseFields(header, header_length, &fields) || fields["op"].size() != 1) {
        return fail("a damaged record header inside a chunk");
      }
      if (static_cast<std::uint8_t>(fields["op"][0]) == kOpConnection &&
          !addConnection(fields, body, data_length, on_connection)) {
        return false;
      }
      continue;
    }
    const std::uint8_t op = static_cast<std::uint8_t>(views["op"][0]);
    if (op == kOpConnection) {
      Fields fields;
      parseFields(header, header_length, &fields);
      if (!addConnection(fields, body, data_length, on_connection)) return false;
    } else if (op == kOpMessageData) {
      const std::string_view conn = views["conn"], time = views["time"];
      if (conn.size() != 4 || time.size() != 8) return fail("a damaged message record");
      const auto c = connections_.find(readU32(reinterpret_cast<const std::uint8_t*>(conn.data())));
      if (c == connections_.end()) return fail("a message of an unknown connection");
      const auto* t = reinterpret_cast<const std::uint8_t*>(time.data());
      Message m;
      m.connection = &c->second;
      m.time = readU32(t) + 1e-9 * readU32(t + 4);
      m.data = body;
      m.size = data_length;
      ++messages_;
      on_message(m);
    }
  }
  return true;
}

bool BagStreamReader::read(const std::function<void(const Message&)>& on_message,
                           const std::function<void(const Connection&)>& on_connection) {
  std::vector<std::uint8_t> header, data, chunk;
  bool truncated = false;
  while (readRecord(&header, &data, &truncated)) {
    Fields fields;
    if (!parseFields(header.data(), header.size(), &fields) || fields["op"].size() != 1) {
      return fail("a damaged record header");
    }
    const std::uint8_t op = static_cast<std::uint8_t>(fields["op"][0]);
    if (op == kOpFileHeader) {
      const std::string& index = fields["index_pos"];
      const std::string& chunks = fields["chunk_count"];
      if (index.size() == 8) {
        const auto* b = reinterpret_cast<const std::uint8_t*>(index.data());
        index_position_ = readU32(b) | static_cast<std::uint64_t>(readU32(b + 4)) << 32;
      }
      if (chunks.size() == 4) chunk_count_ = readU32(reinterpret_cast<const std::uint8_t*>(chunks.data()));
      continue;
    }
    if (op == kOpChunkInfo) ++chunk_infos_;
    if (op == kOpConnection) {
      if (!addConnection(fields, data.data(), data.size(), on_connection)) return false;
      continue;
    }
    if (op != kOpChunk) {
      if (truncated) break;  // the index at the end, cut short: every message was read
      continue;              // the file header, index data and chunk info say nothing new
    }
    data_lost_ = truncated;
    const std::string compression = fields["compression"];
    const std::string& size_field = fields["size"];
    if (size_field.size() != 4) return fail("a damaged chunk header");
    const std::uint32_t size = readU32(reinterpret_cast<const std::uint8_t*>(size_field.data()));
    if (size > kMaxRecord) return fail("a damaged chunk size");
    if (compression == "none") {
      // A chunk cut off while recording: its complete records are still good, the broken last one is the cut.
      const bool parsed = parseRecords(data.data(), data.size(), on_message, on_connection);
      if (!parsed && !truncated) return false;
      if (truncated) error_.clear();
    } else {
      if (truncated) break;  // a compressed chunk cut short cannot be expanded
      chunk.resize(size);
      unsigned int produced = size;
      int status = -1;
      if (compression == "bz2") {
        status = BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(chunk.data()), &produced,
                                            reinterpret_cast<char*>(data.data()),
                                            static_cast<unsigned int>(data.size()), 0, 0) == BZ_OK ? 0 : -1;
      } else if (compression == "lz4") {
        status = roslz4_buffToBuffDecompress(reinterpret_cast<char*>(data.data()),
                                             static_cast<unsigned int>(data.size()),
                                             reinterpret_cast<char*>(chunk.data()), &produced) == ROSLZ4_OK ? 0 : -1;
      } else {
        return fail("a chunk compressed with '" + compression + "', which this reader does not know");
      }
      if (status != 0 || produced != size) return fail("a " + compression + " chunk that does not expand");
      if (!parseRecords(chunk.data(), chunk.size(), on_message, on_connection)) return false;
    }
    if (truncated) break;
  }
  if (!error_.empty()) return false;
  // Cut off: inside a record, or short of the index the header promised (chunk info records missing).
  cut_off_ = cut_off_ || truncated || position_ < file_size_ || chunk_infos_ < chunk_count_;
  if (!cut_off_) return true;
  // Before the index (or with none: cut while recording) messages were lost; inside it, none were.
  data_lost_ = data_lost_ || index_position_ == 0 || position_ < index_position_;
  return fail(data_lost_ ? "the bag ends inside its messages (cut off while recording or copying)"
                         : "the bag ends inside its index (cut off after the last message)");
}

bool decodeFluidPressure(const std::uint8_t* data, std::uint32_t size, double* stamp, double* pressure) {
  Cursor c(data, size);
  double variance = 0.0;
  return c.header(stamp) && c.f64(pressure) && c.f64(&variance);
}

bool decodeValveSignal(const std::uint8_t* data, std::uint32_t size, double* stamp, double* voltage,
                       double* spool) {
  Cursor c(data, size);
  return c.header(stamp) && c.f64(voltage) && c.f64(spool);
}

bool decodeJointState(const std::uint8_t* data, std::uint32_t size, double* stamp, std::vector<std::string>* names,
                      std::vector<double>* position, std::vector<double>* velocity) {
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
