#include "die_cushion_ident/core/adequacy/model_assessment.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>

#include "die_cushion_ident/core/fits/free_run_pressure.h"
#include "die_cushion_ident/core/segmentation/stroke_phase_classifier.h"
#include "die_cushion_ident/core/segmentation/stroke_segmenter.h"
#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {

struct Accumulator {
  int n = 0;
  double sum = 0.0, sum_squares = 0.0;
  void add(double e) {
    ++n;
    sum += e;
    sum_squares += e * e;
  }
};

// The free-run error in bins of one signal with fixed edges, accumulated sample by sample; labels in the
// unit users read (bar, m/s, opening).
class RegionBins {
 public:
  RegionBins(const char* dimension, std::vector<double> edges, double display_scale, const char* unit)
      : dimension_(dimension), edges_(std::move(edges)), scale_(display_scale), unit_(unit), acc_(edges_.size() - 1),
        made_(edges_.size() - 1) {}

  /// `made`: the restarted model's error at the same sample (NaN where it has none).
  void add(double value, double error, double made) {
    if (!std::isfinite(value)) return;
    const auto it = std::upper_bound(edges_.begin(), edges_.end(), value);
    if (it == edges_.begin() || it == edges_.end()) return;
    acc_[it - edges_.begin() - 1].add(error);
    if (std::isfinite(made)) made_[it - edges_.begin() - 1].add(made);
  }

  std::vector<RegionError> regions() const {
    std::vector<RegionError> out;
    for (std::size_t b = 0; b < acc_.size(); ++b) {
      if (acc_[b].n == 0) continue;
      RegionError r;
      r.dimension = dimension_;
      r.low = edges_[b];
      r.high = edges_[b + 1];
      r.label = formatted(FMT_STRING("{:g}"), r.low * scale_) + "..." +
                formatted(FMT_STRING("{:g}"), r.high * scale_) +
                (unit_[0] != '\0' ? std::string(" ") + unit_ : std::string());
      r.samples = acc_[b].n;
      r.rms = std::sqrt(acc_[b].sum_squares / acc_[b].n);
      r.mean_residual = acc_[b].sum / acc_[b].n;
      if (made_[b].n > 0) {
        r.made_rms = std::sqrt(made_[b].sum_squares / made_[b].n);
        r.made_mean_residual = made_[b].sum / made_[b].n;
      }
      out.push_back(r);
    }
    return out;
  }

 private:
  const char* dimension_;
  std::vector<double> edges_;
  double scale_;
  const char* unit_;
  std::vector<Accumulator> acc_, made_;
};

std::string where(const RegionError& r) {
  if (r.dimension == "phase") return "during " + r.label;
  if (r.dimension == "pressure") return "at pressures of " + r.label;
  if (r.dimension == "velocity") return "at cushion velocities of " + r.label;
  return "at spool openings of " + r.label;
}

}  // namespace

StrokeSegmentation segmentStrokes(const std::vector<GridSample>& grid) {
  StrokeSegmentation s;
  s.phase.resize(grid.size());
  s.samples = grid.size();
  StrokeSegmenter segmenter;
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const StrokeSegmenter::Step step = segmenter.push(grid[i]);
    if (step.cycle_start) s.cycle_start.push_back(i);
    s.phase[i] = step.phase;
  }
  const int impacts = segmenter.impacts();
  s.cycles = std::max(segmenter.lastCycleComplete() ? impacts : impacts - 1, 0);
  return s;
}

bool holdsNoPressStroke(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                        double stroke_length) {
  if (!strokes.cycle_start.empty()) return false;
  double lowest = std::numeric_limits<double>::infinity(), highest = -lowest;
  for (const GridSample& g : grid) {
    const double x = g.x;
    if (!std::isfinite(x)) continue;
    lowest = std::min(lowest, x);
    highest = std::max(highest, x);
  }
  // No position at all is another problem (the input's), not a recording at rest.
  return highest >= lowest && highest - lowest < 0.1 * stroke_length;
}

