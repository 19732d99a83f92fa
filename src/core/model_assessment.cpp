#include "die_cushion_ident/core/model_assessment.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>

#include "die_cushion_ident/core/free_run_pressure.h"
#include "die_cushion_ident/core/stroke_phase_classifier.h"

namespace die_cushion_ident {

namespace {

// A recording's last cycle is complete once the cushion is back within this share of its stroke from
// where the ram met it.
constexpr double kTopTolerance = 0.05;

struct Accumulator {
  int n = 0;
  double sum = 0.0, sum_squares = 0.0;
  void add(double e) {
    ++n;
    sum += e;
    sum_squares += e * e;
  }
};

std::string format(const char* pattern, double a, double b = 0.0) {
  char buffer[128];
  std::snprintf(buffer, sizeof(buffer), pattern, a, b);
  return buffer;
}

// Bins of one signal with fixed edges; labels in the unit users read (bar, m/s, opening).
std::vector<RegionError> binned(const char* dimension, const std::vector<double>& edges, double display_scale,
                                const char* unit, const std::vector<GridSample>& grid,
                                const std::vector<float>& modelled,
                                const std::function<double(const GridSample&)>& of) {
  std::vector<Accumulator> acc(edges.size() - 1);
  for (std::size_t i = 0; i < grid.size(); ++i) {
    if (!std::isfinite(modelled[i])) continue;
    const double value = of(grid[i]);
    if (!std::isfinite(value)) continue;
    const auto it = std::upper_bound(edges.begin(), edges.end(), value);
    if (it == edges.begin() || it == edges.end()) continue;
    acc[it - edges.begin() - 1].add(grid[i].p - modelled[i]);
  }
  std::vector<RegionError> out;
  for (std::size_t b = 0; b < acc.size(); ++b) {
    if (acc[b].n == 0) continue;
    RegionError r;
    r.dimension = dimension;
    r.low = edges[b];
    r.high = edges[b + 1];
    r.label = format("%g", r.low * display_scale) + "..." + format("%g", r.high * display_scale) +
              (unit[0] != '\0' ? std::string(" ") + unit : std::string());
    r.samples = acc[b].n;
    r.rms = std::sqrt(acc[b].sum_squares / acc[b].n);
    r.mean_residual = acc[b].sum / acc[b].n;
    out.push_back(r);
  }
  return out;
}

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
  s.cycle.resize(grid.size());
  StrokePhaseClassifier classifier;
  int cycle = -1;
  // A recording may start mid-stroke: drawing seen first is not an impact, only drawing after a rest of a
  // few samples is (the classifier calls its very first sample rest, whatever the cushion does).
  constexpr int kMinRestSamples = 5;
  StrokePhase previous = StrokePhase::kRest;
  int rest_samples = 0;
  // The last cycle counts when it is complete: the cushion went back up to where the ram met it.
  bool returned = false;
  double impact_x = 0.0, deepest = 0.0, last_x = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t i = 0; i < grid.size(); ++i) {
    if (grid[i].discontinuity) {
      classifier.reset();
      rest_samples = 0;
    }
    const StrokePhase phase = classifier.classify(grid[i]);
    const bool after_rest = previous == StrokePhase::kRest && rest_samples >= kMinRestSamples;
    const bool impact = phase == StrokePhase::kImpact || (phase == StrokePhase::kDrawing && after_rest);
    rest_samples = phase == StrokePhase::kRest ? rest_samples + 1 : 0;
    if (impact && previous != StrokePhase::kImpact && previous != StrokePhase::kDrawing) {
      ++cycle;
      returned = false;
      impact_x = deepest = std::isfinite(grid[i].x) ? grid[i].x : 0.0;
    }
    if (phase == StrokePhase::kReturn) returned = true;
    if (std::isfinite(grid[i].x)) {
      last_x = grid[i].x;
      deepest = std::max(deepest, last_x);
    }
    s.phase[i] = phase;
    s.cycle[i] = cycle;
    previous = phase;
  }
  const double stroke = deepest - impact_x;
  const bool last_complete = cycle >= 0 && returned && stroke > 0.0 &&
                             last_x - impact_x <= kTopTolerance * stroke;
  s.cycles = std::max(last_complete ? cycle + 1 : cycle, 0);
  return s;
}

ModelAssessment assessModel(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                            const HydraulicModel& model, const ParameterVector& parameters,
                            double min_pressure) {
  ModelAssessment a;
  a.modelled.assign(grid.size(), std::numeric_limits<float>::quiet_NaN());
  FreeRunPressure free_run(model, min_pressure);
  Accumulator all, phase[6];
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const double p = free_run.step(grid[i], parameters);
    if (!std::isfinite(p) || free_run.anchoredThisStep() || !std::isfinite(grid[i].p)) continue;
    a.modelled[i] = static_cast<float>(p);
    const double e = grid[i].p - p;
    all.add(e);
    phase[static_cast<int>(strokes.phase[i])].add(e);
  }
  a.samples = all.n;
  a.simulation_error_rms = all.n > 0 ? std::sqrt(all.sum_squares / all.n) : 0.0;
  for (int k = 0; k < 6; ++k) {
    if (phase[k].n == 0) continue;
    RegionError r;
    r.dimension = "phase";
    r.label = strokePhaseName(static_cast<StrokePhase>(k));
    r.low = r.high = k;
    r.samples = phase[k].n;
    r.rms = std::sqrt(phase[k].sum_squares / phase[k].n);
    r.mean_residual = phase[k].sum / phase[k].n;
    a.by_phase.push_back(r);
  }
  a.by_pressure = binned("pressure", {-1e5, 20e5, 50e5, 100e5, 150e5, 200e5, 400e5, 2000e5}, 1e-5, "bar",
                         grid, a.modelled, [](const GridSample& g) { return g.p; });
  a.by_velocity = binned("velocity", {-10, -0.1, -0.02, -0.002, 0.002, 0.02, 0.1, 10}, 1.0, "m/s", grid,
                         a.modelled, [](const GridSample& g) { return g.v; });
  a.by_opening = binned("opening", {-1.0, -0.5, -0.2, -0.05, 0.0, 0.05, 0.2, 0.5, 1.0 + 1e-9}, 1.0, "", grid,
                        a.modelled, [](const GridSample& g) { return g.y; });

  // The worst regions with at least 1 % of the samples, worst first, each dimension once.
  std::vector<const RegionError*> regions;
  for (const auto* list : {&a.by_phase, &a.by_pressure, &a.by_velocity, &a.by_opening}) {
    const RegionError* worst = nullptr;
    for (const auto& r : *list) {
      if (r.samples >= 0.01 * a.samples && (!worst || r.rms > worst->rms)) worst = &r;
    }
    if (worst) regions.push_back(worst);
  }
  std::sort(regions.begin(), regions.end(), [](const auto* x, const auto* y) { return x->rms > y->rms; });
  for (const auto* r : regions) {
    const bool biased = std::abs(r->mean_residual) > 0.5 * r->rms;
    std::string sentence = biased ? std::string("the model ") + (r->mean_residual > 0 ? "under" : "over") +
                                        "-predicts the pressure " + where(*r) + " by " +
                                        format("%.1f bar", std::abs(r->mean_residual) * 1e-5) +
                                        " on average" + " (" + format("%.1f bar rms", r->rms * 1e-5) + ")"
                                  : "the model misses the pressure " + where(*r) + " by " +
                                        format("%.1f bar rms", r->rms * 1e-5) + ", in both directions";
    a.worst_regions.push_back(sentence);
  }
  return a;
}

}  // namespace die_cushion_ident
