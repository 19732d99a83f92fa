#include "die_cushion_ident/core/adequacy/effect_ranking.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <tuple>
#include <utility>

#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/model/effect_library.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "die_cushion_ident/core/util/parallel_for.h"

namespace die_cushion_ident {

namespace {

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

struct Judged {
  CandidateEffect candidate;
  HeldOutErrors held_out;
  std::string physics;  // what the effects are, for explanations written after the round's correction
};

// Holm's correction over a round: a `missing` verdict whose test is not significant once corrected for
// the number of extensions tried becomes `inconclusive` (four candidates at 5 % each would otherwise
// raise a false alarm on 18.5 % of clean recordings).
void correctForMultipleTests(std::vector<Judged>& round, const EffectRankingOptions& options) {
  std::vector<double> p_values;
  for (const auto& j : round) p_values.push_back(j.candidate.p_value);
  const std::vector<bool> rejected = holmRejected(p_values, options.significance);
  for (std::size_t i = 0; i < round.size(); ++i) {
    CandidateEffect& c = round[i].candidate;
    if (c.verdict != Verdict::kMissing) continue;
    const std::string demoted = holmDemotion(c.error_reduction, c.p_value, rejected[i], round.size(), "extensions");
    if (demoted.empty()) continue;
    c.verdict = Verdict::kInconclusive;
    c.explanation = round[i].physics + demoted;
  }
}

// `model` extended by the library effects `names`, judged against the held-out errors `base` of `model`.
Judged judgeExtension(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                      const IdentificationConfig& model, const std::vector<std::string>& names,
                      const HeldOutErrors& base, bool enough, const EffectRankingOptions& options) {
  Judged judged;
  CandidateEffect& candidate = judged.candidate;
  candidate.effect = names.front();
  IdentificationConfig extended = model;
  std::string physics, implausible;
  std::vector<ParameterInfo> infos;
  std::vector<std::unique_ptr<Effect>> effects;
  for (const auto& name : names) {
    extended.effects.push_back(name);
    effects.push_back(makeLibraryEffect(name, model.oil));
    infos.push_back(effects.back()->parameterFor(model.geometry));
  }
  // The effects' parameters fitted on all the cycles, in physical units: combined from the two held-out
  // folds' fits (a third of the ranking's work saved), which run side by side unless one job is asked for,
  // so that a round of fewer candidates than cores still fills them.
  const bool side_by_side = options.jobs != 1;
  HydraulicEstimate all;
  if (enough) {
    judged.held_out =
        heldOutErrors(grid, strokes, extended, options.split(strokes.cycles), side_by_side, &all, &base);
  } else {
    all = fitOnCycles(grid, strokes, extended, INT_MIN, INT_MAX);
  }
  for (std::size_t e = 0; e < infos.size(); ++e) {
    const ParameterInfo& info = infos[e];
    double fitted = std::numeric_limits<double>::quiet_NaN();
    for (const auto& p : all.parameters) {
      if (p.name != info.name) continue;
      fitted = p.value;
      candidate.parameters.push_back(p);
      if (!(std::isfinite(p.value) && p.value >= info.lower_bound && p.value <= info.upper_bound)) {
        implausible += "; the fit puts " + info.name + " at " + formatted(FMT_STRING("{:.3g}"), p.value) +
                       " " + info.unit + ", outside its physical range: the data do not show this effect";
      }
    }
    // The physics with the fitted value where it says more ("... at -0.41 %/K"), where it is plausible.
    const bool plausible = std::isfinite(fitted) && fitted >= info.lower_bound && fitted <= info.upper_bound;
    physics += (physics.empty() ? "" : "; ") +
               (plausible ? effects[e]->explanationFor(fitted) : effects[e]->explanation());
  }
  // A fit outside the physical range says "not this effect" however few cycles there are.
  if (!enough) {
    candidate.verdict = implausible.empty() ? Verdict::kInconclusive : Verdict::kNotNeeded;
    candidate.explanation = physics + (implausible.empty() ? "; too few complete press cycles (" +
                                                                 std::to_string(strokes.cycles) +
                                                                 ") to judge on held-out cycles"
                                                           : implausible);
    return judged;
  }
  judged.physics = physics;
  const HeldOutComparison test = compareHeldOut(grid, strokes, base, judged.held_out, options.significance);
  candidate.error_reduction = test.error_reduction;
  candidate.t_statistic = test.t_statistic;
  candidate.p_value = test.p_value;
  candidate.held_out_cycles = test.cycles;
  const HeldOutVerdict verdict =
      judgeHeldOut(test, implausible, options, names.size() > 1 ? "together they remove" : "it removes");
  candidate.verdict = verdict.verdict;
  candidate.explanation = physics + verdict.reason;
  return judged;
}

// The library effects `model` does not use and the recording can show: the oil's temperature only where
// one was recorded (without it the effect cannot act, and a recording without the topic is judged as
// before it existed).
std::vector<std::string> unusedLibraryEffects(const IdentificationConfig& model, bool oil_temperature) {
  std::vector<std::string> unused;
  for (const auto& name : libraryEffectNames()) {
    if (!oil_temperature && makeLibraryEffect(name, model.oil)->needsOilTemperature()) continue;
    if (std::find(model.effects.begin(), model.effects.end(), name) == model.effects.end()) {
      unused.push_back(name);
    }
  }
  return unused;
}

// Every library effect that `model` does not use, judged as its extension; most explanatory first.
std::vector<Judged> judgeLibraryEffects(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                        const IdentificationConfig& model, const HeldOutErrors& base,
                                        bool enough, const EffectRankingOptions& options) {
  const std::vector<std::string> names = unusedLibraryEffects(model, oilTemperatureMeasured(grid));
  std::vector<Judged> round(names.size());
  parallelFor(names.size(), options.jobs, [&](std::size_t i) {
    round[i] = judgeExtension(grid, strokes, model, {names[i]}, base, enough, options);
  });
  correctForMultipleTests(round, options);
  std::stable_sort(round.begin(), round.end(), [](const Judged& a, const Judged& b) {
    return a.candidate.error_reduction > b.candidate.error_reduction;
  });
  return round;
}

// Two effects can mask each other (a leakage fitted negative to make up for a back pressure): neither is
// missing alone, both together are. The most explanatory such pair, when there is one, as two candidates:
// first the member that does better alone (with its own numbers), then the other with the pair's.
std::optional<std::pair<Judged, Judged>> bestMissingPair(const std::vector<GridSample>& grid,
                                                         const StrokeSegmentation& strokes,
                                                         const IdentificationConfig& model,
                                                         const HeldOutErrors& base,
                                                         const std::vector<Judged>& singles,
                                                         const EffectRankingOptions& options) {
  const auto alone = [&](const std::string& name) -> const Judged* {
    for (const auto& s : singles) {
      if (s.candidate.effect == name) return &s;
    }
    return nullptr;
  };
  std::vector<std::pair<std::size_t, std::size_t>> indices;
  for (std::size_t i = 0; i < singles.size(); ++i) {
    for (std::size_t j = i + 1; j < singles.size(); ++j) indices.emplace_back(i, j);
  }
  std::vector<Judged> pairs(indices.size());
  parallelFor(indices.size(), options.jobs, [&](std::size_t k) {
    const auto [i, j] = indices[k];
    pairs[k] = judgeExtension(grid, strokes, model, {singles[i].candidate.effect, singles[j].candidate.effect},
                              base, true, options);
  });
  correctForMultipleTests(pairs, options);
  std::optional<Judged> best;
  const Judged* members[2] = {nullptr, nullptr};
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    Judged& pair = pairs[k];
    if (pair.candidate.verdict != Verdict::kMissing) continue;
    if (best && pair.candidate.error_reduction <= best->candidate.error_reduction) continue;
    best = std::move(pair);
    members[0] = alone(singles[indices[k].first].candidate.effect);
    members[1] = alone(singles[indices[k].second].candidate.effect);
    if (members[1]->candidate.error_reduction > members[0]->candidate.error_reduction) {
      std::swap(members[0], members[1]);
    }
  }
  if (!best) return std::nullopt;
  Judged first = *members[0], second = *members[1];
  first.candidate.verdict = Verdict::kMissing;
  first.candidate.explanation += " (only together with '" + second.candidate.effect + "')";
  second.candidate.verdict = Verdict::kMissing;
  second.candidate.error_reduction = best->candidate.error_reduction;
  second.candidate.t_statistic = best->candidate.t_statistic;
  second.candidate.held_out_cycles = best->candidate.held_out_cycles;
  second.candidate.explanation = best->candidate.explanation + " (together with '" + first.candidate.effect + "')";
  for (const auto& p : best->candidate.parameters) {  // each member's parameter as fitted with the other
    for (Judged* m : {&first, &second}) {
      if (!m->candidate.parameters.empty() && m->candidate.parameters.front().name == p.name) {
        m->candidate.parameters.front() = p;
      }
    }
  }
  second.held_out = std::move(best->held_out);
  return std::make_pair(std::move(first), std::move(second));
}

std::string quotedList(const std::vector<EffectStep>& steps) {
  std::string text;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    if (i > 0) text += i + 1 == steps.size() ? " and " : ", ";
    text += "'" + steps[i].add + "'";
  }
  return text;
}

}  // namespace

