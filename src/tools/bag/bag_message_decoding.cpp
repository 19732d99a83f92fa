// The messages analyze_bag reads, decoded from their serialised bytes (declared in bag_stream_reader.h).
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "bag/bag_record_format.h"
#include "bag/bag_stream_reader.h"

namespace die_cushion_ident {

using namespace bag_format;

namespace {

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
