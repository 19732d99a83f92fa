#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <vector>

#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"

namespace die_cushion_ident {

/// The online estimate at every identification step (for the time series in analysis.bag and CSV), stored
/// flat in single precision (8 + 4 (2n + 1) bytes a step), in memory up to kMemorySteps and beyond that in
/// an anonymous temporary file: 100 steps per second are 17 MB an hour, and a day's recording must not hold
/// them in memory (issue 30). Read back front to back by Reader; where no temporary file can be made, the
/// steps stay in memory.
class EstimateSeries {
 public:
  /// Steps held in memory before they go to the file (4 MB at three parameters).
  static constexpr std::size_t kMemorySteps = 1 << 16;

  void add(const HydraulicEstimate& e);
  std::size_t size() const { return spilled_ + memory_.size() / recordBytes(); }
  int parameters() const { return parameters_; }

  /// The steps in order, one at a time; readers are independent (each reads the file at its own offsets)
  /// and may run on threads of their own while nothing is added.
  class Reader {
   public:
    explicit Reader(const EstimateSeries& series);
    /// Moves to the next step; false after the last.
    bool next();
    double t() const;
    float value(int j) const { return number(j); }
    float std(int j) const { return number(parameters_ + j); }
    float equationError() const { return number(2 * parameters_); }

   private:
    const EstimateSeries& series_;
    int parameters_;
    std::size_t index_ = 0;     // of the step after the current one
    float number(int k) const;  // the k-th float after t
    std::vector<char> block_;
    std::size_t block_first_ = 0, block_steps_ = 0;
    const char* record_ = nullptr;
  };

 private:
  // A step's record: t, then the values, stds and the equation error as floats (bytes, copied as they are).
  std::size_t recordBytes() const {
    return sizeof(double) + sizeof(float) * (1 + 2 * static_cast<std::size_t>(parameters_));
  }
  void spill();

  int parameters_ = 0;
  std::vector<char> memory_;
  std::shared_ptr<std::FILE> file_;  // shared by copies, which must then not add
  std::size_t spilled_ = 0;
  bool no_file_ = false;  // a temporary file could not be made or written: everything stays in memory
};

}  // namespace die_cushion_ident