HeldOutVerdict judgeHeldOut(const HeldOutComparison& test, const std::string& implausible,
                            const EffectRankingOptions& options, const std::string& removes) {
  const std::string reduction = formatted(FMT_STRING("{:.0f} %"), 100.0 * test.error_reduction);
  if (!implausible.empty()) return {Verdict::kNotNeeded, implausible};
  if (test.cycles < options.min_held_out_cycles) {
    return {Verdict::kInconclusive, "; only " + std::to_string(test.cycles) + " held-out cycles"};
  }
  if (test.error_reduction >= options.missing_reduction && test.significant) {
    // The gain in mean square error against the analysis's own: a model that only fits the grid's error
    // better is the product's resolution, not physics.
    const double gain = std::sqrt(std::max(test.base_rms * test.base_rms - test.with_rms * test.with_rms, 0.0));
    if (options.resolution_error > 0.0 && gain <= 2.0 * options.resolution_error) {
      return {Verdict::kInconclusive,
              "; " + reduction + " less held-out error (" + formatted(FMT_STRING("{:.2f} bar"), 1e-5 * gain) +
                  "), but within twice the analysis's own resolution error of " +
                  formatted(FMT_STRING("{:.2f} bar"), 1e-5 * options.resolution_error) +
                  ": resolution-limited" +
                  (options.resolution_remedy.empty() ? std::string() : "; " + options.resolution_remedy)};
    }
    return {Verdict::kMissing, "; " + removes + " " + reduction + " of the free-run error on cycles it was not fitted to"};
  }
  if (test.error_reduction < options.not_needed_reduction) {
    return {Verdict::kNotNeeded, "; it changes the held-out error by only " + reduction};
  }
  return {Verdict::kInconclusive, "; " + reduction +
                                      " less held-out error, but not consistently over the cycles (t = " +
                                      formatted(FMT_STRING("{:.2f}"), test.t_statistic) + ")"};
}

