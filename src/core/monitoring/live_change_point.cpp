#include "die_cushion_ident/core/monitoring/live_change_point.h"

#include <chrono>
#include <cmath>

#include "die_cushion_ident/core/adequacy/model_assessment.h"

namespace die_cushion_ident {

namespace {

// [s] how far a re-segmented impact may lie from the live segmenter's to be the same: both classify the same
// samples, only the history before differs, so they meet within a few samples of the 2 ms grid.
constexpr double kSameImpact = 0.05;

}  // namespace

LiveChangePoint::~LiveChangePoint() {
  if (job_.valid()) job_.wait();
}

void LiveChangePoint::restart() {
  ++generation_;
  segmenter_ = StrokeSegmenter();
  last_complete_ = false;
  check_pending_ = false;
  samples_this_run_ = 0;
  impact_stamps_.clear();
  first_impact_number_ = 0;
  run_start_ = std::numeric_limits<double>::quiet_NaN();
  window_start_ = -std::numeric_limits<double>::infinity();
  onset_.reset();
}

void LiveChangePoint::resync() {
  ++generation_;  // a running check read the run before
  segmenter_ = StrokeSegmenter();
  last_complete_ = false;
  check_pending_ = false;
  first_impact_number_ += static_cast<long>(impact_stamps_.size());
  impact_stamps_.clear();
  samples_this_run_ = 0;
  window_start_ = -std::numeric_limits<double>::infinity();
  onset_.reset();
}

std::optional<LiveOnset> LiveChangePoint::addSample(const GridSample& g, const std::deque<GridSample>& window,
                                                    const IdentificationConfig& config) {
  if (!std::isfinite(run_start_)) run_start_ = g.t;
  ++samples_this_run_;
  const StrokeSegmenter::Step step = segmenter_.push(g);
  if (step.cycle_start) impact_stamps_.push_back(g.t);
  // Impacts that left the window are no cycle of a check any more; their numbers go on counting.
  while (!impact_stamps_.empty() && !window.empty() && impact_stamps_.front() < window.front().t) {
    impact_stamps_.pop_front();
    ++first_impact_number_;
  }
  std::optional<LiveOnset> found = collect();
  // A cycle is complete once the cushion is back up: its last sample is in, the check can see it.
  const bool complete = segmenter_.lastCycleComplete();
  if (complete && !last_complete_) check_pending_ = true;
  last_complete_ = complete;
  if (check_pending_ && !job_.valid()) {
    check_pending_ = false;
    startCheck(window, config);
  }
  return found;
}

void LiveChangePoint::startCheck(const std::deque<GridSample>& window, const IdentificationConfig& config) {
  std::vector<GridSample> grid;
  const std::size_t first = window.size() > samples_this_run_ ? window.size() - samples_this_run_ : 0;
  for (std::size_t i = first; i < window.size(); ++i) {
    if (window[i].t >= window_start_) grid.push_back(window[i]);
  }
  std::vector<double> stamps(impact_stamps_.begin(), impact_stamps_.end());
  job_ = std::async(std::launch::async, [grid = std::move(grid), config, stamps = std::move(stamps),
                                         first = static_cast<int>(first_impact_number_), start = run_start_,
                                         generation = generation_] {
    const auto started = std::chrono::steady_clock::now();
    Job job;
    job.generation = generation;
    job.onset = check(grid, config, stamps, first, start);
    job.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return job;
  });
}

std::optional<LiveOnset> LiveChangePoint::collect() {
  if (!job_.valid() || job_.wait_for(std::chrono::seconds(0)) != std::future_status::ready)
    return std::nullopt;
  Job job = job_.get();
  if (job.generation != generation_) return std::nullopt;
  last_check_seconds_ = job.seconds;
  if (!job.onset) return std::nullopt;
  // The check read the window from window_start_ on, so its onset lies after the last one.
  onset_ = job.onset;
  window_start_ = onset_->stamp - kLeadTime;
  return onset_;
}

std::optional<LiveOnset> LiveChangePoint::check(const std::vector<GridSample>& grid,
                                                const IdentificationConfig& config,
                                                const std::vector<double>& impact_stamps, int first_number,
                                                double run_start) {
  if (grid.empty() || impact_stamps.empty()) return std::nullopt;
  const StrokeSegmentation strokes = segmentStrokes(grid);
  if (strokes.cycles < kOnsetMinimumCycles) return std::nullopt;
  // The window's first cycle by its number since the run started: the live impact at its stamp.
  const double first_stamp = grid[strokes.cycle_start.front()].t;
  std::size_t nearest = 0;
  for (std::size_t i = 1; i < impact_stamps.size(); ++i) {
    if (std::abs(impact_stamps[i] - first_stamp) < std::abs(impact_stamps[nearest] - first_stamp))
      nearest = i;
  }
  if (!(std::abs(impact_stamps[nearest] - first_stamp) <= kSameImpact)) return std::nullopt;
  const int first_cycle = first_number + static_cast<int>(nearest);
  const std::optional<EffectOnset> onset =
      findEffectOnset(grid, strokes, config, kSignificance, 1, 60, 1, run_start, first_cycle);
  if (!onset || strokes.cycles - (onset->cycle - first_cycle) > kRecentCycles) return std::nullopt;
  LiveOnset live;
  live.onset = *onset;
  live.stamp = run_start + onset->time;
  return live;
}

}  // namespace die_cushion_ident
