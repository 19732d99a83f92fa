#pragma once

// Bag format 2.0 at the level of records (private to src/tools/bag): the ops, a record header's fields (into
// a map, or as views for the ten million message records an hour), the search for a record header in damaged
// data and the index records at the end.

#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace die_cushion_ident::bag_format {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr std::size_t kMagicSize = sizeof(kMagic) - 1;
// Far beyond any real record (rosbag's chunks are 768 kB by default): a larger length is damage.
constexpr std::uint32_t kMaxRecord = 512u << 20;
constexpr std::uint8_t kOpMessageData = 0x02, kOpFileHeader = 0x03, kOpIndexData = 0x04, kOpChunk = 0x05,
                       kOpChunkInfo = 0x06, kOpConnection = 0x07;

inline std::uint32_t readU32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

// A little-endian 8-byte field (index_pos, chunk_pos).
inline std::uint64_t u64Field(const std::string& value) {
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

inline bool parseFields(const std::uint8_t* data, std::size_t size,
                        std::map<std::string, std::string>* fields) {
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
inline bool parseFieldViews(const std::uint8_t* data, std::size_t size, FieldViews* fields) {
  fields->count = 0;
  return forEachField(data, size, [&](std::string_view name, std::string_view value) {
    if (fields->count == FieldViews::kMax) return false;
    fields->names[fields->count] = name;
    fields->values[fields->count] = value;
    ++fields->count;
    return true;
  });
}

}  // namespace die_cushion_ident::bag_format
