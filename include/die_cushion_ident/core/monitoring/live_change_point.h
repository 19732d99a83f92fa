#pragma once

#include <cstdint>
#include <deque>
#include <future>
#include <limits>
#include <optional>
#include <vector>

#include "die_cushion_ident/core/adequacy/effect_onset.h"
#include "die_cushion_ident/core/estimation/identification_config.h"
#include "die_cushion_ident/core/segmentation/stroke_segmenter.h"

namespace die_cushion_ident {

/// A library effect that began within the live window: the offline onset (findEffectOnset) with its cycle
/// counted from the first impact the monitor saw since it (re)started and its time from that start.
struct LiveOnset {
  EffectOnset onset;
  double stamp = 0.0;  ///< [s] grid time of the impact of the first cycle the effect acts in
};

/// Whether the plant changed within the live window, checked as soon as a press cycle completes: the offline
/// onset's test (each library effect fitted to every cycle alone, the largest step in its parameter over the
/// cycles, Bonferroni-corrected over every split and effect) on the window's cycles since the last change.
/// With at least two cycles after the step the test can see it, so an effect is named about two cycles after
/// it began instead of once the window (30 s) has filled with the new plant's cycles.
///
/// Once a change is found, the window from the onset cycle's impact on is the plant as it is now
/// (windowStart): the ranking and the next checks look only at it, never again at the cycles before, so the
/// same change is not found twice and the ranking does not average two plants.
///
/// The check takes tens of milliseconds on a 30 s window; it runs on its own thread (std::async) on a copy
/// of the window, one at a time: a check due while one runs waits for the next completed cycle.
class LiveChangePoint {
 public:
  /// Per check, over every split and effect (Bonferroni). A tenth of the offline analysis's
  /// (kVariationSignificance): offline the test runs once per recording, live once per press cycle; at 1e-3
  /// one check in about 1400 on steady plants claimed a change (air on a fast press with a leak throughout,
  /// p = 6.7e-4), a fast press would hear of one every half hour.
  static constexpr double kSignificance = 1e-4;
  /// A change is claimed only while it is recent: at most this many complete cycles after its onset (found
  /// two cycles after it, three for some overlaps and air, where it was found at all). A step further back
  /// has been tested at the checks before; testing it again after every cycle only adds chances of a false
  /// claim.
  static constexpr int kRecentCycles = 4;

  LiveChangePoint() = default;
  /// Waits for a running check.
  ~LiveChangePoint();
  LiveChangePoint(const LiveChangePoint&) = delete;
  LiveChangePoint& operator=(const LiveChangePoint&) = delete;

  /// A new model or a new run: cycles are counted again from the next impact, no change is known, a running
  /// check's result is dropped.
  void restart();
  /// The stamps jumped back (a bag restarted): the cycles before are another run's, forgotten with their
  /// change; the checks read only the samples since.
  void resync();

  /// One grid sample, after it was appended to `window` (the monitor's ranking window). Starts a check of the
  /// window with `config`'s model when a cycle has just completed and none runs; returns a change found by a
  /// check that finished since the last call.
  std::optional<LiveOnset> addSample(const GridSample& g, const std::deque<GridSample>& window,
                                     const IdentificationConfig& config);

  /// [s] samples before the onset cycle's impact that the checks and the ranking keep: the rest before it,
  /// so that the stroke segmentation sees the impact as the first cycle's.
  static constexpr double kLeadTime = 0.1;
  /// [s] grid time from which the window holds only the plant as it is now (kLeadTime before the last
  /// onset's impact); -inf before a change.
  double windowStart() const { return window_start_; }
  /// The last change found since the restart.
  const std::optional<LiveOnset>& onset() const { return onset_; }
  /// Impacts seen since the restart (the number the next cycle will carry).
  int cycles() const { return static_cast<int>(first_impact_number_ + impact_stamps_.size()); }
  bool checkRunning() const { return job_.valid(); }
  /// Blocks until a running check has finished (its result is taken on the next sample), for a caller that
  /// feeds samples faster than real time and wants them handled as if the check took no plant time.
  void waitForCheck() const {
    if (job_.valid()) job_.wait();
  }
  /// [s] wall-clock duration of the last check that finished; NaN before the first.
  double lastCheckSeconds() const { return last_check_seconds_; }

  /// The check itself, free of threads: the onset on `grid` (a copy of the window from windowStart on),
  /// with cycles numbered by the impacts `impact_stamps` [s] (the first is number `first_number`) and times
  /// from `run_start` [s].
  static std::optional<LiveOnset> check(const std::vector<GridSample>& grid,
                                        const IdentificationConfig& config,
                                        const std::vector<double>& impact_stamps, int first_number,
                                        double run_start);

 private:
  struct Job {
    std::optional<LiveOnset> onset;
    int generation = 0;
    double seconds = 0.0;
  };
  void startCheck(const std::deque<GridSample>& window, const IdentificationConfig& config);
  std::optional<LiveOnset> collect();

  StrokeSegmenter segmenter_;
  bool last_complete_ = false;
  std::deque<double> impact_stamps_;  // [s] of the impacts still in the window
  long first_impact_number_ = 0;      // number of impact_stamps_.front()
  double run_start_ = std::numeric_limits<double>::quiet_NaN();
  double window_start_ = -std::numeric_limits<double>::infinity();
  bool check_pending_ = false;  // a cycle completed while a check ran: check again when it ends
  // Samples since the restart or resync: after a resync the window's older samples are another run's (with
  // later stamps, so no time tells them apart).
  std::size_t samples_this_run_ = 0;
  std::optional<LiveOnset> onset_;
  std::future<Job> job_;
  double last_check_seconds_ = std::numeric_limits<double>::quiet_NaN();
  int generation_ = 0;
};

}  // namespace die_cushion_ident
