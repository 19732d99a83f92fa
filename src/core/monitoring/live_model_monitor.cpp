#include "die_cushion_ident/core/monitoring/live_model_monitor.h"

#include <chrono>
#include <cmath>
#include <limits>

#include "die_cushion_ident/core/adequacy/formula_proposals.h"
#include "die_cushion_ident/core/adequacy/model_assessment.h"

namespace die_cushion_ident {

namespace {

// The live clock-offset correction restarts the identification once: taken beyond this many standard
// uncertainties (the survey's, on a finer grid and refined by the free run, uses two).
constexpr double kLiveCorrectionSigmas = 3.0;

// Weight of a new squared residual in the running means: about one press cycle (2.6 s) of 2 ms samples,
// long enough to average over the phases, short enough to forget the estimator's start.
constexpr double kResidualWeight = 1.0 / 1300.0;
// A phase holds about a fifth of a cycle: the same memory in its own samples.
constexpr double kPhaseResidualWeight = 5.0 * kResidualWeight;

}  // namespace

LiveModelMonitor::LiveModelMonitor(const IdentificationConfig& config, const HydraulicModel& model,
                                   LiveMonitorSettings settings)
    : settings_(settings), last_ranking_seconds_(std::numeric_limits<double>::quiet_NaN()) {
  restart(config, model);
}

LiveModelMonitor::~LiveModelMonitor() {
  if (job_.valid()) job_.wait();
}

void LiveModelMonitor::restart(const IdentificationConfig& config, const HydraulicModel& model) {
  config_ = config;
  free_run_ = std::make_unique<FreeRunPressure>(model, config.min_pressure);
  classifier_.reset();
  window_.clear();
  ranking_.reset();
  ++generation_;
  last_ranking_time_ = -1e18;
  ranking_now_ = false;
  change_point_.restart();
  square_error_ = 0.0;
  phase_square_error_.fill(0.0);
  compared_ = 0;
  updates_ = 0;
  modelled_pressure_ = 0.0;
  blocker_ = "";
}

void LiveModelMonitor::resync() {
  free_run_->resync();
  classifier_.reset();
  change_point_.resync();
}

double LiveModelMonitor::simulationErrorRms() const { return std::sqrt(square_error_); }

double LiveModelMonitor::phaseErrorRms(StrokePhase phase) const {
  return std::sqrt(phase_square_error_[static_cast<int>(phase)]);
}

std::optional<LiveRanking> LiveModelMonitor::addSample(const GridSample& g, const HydraulicIdentifier& identifier) {
  last_ = g;
  updates_ = identifier.updates();
  window_.push_back(g);
  const auto capacity = static_cast<std::size_t>(settings_.ranking_window / config_.resampler.sample_period);
  while (window_.size() > capacity) window_.pop_front();
  std::optional<LiveRanking> finished = collectRanking();
  if (change_point_.addSample(g, window_, config_)) ranking_now_ = true;
  if (ranking_now_ && !job_.valid()) {
    // The new plant's first ranking: not a period later, and not skipped for one still running.
    ranking_now_ = false;
    last_ranking_time_ = g.t;
    startRanking();
  } else if (g.t - last_ranking_time_ >= settings_.ranking_period || g.t < last_ranking_time_) {
    last_ranking_time_ = g.t;
    startRanking();
  }

  phase_ = classifier_.classify(g);
  modelled_pressure_ = free_run_->step(g, identifier.physicalParameters());
  blocker_ = !g.complete           ? "a topic is silent or stale (see the input diagnostics)"
             : !std::isfinite(g.v) ? "no velocity (the position topic carries none and it cannot be derived: "
                                     "positions missing or not finite)"
             : !std::isfinite(g.y) ? "no spool position (not measured and not predictable)"
             : g.p < config_.min_pressure ? "the pressure is below min_pressure, where the model is not trusted"
                                          : "";
  // Before the estimator has seen some excitation the model is its start value: not worth comparing. A
  // re-anchored step has zero residual by construction.
  if (estimatorStarted() && std::isfinite(modelled_pressure_) && !free_run_->anchoredThisStep() &&
      std::isfinite(g.p)) {
    const double square = (g.p - modelled_pressure_) * (g.p - modelled_pressure_);
    const double w = std::max(kResidualWeight, 1.0 / static_cast<double>(++compared_));
    square_error_ += w * (square - square_error_);
    double& phase_mean = phase_square_error_[static_cast<int>(phase_)];
    phase_mean += kPhaseResidualWeight * (square - phase_mean);
  }
  return finished;
}

std::vector<GridSample> LiveModelMonitor::currentPlantWindow() const {
  std::vector<GridSample> grid;
  grid.reserve(window_.size());
  for (const GridSample& s : window_) {
    if (s.t >= change_point_.windowStart()) grid.push_back(s);
  }
  return grid;
}

const LiveOnset* LiveModelMonitor::changeWithinWindow() const {
  const auto& onset = change_point_.onset();
  if (!onset || window_.empty() || !(window_.front().t < change_point_.windowStart())) return nullptr;
  return &*onset;
}

void LiveModelMonitor::startRanking() {
  if (job_.valid()) return;  // the previous one is still running: the next period tries again
  std::vector<GridSample> grid = currentPlantWindow();
  // The change is reported while the window still reaches back before it (the ranking left those cycles out).
  std::optional<LiveOnset> onset;
  if (const LiveOnset* change = changeWithinWindow()) onset = *change;
  // The topics' clock offsets, once, on the first window with enough strokes (unless configured).
  if (!config_.topicDelaysSet() && !delay_estimate_) {
    TopicDelayEstimate estimate = estimateTopicDelays(grid, config_);
    if (estimate.valid) {
      // Corrected once, restarting the identification: only an offset beyond three of its standard
      // uncertainties (on a clean small stiff press the window's estimate on the 2 ms grid was -0.55 ms at
      // 2.2 of them, and the correction biased every estimate after it).
      delays_pending_ = estimate.significant(config_.resampler.sample_period) &&
                        estimate.distinguishable(kLiveCorrectionSigmas);
      delay_estimate_ = estimate;
    }
  }
  job_ = std::async(std::launch::async, [grid = std::move(grid), config = config_, generation = generation_,
                                         onset = std::move(onset), options = ranking_options_] {
    const auto started = std::chrono::steady_clock::now();
    Job job;
    job.generation = generation;
    const StrokeSegmentation strokes = segmentStrokes(grid);
    job.ranking.cycles = strokes.cycles;
    job.ranking.result = rankEffects(grid, strokes, config, options);
    // The formula search only where structured error is left, as offline without --propose.
    if (job.ranking.result.residual_unexplained)
      addFormulaProposals(grid, strokes, config, &job.ranking.result, options);
    if (onset) {
      job.ranking.result.conclusion = onset->onset.explanation + ". " +
                                      (strokes.cycles < EffectRankingOptions().min_held_out_cycles
                                           ? "The effects are ranked once more cycles since then are in."
                                           : job.ranking.result.conclusion);
      job.ranking.onset = onset;
    }
    job.ranking.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    return job;
  });
}

std::optional<LiveRanking> LiveModelMonitor::collectRanking() {
  if (!job_.valid() || job_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return std::nullopt;
  Job job = job_.get();
  if (job.generation != generation_) return std::nullopt;  // started before the model changed
  last_ranking_seconds_ = job.ranking.seconds;
  ranking_ = job.ranking.result;
  return std::move(job.ranking);
}

std::optional<std::array<double, kInputStreamCount>> LiveModelMonitor::takeDelayCorrection() {
  if (!delays_pending_) return std::nullopt;
  delays_pending_ = false;
  return delay_estimate_->delays;
}

}  // namespace die_cushion_ident