std::string holmDemotion(double error_reduction, double p_value, bool rejected, std::size_t tried,
                         const std::string& what) {
  if (rejected) return "";
  return "; " + formatted(FMT_STRING("{:.0f} %"), 100.0 * error_reduction) +
         " less held-out error, but not significant once corrected for the " + std::to_string(tried) + " " +
         what + " tried (Holm; one-sided p = " + formatted(FMT_STRING("{:.2g}"), p_value) + ")";
}

double structuredErrorFloor(double noise_rms, const EffectRankingOptions& options) {
  // What the noise leaves in a model's own free run, and twice the recording's resolution error (the same
  // margin withinResolution gives it), independent of each other. No absolute bar: 1 bar was 5 x the noise
  // of a press whose leak law the library lacks, and stopped the search there.
  const double resolution = options.resolution_error > 0.0 ? 2.0 * options.resolution_error : 0.0;
  return std::hypot(options.unexplained_noise_factor * noise_rms, resolution);
}

namespace {

// How much of what is left above the noise the recording's own resolution accounts for (a slow topic, the
// grid), where it was measured: a clean fast press without a velocity sensor ran 2.2 times the noise, of
// which 0.35 bar was the derived velocity's as the free run read it then, and "above the noise" alone left
// the user to guess why.
std::string resolutionShareInWords(double error_rms, double noise_rms, const EffectRankingOptions& options) {
  if (!(options.resolution_error > 0.0)) return "";
  const double above_noise = std::sqrt(std::max(error_rms * error_rms - noise_rms * noise_rms, 0.0));
  return formatted(
             FMT_STRING("; of the {:.2f} bar above the noise, the recording's own resolution accounts for "
                        "about {:.2f} bar"),
             1e-5 * above_noise, 1e-5 * std::min(options.resolution_error, above_noise)) +
         (options.resolution_remedy.empty() ? std::string() : " (" + options.resolution_remedy + ")");
}

}  // namespace

