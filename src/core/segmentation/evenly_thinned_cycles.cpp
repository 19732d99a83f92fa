#include "die_cushion_ident/core/segmentation/evenly_thinned_cycles.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace die_cushion_ident {

EvenlyThinnedCycles::EvenlyThinnedCycles(std::size_t max_samples, std::size_t lead_in)
    : max_samples_(max_samples), lead_in_(lead_in) {
  if (max_samples < 10 * std::max<std::size_t>(lead_in, 1)) {
    throw std::invalid_argument("EvenlyThinnedCycles: the bound must hold at least ten lead-ins");
  }
}

void EvenlyThinnedCycles::reserve(std::size_t samples) {
  // A cycle is appended whole before the store is thinned: room for one beyond the bound.
  kept_.reserve(std::min(samples, max_samples_ + max_samples_ / 8));
}

void EvenlyThinnedCycles::push(const GridSample& sample) {
  const std::uint64_t index = samples_seen_++;
  if (index == 0) first_time_ = sample.t;
  const StrokeSegmenter::Step step = segmenter_.push(sample);
  if (step.cycle_start) startCycle(segmenter_.impacts() - 1, index);
  if (keeping_) {
    append(sample, index);
    if (kept_.size() > max_samples_) {
      thin();
      // Nothing left to drop but the cycle being read (hours without an impact): the rest of it goes.
      if (kept_.size() > max_samples_) keeping_ = false;
    }
  }
  recent_.push_back(sample);
  if (recent_.size() > lead_in_) recent_.pop_front();
}

void EvenlyThinnedCycles::append(const GridSample& sample, std::uint64_t index) {
  const bool follows = !kept_.empty() && index == last_kept_ + 1;
  if (!follows) stretch_begin_ = kept_.size();
  kept_.push_back(sample);
  if (!follows && index > 0) kept_.back().discontinuity = true;
  last_kept_ = index;
}

void EvenlyThinnedCycles::startCycle(int number, std::uint64_t index) {
  const bool keep = number % stride_ == 0;
  if (keep && !keeping_) {
    // The lead-in: the samples before the impact, those not kept already.
    std::uint64_t first = index - recent_.size();
    for (const GridSample& g : recent_) {
      if (kept_.empty() || first > last_kept_) append(g, first);
      ++first;
    }
  }
  if (keep) cycles_.push_back({number, kept_.size(), stretch_begin_, index});
  keeping_ = keep;
}

void EvenlyThinnedCycles::thin() {
  stride_ *= 2;
  std::vector<KeptCycle> still;
  std::size_t write = 0, previous_end = 0, previous_stretch = std::numeric_limits<std::size_t>::max();
  std::size_t new_stretch = 0;
  for (std::size_t k = 0; k < cycles_.size(); ++k) {
    const KeptCycle& c = cycles_[k];
    if (c.number % stride_ != 0) continue;
    std::size_t end = kept_.size();
    if (k + 1 < cycles_.size()) {
      const KeptCycle& next = cycles_[k + 1];
      end = next.stretch_begin == c.stretch_begin ? next.start : next.stretch_begin;
    }
    std::size_t begin = std::max(c.start >= lead_in_ ? c.start - lead_in_ : 0, c.stretch_begin);
    const bool joins = c.stretch_begin == previous_stretch && begin <= previous_end;
    if (joins) begin = previous_end;
    if (!joins) new_stretch = write;
    // Moved towards the front: the destination never lies beyond the source.
    if (write != begin) std::memmove(&kept_[write], &kept_[begin], (end - begin) * sizeof(GridSample));
    if (!joins && c.global_start - (c.start - begin) > 0) kept_[write].discontinuity = true;
    still.push_back({c.number, write + (c.start - begin), new_stretch, c.global_start});
    last_kept_ = c.global_start + (end - c.start) - 1;
    write += end - begin;
    previous_end = end;
    previous_stretch = c.stretch_begin;
  }
  if (still.empty()) {  // no impact yet: the first half of what was read
    write = std::min(kept_.size(), max_samples_ / 2);
    last_kept_ = write - 1;
  }
  kept_.resize(write);
  cycles_ = std::move(still);
  const int reading = segmenter_.impacts() - 1;
  keeping_ = reading >= 0 && !cycles_.empty() && cycles_.back().number == reading;
  if (keeping_) stretch_begin_ = cycles_.back().stretch_begin;
}

}  // namespace die_cushion_ident
