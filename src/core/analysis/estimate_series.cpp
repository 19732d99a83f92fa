#include "die_cushion_ident/core/analysis/estimate_series.h"

#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace die_cushion_ident {

namespace {
void append(std::vector<char>* bytes, const void* value, std::size_t size) {
  const char* begin = static_cast<const char*>(value);
  bytes->insert(bytes->end(), begin, begin + size);
}
void appendFloat(std::vector<char>* bytes, double value) {
  const float f = static_cast<float>(value);
  append(bytes, &f, sizeof(f));
}
}  // namespace

void EstimateSeries::add(const HydraulicEstimate& e) {
  parameters_ = static_cast<int>(e.parameters.size());
  append(&memory_, &e.t, sizeof(e.t));
  for (const auto& p : e.parameters) appendFloat(&memory_, p.value);
  for (const auto& p : e.parameters) appendFloat(&memory_, p.std);
  appendFloat(&memory_, e.equation_error_rms);
  if (memory_.size() >= kMemorySteps * recordBytes() && !no_file_) spill();
}

void EstimateSeries::spill() {
  if (!file_) {
    std::FILE* file = std::tmpfile();  // unlinked at once: nothing is left behind, whatever ends the run
    if (file == nullptr) {
      no_file_ = true;
      return;
    }
    file_.reset(file, [](std::FILE* f) { std::fclose(f); });
  }
  const std::size_t written = std::fwrite(memory_.data(), 1, memory_.size(), file_.get());
  if (written != memory_.size() || std::fflush(file_.get()) != 0) {
    // A full disk: the steps not written stay in memory from here on (those before it are in the file).
    no_file_ = true;
    const std::size_t whole = written / recordBytes();
    spilled_ += whole;
    memory_.erase(memory_.begin(), memory_.begin() + static_cast<std::ptrdiff_t>(whole * recordBytes()));
    return;
  }
  spilled_ += memory_.size() / recordBytes();
  memory_.clear();
}

EstimateSeries::Reader::Reader(const EstimateSeries& series)
    : series_(series), parameters_(series.parameters_) {}

bool EstimateSeries::Reader::next() {
  if (index_ >= series_.size()) return false;
  const std::size_t bytes_per_step = series_.recordBytes();
  if (index_ >= series_.spilled_) {
    record_ = series_.memory_.data() + (index_ - series_.spilled_) * bytes_per_step;
  } else {
    if (index_ >= block_first_ + block_steps_) {
      // The next block from the file, read at its offset (pread: readers do not share a file position).
      block_first_ = index_;
      block_steps_ = std::min<std::size_t>(4096, series_.spilled_ - index_);
      block_.resize(block_steps_ * bytes_per_step);
      const std::size_t bytes = block_.size();
      const off_t offset = static_cast<off_t>(index_ * bytes_per_step);
      std::size_t done = 0;
      while (done < bytes) {
        const ssize_t got = ::pread(::fileno(series_.file_.get()), block_.data() + done, bytes - done,
                                    offset + static_cast<off_t>(done));
        if (got <= 0) throw std::runtime_error("the estimates' temporary file could not be read back");
        done += static_cast<std::size_t>(got);
      }
    }
    record_ = block_.data() + (index_ - block_first_) * bytes_per_step;
  }
  ++index_;
  return true;
}

float EstimateSeries::Reader::number(int k) const {
  float f;
  std::memcpy(&f, record_ + sizeof(double) + sizeof(float) * static_cast<std::size_t>(k), sizeof(f));
  return f;
}

double EstimateSeries::Reader::t() const {
  double t;
  std::memcpy(&t, record_, sizeof(double));
  return t;
}

}  // namespace die_cushion_ident