std::string errorLeftInWords(double error_rms, double noise_rms, const EffectRankingOptions& options) {
  const double floor = structuredErrorFloor(noise_rms, options);
  const std::string left =
      formatted(FMT_STRING("{:.2f} bar rms left on held-out cycles, {:.1f} x the noise of {:.2f} bar"),
                1e-5 * error_rms, noise_rms > 0.0 ? error_rms / noise_rms : 0.0, 1e-5 * noise_rms);
  if (error_rms <= options.within_noise_factor * noise_rms) return left + ": within the noise";
  const std::string floor_words =
      formatted(FMT_STRING("the {:.2f} bar a model's own free run leaves ({:.0f} x the noise"), 1e-5 * floor,
                options.unexplained_noise_factor) +
      (options.resolution_error > 0.0
           ? formatted(FMT_STRING(", with twice the recording's resolution error of {:.2f} bar)"),
                       1e-5 * options.resolution_error)
           : std::string(")"));
  if (error_rms <= floor)
    return left + ": above the noise, but within " + floor_words + ", too little to search a formula for" +
           resolutionShareInWords(error_rms, noise_rms, options);
  return left + ": above " + floor_words + resolutionShareInWords(error_rms, noise_rms, options);
}

bool withinResolution(double error_rms, double noise_rms, const EffectRankingOptions& options) {
  if (!(options.resolution_error > 0.0)) return false;
  const double structured = std::sqrt(std::max(error_rms * error_rms - noise_rms * noise_rms, 0.0));
  return structured <= 2.0 * options.resolution_error;
}

namespace {

// Where the recording's rates limit the analysis (a remedy was found), what is left may be partly theirs: the
// study measured it on the model as configured, before any effect was added (a fast press with its valve at
// 250 Hz and its overlap named: 14 bar left, "structured", of which the valve's rate alone had been 3.9 bar
// without the overlap).
std::string recordingsOwnShare(const EffectRankingOptions& options) {
  if (options.resolution_remedy.empty() || !(options.resolution_error > 0.0)) return "";
  return " Part of it is the recording's own resolution (" +
         formatted(FMT_STRING("{:.2f} bar"), 1e-5 * options.resolution_error) +
         " measured on the model as configured): " + options.resolution_remedy + ", then judge it again.";
}

// The ranking's conclusion in words, from its steps and what is left.
std::string conclusionOf(const EffectRankingResult& ranking, bool enough, int cycles,
                         const EffectRankingOptions& options) {
  const std::string held_out_path = [&] {
    std::string text = formatted(FMT_STRING("{:.1f}"), ranking.base_error_rms * 1e-5);
    for (const auto& step : ranking.steps)
      text += " -> " + formatted(FMT_STRING("{:.1f}"), step.held_out_error_rms * 1e-5);
    return text + " bar rms on held-out cycles";
  }();
  if (!enough) {
    return "Too few complete press cycles (" + std::to_string(cycles) + ", need " +
           std::to_string(options.min_held_out_cycles) + ") to judge effects on held-out cycles.";
  }
  if (ranking.resolution_limited) {
    return std::string(ranking.steps.empty()
                           ? ""
                           : "Add " + quotedList(ranking.steps) + " (" + held_out_path + "). ") +
           "The error left (" + formatted(FMT_STRING("{:.2f} bar rms"), ranking.best_error_rms * 1e-5) +
           " on held-out cycles, noise " + formatted(FMT_STRING("{:.2f} bar"), ranking.noise_rms * 1e-5) +
           ") is within the analysis's own resolution error (" +
           formatted(FMT_STRING("{:.2f} bar"), options.resolution_error * 1e-5) +
           "): resolution-limited, no effect is named" +
           (options.resolution_remedy.empty() ? std::string(".") : "; " + options.resolution_remedy + ".");
  }
  const std::string left = errorLeftInWords(ranking.best_error_rms, ranking.noise_rms, options);
  if (!ranking.steps.empty() && !ranking.residual_unexplained) {
    return (ranking.steps.size() == 1
                ? "Add the effect " + quotedList(ranking.steps) + ": it explains the remaining error (" +
                      held_out_path + "); "
                : "Add the effects " + quotedList(ranking.steps) +
                      " together: they explain the remaining error (" + held_out_path + "); ") +
           left + ".";
  }
  if (ranking.residual_unexplained) {
    return std::string(ranking.steps.empty() ? "The"
                                             : "Adding " + quotedList(ranking.steps) + " helps (" +
                                                   held_out_path + "), but the") +
           " remaining error (" + formatted(FMT_STRING("{:.1f} bar rms"), ranking.best_error_rms * 1e-5) +
           " on held-out cycles, noise " + formatted(FMT_STRING("{:.2f} bar"), ranking.noise_rms * 1e-5) +
           ") is structured and not explained by the library's effects: describe it with a custom effect "
           "(--custom-effect NAME=EXPR) where the model fails." +
           recordingsOwnShare(options);
  }
  if (ranking.best_error_rms <= options.within_noise_factor * ranking.noise_rms) {
    return "The model explains the measurement to within the noise: no effect is missing (" + left + ").";
  }
  return "Within what a model's own free run leaves, no effect is missing: " + left + ".";
}

}  // namespace

