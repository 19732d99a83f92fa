#include "study_level.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "die_cushion_ident/core/estimation/identification_pipeline.h"
#include "die_cushion_ident/core/fits/free_run_pressure.h"

namespace die_cushion_ident::settings_detail {

int oddSamples(double seconds, double period, int lowest) {
  int n = static_cast<int>(std::lround(seconds / period));
  if (n % 2 == 0) ++n;
  return std::max(lowest, n);
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  auto middle = values.begin() + values.size() / 2;
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

// The configuration at `period` with the paper's windows in time, no longer than half the shortest drawing;
// the velocity derived (where the position has none) over the same window at every period (a central
// difference over 2 ms samples): a window that shrank with the period made the derived velocity noisier (it
// shapes the stroke phases and the equation-error fit; the free run reads the position's own slope).
IdentificationConfig atPeriod(IdentificationConfig c, double period, double shortest_drawing) {
  c.resampler.sample_period = period;
  c.velocity_window = std::max(c.velocity_window, 2.0 * period);
  c.moving_average_width = oddSamples(kMovingAverageWindow, period, 1);
  c.derivative_width = oddSamples(kDerivativeWindow, period, 3);
  if (shortest_drawing > 0.0) {
    const double span = (c.moving_average_width + c.derivative_width - 1) * period;
    const double allowed = 0.5 * shortest_drawing;
    if (span > allowed) {
      const double shrink = allowed / span;
      c.moving_average_width = oddSamples(shrink * kMovingAverageWindow, period, 1);
      c.derivative_width = oddSamples(shrink * kDerivativeWindow, period, 3);
    }
  }
  c.identification_period = period * std::max(1L, std::lround(kIdentificationPeriod / period));
  return c;
}

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::vector<GridSample> gridAt(const IdentificationConfig& config, const Messages& messages) {
  std::vector<GridSample> grid;
  IdentificationPipeline pipeline(config);
  pipeline.setIdentifying(false);
  pipeline.setGridCallback([&](const GridSample& g, const HydraulicIdentifier&) { grid.push_back(g); });
  for (const auto& [stream, sample] : messages) pipeline.push(stream, sample);
  pipeline.flush();
  return grid;
}

Level levelAt(const IdentificationConfig& config, const Messages& messages) {
  Level level;
  level.period = config.resampler.sample_period;
  level.grid = gridAt(config, messages);
  level.strokes = segmentStrokes(level.grid);
  return level;
}

// The shortest drawing phase (impact included) of the complete cycles [s], 0 where there is none.
double shortestDrawing(const Level& level) {
  double shortest = 0.0;
  for (int c = 0; c < level.strokes.cycles; ++c) {
    const auto [begin, end] = level.strokes.range(c, c);
    std::size_t drawing = 0;
    for (std::size_t i = begin; i < end; ++i) {
      const StrokePhase phase = level.strokes.phase[i];
      drawing += phase == StrokePhase::kDrawing || phase == StrokePhase::kImpact ? 1 : 0;
    }
    const double seconds = drawing * level.period;
    if (seconds > 0.0 && (shortest == 0.0 || seconds < shortest)) shortest = seconds;
  }
  return shortest;
}

// The free run of `theta` on the level's grid.
void runFree(const HydraulicModel& model, const ParameterVector& theta, double min_pressure, Level* level) {
  const std::vector<GridSample>& grid = level->grid;
  FreeRunPressure free_run(model, min_pressure);
  double sum = 0.0;
  std::size_t n = 0;
  level->t.assign(grid.size(), 0.0);
  level->modelled.assign(grid.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const GridSample* next = i + 1 < grid.size() ? &grid[i + 1] : nullptr;
    const double p = free_run.step(grid[i], theta, next);
    level->t[i] = grid[i].t;
    if (!std::isfinite(p) || free_run.anchoredThisStep() || !std::isfinite(grid[i].p)) continue;
    level->modelled[i] = p;
    sum += (grid[i].p - p) * (grid[i].p - p);
    ++n;
  }
  if (n > 0) level->error_rms = std::sqrt(sum / n);
}

// The free run's own numerical error on a level already run: its rms difference from the same run with a
// twenty times tighter tolerance. Only the chosen level's is asked for (the tight run costs more than the
// run itself: it was a third of the study where every level ran it).
double numericalError(const HydraulicModel& model, const ParameterVector& theta, double min_pressure,
                      Level* level) {
  if (!std::isnan(level->numerical_error) || level->modelled.empty()) return level->numerical_error;
  const std::vector<GridSample>& grid = level->grid;
  FreeRunPressure tight(model, min_pressure, FreeRunPressure::kDefaultTolerance / 20.0);
  double difference = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const double q = tight.step(grid[i], theta, i + 1 < grid.size() ? &grid[i + 1] : nullptr);
    const double p = level->modelled[i];
    if (!std::isfinite(p) || !std::isfinite(q)) continue;
    difference += (p - q) * (p - q);
    ++n;
  }
  level->numerical_error = n > 0 ? std::sqrt(difference / n) : std::numeric_limits<double>::quiet_NaN();
  return level->numerical_error;
}

// rms difference of two levels' free runs at the samples both have (the coarser grid's times lie on the
// finer).
double changeBetween(const Level& coarse, const Level& fine, double fine_period) {
  if (fine.t.empty()) return std::numeric_limits<double>::quiet_NaN();
  // Counted in fine periods from the fine grid's first point: a grid whose points lie half a period off k T
  // (grid_phase) put t / period on .5, where rounding paired samples a period apart.
  const double origin = fine.t.front();
  std::unordered_map<long long, double> at;
  at.reserve(fine.t.size());
  for (std::size_t i = 0; i < fine.t.size(); ++i)
    at[std::llround((fine.t[i] - origin) / fine_period)] = fine.modelled[i];
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < coarse.t.size(); ++i) {
    const auto it = at.find(std::llround((coarse.t[i] - origin) / fine_period));
    if (it == at.end()) continue;
    const double d = coarse.modelled[i] - it->second;
    if (!std::isfinite(d)) continue;
    sum += d * d;
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : std::numeric_limits<double>::quiet_NaN();
}

Richardson richardson(double change, double earlier_change) {
  Richardson r;
  if (std::isfinite(earlier_change) && change > 0.0)
    r.order = std::clamp(std::log2(earlier_change / change), 1.0, 4.0);
  r.error = change / (std::pow(2.0, r.order) - 1.0);
  return r;
}

// The message rate [Hz] to record at for a sample interval [s], rounded up to 100 Hz.
double recordingRate(double interval) { return 100.0 * std::ceil(0.01 / interval); }

}  // namespace die_cushion_ident::settings_detail