std::pair<std::size_t, std::size_t> StrokeSegmentation::range(int first, int last) const {
  const int impacts = static_cast<int>(cycle_start.size());
  const std::size_t begin = first <= -1 ? 0 : first >= impacts ? samples : cycle_start[first];
  const std::size_t end = last < -1 ? 0 : last == -1 ? (impacts > 0 ? cycle_start[0] : samples)
                          : last >= impacts - 1 ? samples
                                                : cycle_start[static_cast<std::size_t>(last) + 1];
  return {begin, std::max(begin, end)};
}

int StrokeSegmentation::cycleOf(std::size_t i) const {
  return static_cast<int>(std::upper_bound(cycle_start.begin(), cycle_start.end(), i) - cycle_start.begin()) - 1;
}

namespace {

// The model restarted from the measurement every kMadeHorizon: its errors are made within the horizon, in
// the phase where they show (the restart's pressure is the mean of the five samples around it, so that one
// sample's noise does not offset the whole stretch). Fills `made` per phase; returns the error per sample
// (NaN where none).
std::vector<float> errorsMadeWithinHorizon(const std::vector<GridSample>& grid,
                                           const StrokeSegmentation& strokes, const HydraulicModel& model,
                                           const ParameterVector& parameters, double min_pressure,
                                           Accumulator made[kStrokePhaseCount]) {
  FreeRunPressure restarted(model, min_pressure);
  std::vector<float> made_error(grid.size(), std::numeric_limits<float>::quiet_NaN());
  double next_restart = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const GridSample* next = i + 1 < grid.size() ? &grid[i + 1] : nullptr;
    if (grid[i].t >= next_restart) {
      double sum = 0.0;
      int n = 0;
      for (std::size_t j = i >= 2 ? i - 2 : 0; j <= i + 2 && j < grid.size(); ++j) {
        if (std::isfinite(grid[j].p) && !grid[j].discontinuity) {
          sum += grid[j].p;
          ++n;
        }
      }
      restarted.restartAt(n > 0 ? sum / n : grid[i].p);
      next_restart = grid[i].t + ModelAssessment::kMadeHorizon;
    }
    const double q = restarted.step(grid[i], parameters, next);
    if (std::isfinite(q) && !restarted.anchoredThisStep() && std::isfinite(grid[i].p)) {
      made[static_cast<int>(strokes.phase[i])].add(grid[i].p - q);
      made_error[i] = static_cast<float>(grid[i].p - q);
    }
  }
  return made_error;
}

std::vector<RegionError> phaseRegions(const Accumulator phase[kStrokePhaseCount],
                                      const Accumulator made[kStrokePhaseCount]) {
  std::vector<RegionError> regions;
  for (int k = 0; k < kStrokePhaseCount; ++k) {
    if (phase[k].n == 0) continue;
    RegionError r;
    r.dimension = "phase";
    r.label = strokePhaseName(static_cast<StrokePhase>(k));
    r.low = r.high = k;
    r.samples = phase[k].n;
    r.rms = std::sqrt(phase[k].sum_squares / phase[k].n);
    r.mean_residual = phase[k].sum / phase[k].n;
    if (made[k].n > 0) {
      r.made_rms = std::sqrt(made[k].sum_squares / made[k].n);
      r.made_mean_residual = made[k].sum / made[k].n;
    }
    regions.push_back(r);
  }
  return regions;
}

