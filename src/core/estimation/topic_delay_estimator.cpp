#include "die_cushion_ident/core/estimation/topic_delay_estimator.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "balance_cost.h"
#include "die_cushion_ident/core/signal/white_noise_estimator.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "die_cushion_ident/core/util/parallel_for.h"

namespace die_cushion_ident {

using namespace topic_delay_detail;

namespace {

// The parabola's vertex through three costs `spacing` apart, as an offset from the middle one (0 where they
// are not convex): through their squares, the sum of squares being what is quadratic near the minimum.
double parabolaVertex(double minus, double middle, double plus, double spacing) {
  const double s_minus = minus * minus, s0 = middle * middle, s_plus = plus * plus;
  const double second = s_minus - 2.0 * s0 + s_plus;
  if (!(second > 0.0) || !std::isfinite(second)) return 0.0;
  return spacing * 0.5 * (s_minus - s_plus) / second;
}

struct LineSearch {
  double best = 0.0;  // [samples]
  double best_cost = 0.0;
};

// Minimum of cost(shift) over [-range, range] samples: whole samples, then quarter samples around the best,
// then a parabola through the best three. `costs` gives the costs of a list of shifts (each stage's points
// are independent of each other: they are asked for together, to be evaluated side by side).
template <typename Costs>
LineSearch searchShift(const Costs& costs, double range) {
  // The integer, quarter and parabola points overlap (0, the coarse best, best +- 1/4): each is evaluated
  // once (a third of the search's evaluations on the polishing rounds).
  std::vector<std::pair<double, double>> seen;
  const auto known = [&](double shift, double* value) {
    for (const auto& [at, v] : seen) {
      if (std::abs(at - shift) < 1e-9) {
        *value = v;
        return true;
      }
    }
    return false;
  };
  const auto stage = [&](const std::vector<double>& shifts) {
    std::vector<double> missing;
    double unused;
    for (double shift : shifts) {
      const bool listed =
          std::any_of(missing.begin(), missing.end(), [&](double m) { return std::abs(m - shift) < 1e-9; });
      if (!known(shift, &unused) && !listed) missing.push_back(shift);
    }
    if (!missing.empty()) {
      const std::vector<double> values = costs(missing);
      for (std::size_t i = 0; i < missing.size(); ++i) seen.emplace_back(missing[i], values[i]);
    }
    std::vector<double> out(shifts.size());
    for (std::size_t i = 0; i < shifts.size(); ++i) known(shifts[i], &out[i]);
    return out;
  };
  std::vector<double> whole{0.0};
  for (double shift = -std::floor(range); shift <= range; shift += 1.0) whole.push_back(shift);
  const std::vector<double> whole_costs = stage(whole);
  double best = 0.0, best_cost = whole_costs[0];
  for (std::size_t i = 1; i < whole.size(); ++i) {
    if (whole_costs[i] < best_cost) {
      best_cost = whole_costs[i];
      best = whole[i];
    }
  }
  const double coarse = best;
  std::vector<double> quarters;
  for (double shift = coarse - 0.75; shift <= coarse + 0.75 + 1e-9; shift += 0.25) quarters.push_back(shift);
  const std::vector<double> quarter_costs = stage(quarters);
  for (std::size_t i = 0; i < quarters.size(); ++i) {
    if (quarter_costs[i] < best_cost) {
      best_cost = quarter_costs[i];
      best = quarters[i];
    }
  }
  const std::vector<double> around = stage({best - 0.25, best + 0.25});
  const double f_minus = around[0], f_plus = around[1];
  LineSearch result;
  result.best = best;
  result.best_cost = best_cost;
  result.best = best + parabolaVertex(f_minus, best_cost, f_plus, 0.25);
  return result;
}

}  // namespace

bool TopicDelayEstimate::distinguishable(double sigmas) const {
  if (!valid) return false;
  for (int s = 1; s < kInputStreamCount; ++s) {
    if (std::abs(delays[s]) > sigmas * resolution[s]) return true;
  }
  return false;
}

void addValveModelTiming(const ServoValveParameters& assumed, TopicDelayEstimate* delays) {
  if (!delays->valid || delays->valve_model_timing > 0.0) return;
  constexpr int kValve = static_cast<int>(InputStream::kValve);
  delays->valve_model_timing = assumed.lowFrequencyDelay() / std::sqrt(3.0);
  delays->resolution[kValve] = std::hypot(delays->resolution[kValve], delays->valve_model_timing);
  delays->message +=
      formatted(FMT_STRING("; the valve's offset includes the default valve model's timing error (the spool "
                           "is not measured): +-{:.2f} ms"),
                1e3 * delays->valve_model_timing);
}

std::string valveTimingWarning(double valve_offset, bool corrected) {
  return formatted(
             FMT_STRING(
                 "the valve topic's stamps, or the valve's own timing, are {:+.2f} ms off the default valve "
                 "model's (the spool is not measured, so the two cannot be told apart): "),
             1e3 * valve_offset) +
         (corrected ? "corrected as one" : "not corrected") +
         "; configure the valve from a sweep (valve_dead_time, valve_natural_frequency) to tell them apart";
}

bool TopicDelayEstimate::significant(double sample_period) const {
  if (!valid) return false;
  for (double d : delays) {
    if (std::abs(d) > 0.25 * sample_period) return true;
  }
  return false;
}

namespace {

// The stretch that holds enough usable samples: an hour's grid is 1.8 M samples, the estimate needs a few
// minutes of strokes. Returns its end.
std::size_t usableStretch(const std::vector<GridSample>& grid, const IdentificationConfig& config) {
  std::size_t end = 0, usable = 0;
  while (end < grid.size() && usable < 3 * kMaxSamples) {
    const GridSample& g = grid[end++];
    if (g.complete && g.p >= config.min_pressure && std::abs(g.y) <= config.max_spool_opening) ++usable;
  }
  return end;
}

// Windows (one every `window` samples) where the cushion moves or the pressure changes; the shifts reach
// up to `reach` samples beyond each window's ends. Counts their samples in `excited_samples`.
std::vector<std::size_t> excitedWindows(const Signals& s, std::size_t end, std::size_t window,
                                        std::size_t reach, const IdentificationConfig& config,
                                        std::size_t* excited_samples) {
  const double dt = config.resampler.sample_period;
  std::vector<std::size_t> starts;
  *excited_samples = 0;
  for (std::size_t k = reach; k + window + reach < end && *excited_samples < kMaxSamples; k += window) {
    const double p0 = s.p[k], p1 = s.p[k + window], x0 = s.x[k], x1 = s.x[k + window];
    if (!std::isfinite(p0 + p1 + x0 + x1)) continue;
    // Every shift the search may try must find the window's channels: the cost compares the same rows.
    bool complete = true;
    for (std::size_t j = k - reach; j <= k + window + reach && complete; ++j) {
      complete = std::isfinite(s.x[j]) && std::isfinite(s.y[j]) &&
                 (j < k || j > k + window || std::isfinite(s.p[j]));
    }
    if (!complete) continue;
    const double seconds = window * dt;
    if (std::abs(x1 - x0) < config.min_velocity * seconds &&
        std::abs(p1 - p0) < config.min_pressure_rate * seconds)
      continue;
    starts.push_back(k);
    *excited_samples += window;
  }
  return starts;
}

struct MapPoint {
  double cost, position, valve;
};

// The coarse map's lowest points that are not neighbours of a lower one (at most three): each is refined,
// the lowest refined one wins (on a fast press the true basin is narrower than the map's step, and a
// neighbouring basin could look lower on the map: a 20 ms offset was found at 5.5 ms).
std::vector<MapPoint> coarseBasins(const BalanceCost& coarse, double search_range, double step, int jobs) {
  std::vector<MapPoint> map;
  std::vector<double> shifts;
  for (double shift = -std::floor(search_range / step) * step; shift <= search_range; shift += step)
    shifts.push_back(shift);
  const std::vector<double> map_costs = coarse.costMap(shifts, shifts, jobs);
  for (std::size_t i = 0; i < shifts.size(); ++i) {
    for (std::size_t j = 0; j < shifts.size(); ++j)
      map.push_back({map_costs[i * shifts.size() + j], shifts[i], shifts[j]});
  }
  std::sort(map.begin(), map.end(), [](const MapPoint& a, const MapPoint& b) { return a.cost < b.cost; });
  std::vector<MapPoint> basins;
  for (const MapPoint& candidate : map) {
    if (!std::isfinite(candidate.cost) || basins.size() >= 3) break;
    bool near = false;
    for (const MapPoint& b : basins) {
      near |= std::abs(b.position - candidate.position) <= 1.5 * step &&
              std::abs(b.valve - candidate.valve) <= 1.5 * step;
    }
    if (!near) basins.push_back(candidate);
  }
  if (basins.empty()) basins.push_back({coarse.cost(0.0, 0.0), 0.0, 0.0});
  return basins;
}

struct Refined {
  double position, valve, cost;
};

// The lowest point of the cost on the square of (2 half + 1)^2 pairs of shifts `spacing` apart around
// (position, valve) [samples]; with `vertex`, moved along each offset to the parabola through its
// neighbours where both lie on the square. Each position shift's and each valve shift's parts are made
// once and every pair assembled from blocks (costMap): a square of 11 x 11 costs 22 windows' integrations
// where the line searches of coordinate descent took about three times as many for fewer points.
Refined lowestOnSquare(const BalanceCost& cost, double position, double valve, int half, double spacing,
                       bool vertex) {
  std::vector<double> positions, valves;
  for (int i = -half; i <= half; ++i) {
    positions.push_back(position + i * spacing);
    valves.push_back(valve + i * spacing);
  }
  const std::vector<double> costs = cost.costMap(positions, valves, 1);
  const std::size_t m = valves.size();
  std::size_t best = 0;
  for (std::size_t k = 1; k < costs.size(); ++k) {
    if (costs[k] < costs[best]) best = k;
  }
  const std::size_t i = best / m, j = best % m;
  Refined r{positions[i], valves[j], costs[best]};
  if (!vertex) return r;
  const auto at = [&](std::size_t a, std::size_t b) { return costs[a * m + b]; };
  if (i > 0 && i + 1 < positions.size())
    r.position += parabolaVertex(at(i - 1, j), r.cost, at(i + 1, j), spacing);
  if (j > 0 && j + 1 < m) r.valve += parabolaVertex(at(i, j - 1), r.cost, at(i, j + 1), spacing);
  r.cost = cost.costsAt({{r.position, r.valve}}, 1).front();
  return r;
}

// The costs searchShift asks for along (dx, dv) per unit of shift from (position, valve), read when asked
// (the caller moves them between searches), each stage's points side by side.
auto costsAlong(const BalanceCost& cost, const double& position, const double& valve, double dx, double dv,
                int jobs) {
  return [&cost, &position, &valve, dx, dv, jobs](const std::vector<double>& shifts) {
    std::vector<std::pair<double, double>> pairs;
    for (double shift : shifts) pairs.emplace_back(position + dx * shift, valve + dv * shift);
    return cost.costsAt(pairs, jobs);
  };
}

// One round of coordinate descent from `r` within `range` samples: both offsets together, then position,
// then valve.
Refined refineRound(const BalanceCost& cost, Refined r, double range, int jobs) {
  const LineSearch both = searchShift(costsAlong(cost, r.position, r.valve, 1.0, 1.0, jobs), range);
  r.position += both.best;
  r.valve += both.best;
  r.position += searchShift(costsAlong(cost, r.position, r.valve, 1.0, 0.0, jobs), range).best;
  r.valve += searchShift(costsAlong(cost, r.position, r.valve, 0.0, 1.0, jobs), range).best;
  r.cost = cost.cost(r.position, r.valve);
  return r;
}

// Each basin searched on a square of whole samples as wide as the map's step and a sample more, then on a
// square of quarter samples around its lowest point with the parabolas; the lowest wins. The basins on up
// to `jobs` threads (the squares keep no cache).
Refined refineBasins(const BalanceCost& cost, const std::vector<MapPoint>& basins, double step, int jobs) {
  std::vector<Refined> rounds(basins.size());
  parallelFor(basins.size(), jobs, [&](std::size_t b) {
    const Refined whole =
        lowestOnSquare(cost, basins[b].position, basins[b].valve, static_cast<int>(step) + 1, 1.0, false);
    rounds[b] = lowestOnSquare(cost, whole.position, whole.valve, 3, 0.25, true);
  });
  Refined best{0.0, 0.0, std::numeric_limits<double>::infinity()};
  for (const Refined& r : rounds) {
    if (r.cost < best.cost) best = r;
  }
  // The winner polished by a round of coordinate descent: the offsets' valley runs along the diagonal (a late
  // pressure looks like early position and valve), which the squares' parabolas along each offset cut across
  // (without it a large soft chamber's 20 ms came out 0.34 ms off; with one round or two, 0.20-0.21 ms, as
  // with coordinate descent from every basin).
  best = refineRound(cost, best, 1.0, jobs);
  return best;
}

// The offsets' standard uncertainties: a statistical part as of a least-squares parameter, var(tau) =
// 2 sigma^2 / S''(tau) with S the sum of squares (rows x the squared rms) and sigma^2 its minimum per row,
// inflated by the rows' correlation; and a part of the method, how far the minimum moves with windows
// half as long (what the model does not describe pulls the two differently: on the simulated presses the
// statistical part alone was 0.02-0.05 ms where the offsets were 0.1-0.2 ms off).
void setUncertainties(const BalanceCost& cost, const BalanceCost& half_windows, const Refined& best,
                      double search_range, double dt, int jobs, TopicDelayEstimate& e) {
  const double position = best.position, valve = best.valve;
  const BalanceCost::Fit at_minimum = cost(position, valve, true);
  // The sum of squares' curvature along one offset at the minimum, from samples a quarter, half and a whole
  // sample each side (the widest that is convex): the line search's own parabola can sit on a flat stretch.
  const auto curvature = [&](bool along_position) {
    const double s0 = at_minimum.rms * at_minimum.rms;
    for (double h : {0.25, 0.5, 1.0, 2.0}) {
      const double minus = along_position ? cost.cost(position - h, valve) : cost.cost(position, valve - h);
      const double plus = along_position ? cost.cost(position + h, valve) : cost.cost(position, valve + h);
      const double second = (minus * minus - 2.0 * s0 + plus * plus) / (h * h);
      if (second > 0.0 && std::isfinite(second)) return second;
    }
    return 0.0;
  };
  const auto statistical = [&](bool along_position) {
    const double second = curvature(along_position);
    if (!(second > 0.0) || !(at_minimum.rms > 0.0)) return search_range * dt;
    const double variance = 2.0 * at_minimum.rms * at_minimum.rms / (at_minimum.rows * second);
    return std::sqrt(variance * at_minimum.correlation_factor) * dt;
  };
  double x_half = position, v_half = valve;
  for (int round = 0; round < 2; ++round) {
    x_half += searchShift(costsAlong(half_windows, x_half, v_half, 1.0, 0.0, jobs), 1.0).best;
    v_half += searchShift(costsAlong(half_windows, x_half, v_half, 0.0, 1.0, jobs), 1.0).best;
  }
  // And a floor of an eighth of a sample: the offsets come from interpolating between samples, which on the
  // simulated presses was not finer than that (errors up to 0.23 ms on a 1 ms grid; the two parts above
  // alone covered 70 % of them at two standard uncertainties, with the floor all).
  const double floor = dt / 8.0;
  constexpr int kX = static_cast<int>(InputStream::kPosition), kV = static_cast<int>(InputStream::kValve);
  e.resolution[kX] =
      std::sqrt(std::pow(statistical(true), 2) + std::pow((x_half - position) * dt, 2) + floor * floor);
  e.resolution[kV] =
      std::sqrt(std::pow(statistical(false), 2) + std::pow((v_half - valve) * dt, 2) + floor * floor);
}

}  // namespace

TopicDelayEstimate estimateTopicDelays(const std::vector<GridSample>& grid,
                                       const IdentificationConfig& config, int jobs) {
  TopicDelayEstimate e;
  const double dt = config.resampler.sample_period;
  const std::size_t window = std::max<std::size_t>(2, std::lround(kWindow / dt));
  const std::size_t end = usableStretch(grid, config);
  const Signals s = prepare(grid, end, config);
  const std::size_t reach = static_cast<std::size_t>(std::ceil(config.topic_delay_search / dt)) + 2;
  std::size_t excited_samples = 0;
  std::vector<std::size_t> starts = excitedWindows(s, end, window, reach, config, &excited_samples);
  e.samples = static_cast<int>(excited_samples);
  if (excited_samples < 2000) {
    e.message = "too few samples with the cushion moving or the pressure changing (" +
                std::to_string(excited_samples) + ") to estimate the topics' clock offsets";
    return e;
  }
  // A coarse map over both offsets finds the basins (the offsets interact: a late pressure looks like early
  // position and valve), then squares of shifts around each and a round of coordinate descent on the best
  // refine it on all windows (refineBasins).
  std::vector<std::size_t> coarse_starts;
  // At most kCoarseWindows windows (rounding the stride down took up to twice as many), spread over the
  // stretch, integrated in steps of the map's own step.
  const std::size_t coarse_stride =
      std::max<std::size_t>(1, (starts.size() + kCoarseWindows - 1) / kCoarseWindows);
  for (std::size_t i = 0; i < starts.size(); i += coarse_stride) coarse_starts.push_back(starts[i]);
  WhiteNoiseEstimator pressure_noise(4);
  for (std::size_t i = 2; i < end; ++i) {
    if (std::isfinite(s.p[i - 2] + s.p[i - 1] + s.p[i])) pressure_noise.add(s.p[i - 2], s.p[i - 1], s.p[i]);
  }
  const double step = std::max(1.0, std::round(kCoarseStep / dt));
  const Signals smoothed = smoothedSignals(s, static_cast<std::size_t>(step) | 1u);
  const BalanceCost coarse(smoothed, config, dt, std::move(coarse_starts),
                           pressure_noise.sigma() / std::sqrt(step), kWindow, static_cast<std::size_t>(step));
  // The same windows' first halves, for the method's share of the uncertainty below.
  const BalanceCost half_windows(s, config, dt, starts, pressure_noise.sigma(), 0.5 * kWindow);
  const BalanceCost cost(s, config, dt, std::move(starts), pressure_noise.sigma());
  const double search_range = config.topic_delay_search / dt;
  const Refined best = refineBasins(cost, coarseBasins(coarse, search_range, step, jobs), step, jobs);

  constexpr int kX = static_cast<int>(InputStream::kPosition), kV = static_cast<int>(InputStream::kValve);
  e.delays[kX] = best.position * dt;
  e.delays[kV] = best.valve * dt;
  setUncertainties(cost, half_windows, best, search_range, dt, jobs, e);
  e.valid = std::isfinite(e.delays[kX]) && std::isfinite(e.delays[kV]);
  if (!e.valid) e.message = "the balance could not be fitted at any offset";
  return e;
}

}  // namespace die_cushion_ident
