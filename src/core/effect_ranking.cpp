#include "die_cushion_ident/core/effect_ranking.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>

#include "die_cushion_ident/core/effect_library.h"
#include "die_cushion_ident/core/free_run_pressure.h"

namespace die_cushion_ident {

namespace {

std::string format(const char* pattern, double a) {
  char buffer[96];
  std::snprintf(buffer, sizeof(buffer), pattern, a);
  return buffer;
}

// One-sided 95 % / 97.5 % ... points are not needed: the t quantile for the configured level by
// Cornish-Fisher from the normal quantile (within 1 % for df >= 3).
double tQuantile(double p, int df) {
  // Normal quantile by Acklam's rational approximation (p in (0, 1)).
  const double q = p - 0.5;
  double z;
  if (std::abs(q) < 0.425) {
    const double r = 0.180625 - q * q;
    z = q *
        (((((((2509.0809287301226727 * r + 33430.575583588128105) * r + 67265.770927008700853) * r +
             45921.953931549871457) *
                r +
            13731.693765509461125) *
               r +
           1971.5909503065514427) *
              r +
          133.14166789178437745) *
             r +
         3.387132872796366608) /
        (((((((5226.495278852545925 * r + 28729.085735721942674) * r + 39307.89580009271061) * r +
             21213.794301586595867) *
                r +
            5394.1960214247511077) *
               r +
           687.1870074920579083) *
              r +
          42.313330701600911252) *
             r +
         1.0);
  } else {
    double r = q < 0 ? p : 1.0 - p;
    r = std::sqrt(-std::log(r));
    double v;
    if (r <= 5.0) {
      r -= 1.6;
      v = (((((((7.7454501427834140764e-4 * r + 0.0227238449892691845833) * r + 0.24178072517745061177) * r +
               1.27045825245236838258) *
                  r +
              3.64784832476320460504) *
                 r +
             5.7694972214606914055) *
                r +
            4.6303378461565452959) *
               r +
           1.42343711074968357734) /
          (((((((1.05075007164441684324e-9 * r + 5.475938084995344946e-4) * r + 0.0151986665636164571966) *
                   r +
               0.14810397642748007459) *
                  r +
              0.68976733498510000455) *
                 r +
             1.6763848301838038494) *
                r +
            2.05319162663775882187) *
               r +
           1.0);
    } else {
      r -= 5.0;
      v = (((((((2.01033439929228813265e-7 * r + 2.71155556874348757815e-5) * r + 0.0012426609473880784386) *
                   r +
               0.026532189526576123093) *
                  r +
              0.29656057182850489123) *
                 r +
             1.7848265399172913358) *
                r +
            5.4637849111641143699) *
               r +
           6.6579046435011037772) /
          (((((((2.04426310338993978564e-15 * r + 1.4215117583164458887e-7) * r + 1.8463183175100546818e-5) *
                   r +
               7.868691311456132591e-4) *
                  r +
              0.0148753612908506148525) *
                 r +
             0.13692988092273580531) *
                r +
            0.59983220655588793769) *
               r +
           1.0);
    }
    z = q < 0 ? -v : v;
  }
  const double n = df;
  const double z3 = z * z * z, z5 = z3 * z * z;
  return z + (z3 + z) / (4 * n) + (5 * z5 + 16 * z3 + 3 * z) / (96 * n * n);
}

// Pressure sensor noise from the grid: second differences of a smooth signal are noise (MAD, robust to
// the fast transients at impact and release).
double noiseRms(const std::vector<GridSample>& grid) {
  // At most about 200 000 differences: the median is as good, and an hour's grid needs no 14 MB copy.
  constexpr std::size_t kMostDifferences = 200000;
  const std::size_t stride = std::max<std::size_t>(1, grid.size() / kMostDifferences);
  std::vector<double> d;
  d.reserve(grid.size() / stride + 1);
  for (std::size_t i = 2; i < grid.size(); i += stride) {
    const double v = grid[i].p - 2 * grid[i - 1].p + grid[i - 2].p;
    if (std::isfinite(v) && !grid[i].discontinuity && !grid[i - 1].discontinuity) d.push_back(std::abs(v));
  }
  if (d.empty()) return 0.0;
  auto middle = d.begin() + d.size() / 2;
  std::nth_element(d.begin(), middle, d.end());
  return 1.4826 * *middle / std::sqrt(6.0);
}

struct HeldOut {
  std::vector<double> cycle_rms;  // per held-out cycle, both folds
  double rms = 0.0;
};

// Fit on one half, run free on the other, both ways.
HeldOut heldOutErrors(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                      const IdentificationConfig& config, int split) {
  HeldOut result;
  const HydraulicModel model =
      HydraulicModel::fromNames(config.geometry, config.effects, config.custom_effects);
  double total = 0.0;
  int total_n = 0;
  for (int fold = 0; fold < 2; ++fold) {
    const int fit_first = fold == 0 ? 0 : split, fit_last = fold == 0 ? split - 1 : strokes.cycles - 1;
    const int test_first = fold == 0 ? split : 0, test_last = fold == 0 ? strokes.cycles - 1 : split - 1;
    const HydraulicEstimate e = fitOnCycles(grid, strokes, config, fit_first, fit_last);
    ParameterVector theta(model.parameterCount());
    for (int i = 0; i < model.parameterCount(); ++i) theta(i) = e.parameters[i].value;
    FreeRunPressure free_run(model, config.min_pressure);
    std::vector<double> sum(strokes.cycles, 0.0);
    std::vector<int> count(strokes.cycles, 0);
    const std::size_t stretch_begin = strokes.range(test_first, test_last).first;
    for (int c = test_first; c <= test_last; ++c) {
      const auto [begin, end] = strokes.range(c, c);
      for (std::size_t i = begin; i < end && i < grid.size(); ++i) {
        GridSample g = grid[i];
        if (i == stretch_begin) g.discontinuity = true;  // start anchored at each held-out stretch
        const double p = free_run.step(g, theta);
        if (!std::isfinite(p) || free_run.anchoredThisStep() || !std::isfinite(g.p)) continue;
        sum[c] += (g.p - p) * (g.p - p);
        ++count[c];
      }
    }
    for (int c = test_first; c <= test_last; ++c) {
      if (count[c] == 0) continue;
      result.cycle_rms.push_back(std::sqrt(sum[c] / count[c]));
      total += sum[c];
      total_n += count[c];
    }
  }
  result.rms = total_n > 0 ? std::sqrt(total / total_n) : 0.0;
  return result;
}

}  // namespace

HydraulicEstimate fitOnCycles(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                              const IdentificationConfig& config, int first_cycle, int last_cycle) {
  IdentificationConfig batch = config;
  batch.forgetting_factor = 1.0;  // constant parameters over the whole stretch: least squares
  HydraulicIdentifier identifier(batch);
  // The cycles are one contiguous stretch of the grid.
  const auto [begin, end] = strokes.range(first_cycle, last_cycle);
  for (std::size_t i = begin; i < end && i < grid.size(); ++i) {
    GridSample g = grid[i];
    if (i == begin) g.discontinuity = true;
    identifier.push(g);
  }
  return identifier.estimate();
}

EffectRankingResult rankEffects(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                const IdentificationConfig& config, const EffectRankingOptions& options) {
  EffectRankingResult ranking;
  ranking.noise_rms = noiseRms(grid);
  const int cycles = strokes.cycles;
  const int split = cycles / 2;
  const bool enough = split >= 1 && cycles - split >= 1 && cycles >= options.min_held_out_cycles;
  const HeldOut base = enough ? heldOutErrors(grid, strokes, config, split) : HeldOut();
  ranking.base_error_rms = base.rms;

  for (const auto& name : libraryEffectNames()) {
    if (std::find(config.effects.begin(), config.effects.end(), name) != config.effects.end()) continue;
    CandidateEffect candidate;
    candidate.effect = name;
    IdentificationConfig extended = config;
    extended.effects.push_back(name);
    const auto effect = makeLibraryEffect(name);
    const ParameterInfo info = effect->parameter();
    // The effect's parameter fitted on all the data, in physical units.
    const HydraulicEstimate all = fitOnCycles(grid, strokes, extended, INT_MIN, INT_MAX);
    for (const auto& p : all.parameters) {
      if (p.name == info.name) candidate.parameters.push_back(p);
    }
    const double value = candidate.parameters.empty() ? 0.0 : candidate.parameters.front().value;
    const bool plausible = std::isfinite(value) && value >= info.lower_bound && value <= info.upper_bound;

    if (!enough) {
      candidate.verdict = "inconclusive";
      candidate.explanation = effect->explanation() + "; too few complete press cycles (" +
                              std::to_string(cycles) + ") to judge on held-out cycles";
      ranking.candidates.push_back(candidate);
      continue;
    }
    const HeldOut with = heldOutErrors(grid, strokes, extended, split);
    candidate.held_out_cycles = static_cast<int>(std::min(with.cycle_rms.size(), base.cycle_rms.size()));
    candidate.error_reduction = base.rms > 0.0 ? 1.0 - with.rms / base.rms : 0.0;
    double mean = 0.0, squares = 0.0;
    const int n = candidate.held_out_cycles;
    for (int c = 0; c < n; ++c) {
      const double d = std::log(std::max(with.cycle_rms[c], 1e-9) / std::max(base.cycle_rms[c], 1e-9));
      mean += d / n;
      squares += d * d;
    }
    const double sd = n > 1 ? std::sqrt(std::max(squares - n * mean * mean, 0.0) / (n - 1)) : 0.0;
    candidate.t_statistic = sd > 0.0 ? mean / (sd / std::sqrt(n)) : (mean < 0 ? -1e9 : 1e9);
    const double critical = n > 1 ? tQuantile(1.0 - options.significance, n - 1) : 1e9;

    const std::string reduction = format("%.0f %%", 100.0 * candidate.error_reduction);
    if (!plausible) {
      candidate.verdict = "not_needed";
      candidate.explanation = effect->explanation() + "; the fit puts " + info.name + " at " +
                              format("%.3g", value) + " " + info.unit +
                              ", outside its physical range: the data do not show this effect";
    } else if (n < options.min_held_out_cycles) {
      candidate.verdict = "inconclusive";
      candidate.explanation = effect->explanation() + "; only " + std::to_string(n) + " held-out cycles";
    } else if (candidate.error_reduction >= options.missing_reduction && candidate.t_statistic < -critical) {
      candidate.verdict = "missing";
      candidate.explanation = effect->explanation() + "; it removes " + reduction +
                              " of the free-run error on cycles it was not fitted to";
    } else if (candidate.error_reduction < options.not_needed_reduction) {
      candidate.verdict = "not_needed";
      candidate.explanation = effect->explanation() + "; it changes the held-out error by only " + reduction;
    } else {
      candidate.verdict = "inconclusive";
      candidate.explanation = effect->explanation() + "; " + reduction +
                              " less held-out error, but not consistently over the cycles (t = " +
                              format("%.2f", candidate.t_statistic) + ")";
    }
    ranking.candidates.push_back(candidate);
  }
  std::sort(ranking.candidates.begin(), ranking.candidates.end(),
            [](const auto& a, const auto& b) { return a.error_reduction > b.error_reduction; });

  ranking.best_error_rms = ranking.base_error_rms;
  const CandidateEffect* top = ranking.candidates.empty() ? nullptr : &ranking.candidates.front();
  if (top && top->verdict == "missing")
    ranking.best_error_rms = ranking.base_error_rms * (1.0 - top->error_reduction);
  const double floor = std::max(options.unexplained_noise_factor * ranking.noise_rms, 1e5);
  ranking.residual_unexplained = enough && ranking.best_error_rms > floor;
  if (!enough) {
    ranking.conclusion = "Too few complete press cycles (" + std::to_string(cycles) + ", need " +
                         std::to_string(options.min_held_out_cycles) +
                         ") to judge effects on held-out cycles.";
  } else if (top && top->verdict == "missing" && !ranking.residual_unexplained) {
    ranking.conclusion = "Add the effect '" + top->effect + "': it explains the remaining error (" +
                         format("%.1f", ranking.base_error_rms * 1e-5) + " -> " +
                         format("%.1f bar rms", ranking.best_error_rms * 1e-5) + " on held-out cycles).";
  } else if (ranking.residual_unexplained) {
    ranking.conclusion =
        std::string(top && top->verdict == "missing" ? "Adding '" + top->effect + "' helps, but the"
                                                     : "The") +
        " remaining error (" + format("%.1f bar rms", ranking.best_error_rms * 1e-5) +
        " on held-out cycles, noise " + format("%.2f bar", ranking.noise_rms * 1e-5) +
        ") is structured and not explained by the library's effects: describe it with a custom effect "
        "(--custom-effect NAME=EXPR) where the model fails.";
  } else {
    ranking.conclusion = "The model explains the measurement to within the noise: no effect is missing.";
  }
  return ranking;
}

}  // namespace die_cushion_ident
