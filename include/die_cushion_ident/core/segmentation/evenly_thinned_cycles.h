#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <limits>
#include <vector>

#include "die_cushion_ident/core/segmentation/stroke_segmenter.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"

namespace die_cushion_ident {

/// The grid the offline analysis keeps, bounded in samples whatever the recording's length: every sample
/// while the recording fits, else an evenly spaced subset of whole press cycles (every 2nd, 4th, ... cycle,
/// each with the samples before its impact that the filters need to settle, `lead_in`), cut at the impacts
/// as they are read (StrokeSegmenter). The analyses that read the grid many times (the fit to the whole
/// recording, the free run and its refinement, the jackknife, the cycle groups, the change search, the
/// effect ranking, the formula search) then judge that subset: an hour's ranking alone took 7.7 s and its
/// grid 86 MB (doc/performance.md).
///
/// Where a kept stretch does not follow the previous one in time, its first sample is a discontinuity:
/// every stage restarts its filters, free runs and phase classifier there, as at a gap in the recording.
/// Samples before the first impact (cycle -1) are kept only while nothing is thinned.
class EvenlyThinnedCycles {
 public:
  /// `max_samples`: the bound (at least 10 times `lead_in`); `lead_in`: samples kept before each kept
  /// cycle's impact.
  EvenlyThinnedCycles(std::size_t max_samples, std::size_t lead_in);

  void push(const GridSample& sample);
  /// Room for `samples` (no more than the bound and the longest cycle beyond it).
  void reserve(std::size_t samples);

  const std::vector<GridSample>& grid() const { return kept_; }
  /// Sets each kept sample's oil temperature to `at(t)` [degC] (the offline analysis, once every message of
  /// the slow temperature topic is in: while reading, a sample takes the newest one that has arrived).
  template <typename At>
  void setOilTemperature(At at) {
    for (GridSample& g : kept_) g.T = static_cast<float>(at(g.t));
  }
  /// 1 while every sample is kept, else every stride-th cycle is (a power of 2).
  int stride() const { return stride_; }
  std::uint64_t samplesSeen() const { return samples_seen_; }
  /// [s] the first sample's time (NaN before one): where the recording's grid began, kept or not.
  double firstTime() const { return first_time_; }
  /// Cycles begun (impacts) in the whole recording, and of them kept.
  int cyclesSeen() const { return segmenter_.impacts(); }
  int cyclesKept() const { return static_cast<int>(cycles_.size()); }

 private:
  // A kept cycle: its number in the recording, where its impact is in kept_, where the stretch of kept_
  // that is contiguous in time and holds it begins, and its impact's index among all samples read.
  struct KeptCycle {
    int number;
    std::size_t start, stretch_begin;
    std::uint64_t global_start;
  };
  void thin();  // doubles the stride, in place
  void startCycle(int number, std::uint64_t index);
  // Appends the index-th sample read; one that does not follow the last kept begins a stretch.
  void append(const GridSample& sample, std::uint64_t index);

  std::size_t max_samples_, lead_in_;
  StrokeSegmenter segmenter_;
  std::vector<GridSample> kept_;
  std::vector<KeptCycle> cycles_;
  std::deque<GridSample> recent_;  // the last lead_in_ samples read, for a kept cycle after skipped ones
  int stride_ = 1;
  bool keeping_ = true;
  std::size_t stretch_begin_ = 0;  // of the stretch being appended to
  std::uint64_t samples_seen_ = 0;
  std::uint64_t last_kept_ = 0;  // index among all samples read of kept_.back()
  double first_time_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace die_cushion_ident