EffectRankingResult rankEffects(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                const IdentificationConfig& config, const EffectRankingOptions& options) {
  EffectRankingResult ranking;
  ranking.noise_rms = config.grid_pressure_noise > 0.0 ? config.grid_pressure_noise : noiseRms(grid);
  const int cycles = strokes.cycles;
  const int split = options.split(cycles);
  const bool enough = split >= 1 && cycles - split >= 1 && cycles >= options.min_held_out_cycles;
  // The folds side by side: nothing else runs yet (one fold after the other left a core idle for 0.7 s/h).
  // The base's free runs kept, so that each extension's own run gives its adjustment (compareHeldOut).
  HeldOutErrors current =
      enough ? heldOutErrorsKept(grid, strokes, config, split, options.jobs != 1) : HeldOutErrors();
  ranking.base_error_rms = current.rms;
  std::vector<Judged> round = judgeLibraryEffects(grid, strokes, config, current, enough, options);
  // The staircase: add the most explanatory missing effect, judge the rest against the extended model,
  // until nothing is missing. Effects that come together (a worn seal and air in the oil) are found in
  // one analysis, each step verified on held-out cycles.
  IdentificationConfig model = config;
  std::vector<CandidateEffect> added;
  const double floor = structuredErrorFloor(ranking.noise_rms, options);
  const auto add = [&](Judged top, const std::string& together_with) {
    model.effects.push_back(top.candidate.effect);
    current = std::move(top.held_out);
    keepPredictions(grid, strokes, &current);
    if (!ranking.steps.empty() && together_with.empty()) {
      top.candidate.explanation += " (after adding " + quotedList(ranking.steps) + ")";
    }
    ranking.steps.push_back({top.candidate.effect, current.rms, together_with});
    added.push_back(std::move(top.candidate));
  };
  while (enough) {
    // Once an effect is in, the model's own free-run floor (2-4 x the sensor noise on simulated plants
    // with the true law) is what is left to explain; another "missing" effect there fits that floor, not
    // physics. So the staircase stops when the error has reached the noise.
    if (!ranking.steps.empty() && current.rms <= options.staircase_noise_factor * ranking.noise_rms) break;
    if (!round.empty() && round.front().candidate.verdict == Verdict::kMissing) {
      add(std::move(round.front()), "");
    } else if (ranking.steps.empty() && current.rms > floor && round.size() >= 2) {
      // Structured error left and no single effect explains it: two that mask each other might. Tried
      // before any step only (each pair costs a candidate's fits; after a step, the formula search is
      // the better use of the time).
      auto pair = bestMissingPair(grid, strokes, model, current, round, options);
      if (!pair) break;
      const std::string first = pair->first.candidate.effect;
      add(std::move(pair->first), "");
      add(std::move(pair->second), first);
    } else {
      break;
    }
    round = judgeLibraryEffects(grid, strokes, model, current, enough, options);
  }
  ranking.candidates = std::move(added);
  for (auto& judged : round) ranking.candidates.push_back(std::move(judged.candidate));
  ranking.best_error_rms = current.rms;
  ranking.recommended_held_out = current;
  ranking.recommended_effects = model.effects;
  ranking.resolution_limited = enough && ranking.best_error_rms > options.staircase_noise_factor * ranking.noise_rms &&
                               withinResolution(ranking.best_error_rms, ranking.noise_rms, options);
  ranking.residual_unexplained = enough && ranking.best_error_rms > floor && !ranking.resolution_limited;
  ranking.conclusion = conclusionOf(ranking, enough, cycles, options);
  return ranking;
}

}  // namespace die_cushion_ident
