// BagStreamReader: the records inside chunks, compressed or not, the open chunk of a killed recording, and
// the index records checked against what was read.
#include <bzlib.h>
#include <roslz4/lz4s.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string_view>

#include "bag/bag_record_format.h"
#include "bag/bag_stream_reader.h"

namespace die_cushion_ident {

using namespace bag_format;

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

}  // namespace die_cushion_ident