// The worst regions with at least 1 % of the samples, worst first, each dimension once, judged by the error
// the model makes there (the restarted model's), not by what the free run carries into them.
std::vector<std::string> worstRegions(const ModelAssessment& a) {
  const auto judged = [](const RegionError& r) { return std::isfinite(r.made_rms) ? r.made_rms : r.rms; };
  std::vector<const RegionError*> regions;
  for (const auto* list : {&a.by_phase, &a.by_pressure, &a.by_velocity, &a.by_opening}) {
    const RegionError* worst = nullptr;
    for (const auto& r : *list) {
      if (r.samples >= 0.01 * a.samples && (!worst || judged(r) > judged(*worst))) worst = &r;
    }
    if (worst) regions.push_back(worst);
  }
  std::sort(regions.begin(), regions.end(), [&](const auto* x, const auto* y) { return judged(*x) > judged(*y); });
  std::vector<std::string> sentences;
  for (const auto* r : regions) {
    const bool made = std::isfinite(r->made_rms);
    const double rms = made ? r->made_rms : r->rms;
    const double mean = made ? r->made_mean_residual : r->mean_residual;
    const std::string within = made ? formatted(FMT_STRING(" within {:.0f} ms of the measurement"),
                                                1e3 * ModelAssessment::kMadeHorizon)
                                    : "";
    const bool biased = std::abs(mean) > 0.5 * rms;
    sentences.push_back(
        biased ? std::string("the model ") + (mean > 0 ? "under" : "over") + "-predicts the pressure " +
                     where(*r) + " by " + formatted(FMT_STRING("{:.1f} bar"), std::abs(mean) * 1e-5) +
                     " on average" + within + " (" + formatted(FMT_STRING("{:.1f} bar rms"), rms * 1e-5) + ")"
               : "the model misses the pressure " + where(*r) + " by " +
                     formatted(FMT_STRING("{:.1f} bar rms"), rms * 1e-5) + within + ", in both directions");
  }
  return sentences;
}

}  // namespace

ModelAssessment assessModel(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                            const HydraulicModel& model, const ParameterVector& parameters,
                            double min_pressure) {
  ModelAssessment a;
  // The statistics are accumulated sample by sample; only every kModelledStride-th free-run value is kept
  // (the comparison series that is written), so that an hour's assessment does not hold 1.8 M values.
  a.modelled.reserve(grid.size() / ModelAssessment::kModelledStride + 1);
  RegionBins pressure("pressure", {-1e5, 20e5, 50e5, 100e5, 150e5, 200e5, 400e5, 2000e5}, 1e-5, "bar");
  RegionBins velocity("velocity", {-10, -0.1, -0.02, -0.002, 0.002, 0.02, 0.1, 10}, 1.0, "m/s");
  RegionBins opening("opening", {-1.0, -0.5, -0.2, -0.05, 0.0, 0.05, 0.2, 0.5, 1.0 + 1e-9}, 1.0, "");
  Accumulator made[kStrokePhaseCount];
  const std::vector<float> made_error =
      errorsMadeWithinHorizon(grid, strokes, model, parameters, min_pressure, made);
  FreeRunPressure free_run(model, min_pressure);
  Accumulator all, phase[kStrokePhaseCount];
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const double p = free_run.step(grid[i], parameters, i + 1 < grid.size() ? &grid[i + 1] : nullptr);
    const bool compared = std::isfinite(p) && !free_run.anchoredThisStep() && std::isfinite(grid[i].p);
    if (i % ModelAssessment::kModelledStride == 0)
      a.modelled.push_back(compared ? static_cast<float>(p) : std::numeric_limits<float>::quiet_NaN());
    if (!compared) continue;
    const GridSample& g = grid[i];
    const double e = g.p - p;
    all.add(e);
    phase[static_cast<int>(strokes.phase[i])].add(e);
    pressure.add(g.p, e, made_error[i]);
    velocity.add(g.v, e, made_error[i]);
    opening.add(g.y, e, made_error[i]);
  }
  a.samples = all.n;
  a.simulation_error_rms = all.n > 0 ? std::sqrt(all.sum_squares / all.n) : 0.0;
  a.by_phase = phaseRegions(phase, made);
  a.by_pressure = pressure.regions();
  a.by_velocity = velocity.regions();
  a.by_opening = opening.regions();
  a.worst_regions = worstRegions(a);
  return a;
}

}  // namespace die_cushion_ident
