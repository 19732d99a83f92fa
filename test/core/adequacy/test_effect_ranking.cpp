// Issue 5's acceptance on simulated data with realistic noise: every library effect hidden in the data is
// found (top candidate, verdict missing, error at least halved, parameter within 25 %); clean data get no
// "missing"; an effect outside the library (a relief valve) is not passed off as a library effect, and a
// custom effect with the right formula halves the error.
#include <gtest/gtest.h>

#include <limits>

#include <algorithm>
#include <boost/math/special_functions/beta.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "die_cushion_ident/core/adequacy/effect_ranking.h"
#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/simulation/press_class.h"
#include "simulation_fixtures.h"

namespace die_cushion_ident {
namespace {

using testing::record;
using testing::Recording;

double freeRunError(const Recording& r, const IdentificationConfig& config) {
  const HydraulicEstimate e = fitOnCycles(r.grid, r.strokes, config, -2, 1 << 30);
  const HydraulicModel model =
      HydraulicModel::fromNames(config.geometry, config.effects, config.custom_effects, config.oil);
  ParameterVector theta(model.parameterCount());
  for (int i = 0; i < model.parameterCount(); ++i) theta(i) = e.parameters[i].value;
  return assessModel(r.grid, r.strokes, model, theta, config.min_pressure).simulation_error_rms;
}

class HiddenEffect : public ::testing::TestWithParam<std::string> {};

TEST_P(HiddenEffect, IsTheTopCandidateMissingAndAddingItHalvesTheError) {
  const std::string effect = GetParam();
  for (std::uint64_t seed : {1, 2, 3}) {
    SCOPED_TRACE(effect + ", seed " + std::to_string(seed));
    const Recording r = record(testing::randomPlant(seed, {effect}));
    const IdentificationConfig base = testing::configFor(r.plant, {});
    const EffectRankingResult ranking = rankEffects(r.grid, r.strokes, base);
    ASSERT_FALSE(ranking.candidates.empty());
    const CandidateEffect& top = ranking.candidates.front();
    EXPECT_EQ(top.effect, effect) << ranking.conclusion;
    EXPECT_EQ(top.verdict, Verdict::kMissing) << top.explanation;
    EXPECT_FALSE(ranking.residual_unexplained) << ranking.conclusion;
    for (std::size_t i = 1; i < ranking.candidates.size(); ++i) {
      EXPECT_NE(ranking.candidates[i].verdict, Verdict::kMissing) << ranking.candidates[i].effect;
    }
    // Its parameter in physical units, within 25 % of the truth.
    ASSERT_EQ(top.parameters.size(), 1u);
    const double truth = r.truth(top.parameters.front().name);
    EXPECT_NEAR(top.parameters.front().value / truth, 1.0, 0.25);
    // Adding it lowers the free-run pressure error at least twofold, on held-out cycles and on all data.
    EXPECT_GT(ranking.base_error_rms, 2.0 * ranking.best_error_rms);
    const IdentificationConfig extended = testing::configFor(r.plant, {effect});
    EXPECT_GT(freeRunError(r, base), 2.0 * freeRunError(r, extended));
  }
}

INSTANTIATE_TEST_SUITE_P(Library, HiddenEffect,
                         ::testing::Values("leakage", "entrained_air", "valve_overlap", "tank_pressure"));

// Issue 12: a worn seal and air in the oil often come together. The staircase adds exactly the hidden
// pair, each step verified on held-out cycles, and the recommended model runs free to within four times
// the sensor noise.
class HiddenPair : public ::testing::TestWithParam<std::pair<std::string, std::string>> {};

TEST_P(HiddenPair, TheStaircaseAddsExactlyBothAndReachesTheNoise) {
  const auto [first, second] = GetParam();
  for (std::uint64_t seed : {11, 12, 13}) {
    SCOPED_TRACE(first + " + " + second + ", seed " + std::to_string(seed));
    const Recording r = record(testing::randomPlant(seed, {first, second}));
    const EffectRankingResult ranking = rankEffects(r.grid, r.strokes, testing::configFor(r.plant, {}));
    ASSERT_EQ(ranking.steps.size(), 2u) << ranking.conclusion;
    std::vector<std::string> added = {ranking.steps[0].add, ranking.steps[1].add};
    std::sort(added.begin(), added.end());
    std::vector<std::string> hidden = {first, second};
    std::sort(hidden.begin(), hidden.end());
    EXPECT_EQ(added, hidden) << ranking.conclusion;
    EXPECT_LT(ranking.steps[1].held_out_error_rms, ranking.steps[0].held_out_error_rms);
    EXPECT_LT(ranking.best_error_rms, 4.0 * r.plant.sensors.pressure_noise) << ranking.conclusion;
    EXPECT_NE(ranking.conclusion.find("together"), std::string::npos) << ranking.conclusion;
    for (std::size_t i = 0; i < ranking.candidates.size(); ++i) {
      EXPECT_EQ(ranking.candidates[i].verdict == Verdict::kMissing, i < 2) << ranking.candidates[i].effect;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Library, HiddenPair,
                         ::testing::Values(std::make_pair("leakage", "entrained_air"),
                                           std::make_pair("leakage", "tank_pressure"),
                                           std::make_pair("entrained_air", "valve_overlap"),
                                           std::make_pair("leakage", "valve_overlap"),
                                           std::make_pair("entrained_air", "tank_pressure"),
                                           std::make_pair("valve_overlap", "tank_pressure")));

// The oil warming by 20 K while it is recorded (issue 46), with a worn seal in the plant and in the model:
// the oil's temperature is named missing with its coefficient near the plant's, and with it added the
// held-out free run is within 2 x the noise and nothing else is missing. Two press classes, two oils.
TEST(EffectRankingResult, AWarmingOilIsNamedMissingAndWithItNothingElse) {
  struct Oil {
    PressClass press;
    double alpha, beta;  // the plant oil's coefficients [1/K]
  };
  for (const Oil& oil :
       {Oil{PressClass::kSlowHydraulic, -0.0045, 0.045}, Oil{PressClass::kSmallStiff, -0.003, 0.045}}) {
    SCOPED_TRACE(pressClassName(oil.press));
    SimulatorConfig plant = pressClassPlant(oil.press, 5, {"leakage", "oil_temperature"}, 21);
    plant.oil.bulk_modulus_coefficient = oil.alpha;
    plant.oil.leakage_coefficient = oil.beta;
    const double duration = 10 * PressCycleProgram(plant.cycle).cycleDuration();
    plant.oil_temperature.start = 38.0;
    plant.oil_temperature.warming_rate = 20.0 / duration;
    const Recording r = record(plant, 10);
    ASSERT_TRUE(oilTemperatureMeasured(r.grid));
    IdentificationConfig model = testing::configFor(plant, {"leakage"});
    double sum = 0.0;
    int n = 0;
    for (const GridSample& g : r.grid) {
      if (std::isfinite(g.T)) sum += g.T, ++n;
    }
    model.oil.temperature_origin = sum / n;  // as the offline analysis centres it
    model.refine_held_out_fits = true;       // and refines the fits by their free run
    const EffectRankingResult ranking = rankEffects(r.grid, r.strokes, model);
    ASSERT_FALSE(ranking.candidates.empty());
    const CandidateEffect& top = ranking.candidates.front();
    EXPECT_EQ(top.effect, "oil_temperature") << ranking.conclusion;
    EXPECT_EQ(top.verdict, Verdict::kMissing) << top.explanation;
    EXPECT_NE(top.explanation.find("the bulk modulus follows the oil temperature at -0."), std::string::npos)
        << top.explanation;
    ASSERT_EQ(top.parameters.size(), 1u);
    // The plant's coefficient is relative to its bulk modulus at 40 degC, the fit's to the one at the mean
    // temperature: alpha / (1 + alpha (T_mean - 40)).
    const double expected = oil.alpha / (1.0 + oil.alpha * (model.oil.temperature_origin - 40.0));
    EXPECT_NEAR(top.parameters.front().value, expected, 0.0008) << "the coefficient within 0.08 %/K";
    ASSERT_EQ(ranking.steps.size(), 1u) << ranking.conclusion;
    EXPECT_LE(ranking.best_error_rms, 2.0 * ranking.noise_rms) << ranking.conclusion;
    for (std::size_t i = 1; i < ranking.candidates.size(); ++i) {
      EXPECT_NE(ranking.candidates[i].verdict, Verdict::kMissing) << ranking.candidates[i].effect;
    }
    // Without the temperature on the grid the effect is not offered at all (a recording without the topic is
    // judged as before the effect existed).
    std::vector<GridSample> without = r.grid;
    for (GridSample& g : without) g.T = std::numeric_limits<float>::quiet_NaN();
    const EffectRankingResult blind = rankEffects(without, r.strokes, model);
    for (const auto& c : blind.candidates) EXPECT_NE(c.effect, "oil_temperature");
  }
}

TEST(EffectRankingResult, CleanDataGetNoMissingVerdict) {
  for (std::uint64_t seed : {1, 2, 3, 4}) {
    const Recording r = record(testing::randomPlant(seed));
    const EffectRankingResult ranking = rankEffects(r.grid, r.strokes, testing::configFor(r.plant, {}));
    for (const auto& c : ranking.candidates) {
      EXPECT_NE(c.verdict, Verdict::kMissing) << "seed " << seed << ": " << c.effect << " " << c.explanation;
    }
    EXPECT_FALSE(ranking.residual_unexplained) << ranking.conclusion;
    EXPECT_NE(ranking.conclusion.find("no effect is missing"), std::string::npos) << ranking.conclusion;
  }
}

TEST(EffectRankingResult, AnEffectOutsideTheLibraryIsReportedAsUnexplainedAndACustomEffectFixesIt) {
  for (std::uint64_t seed : {1, 2}) {
    SimulatorConfig plant = testing::randomPlant(seed);
    // A pressure relief valve cracking at 140 bar, flow proportional to the excess pressure.
    plant.custom_effects = {"relief=max(p-140e5,0)"};
    plant.parameters["relief_theta"] = 3e-10;
    const Recording r = record(plant);
    const IdentificationConfig base = testing::configFor(r.plant, {});
    const EffectRankingResult ranking = rankEffects(r.grid, r.strokes, base);
    EXPECT_TRUE(ranking.residual_unexplained) << ranking.conclusion;
    EXPECT_NE(ranking.conclusion.find("not explained by the library"), std::string::npos)
        << ranking.conclusion;
    IdentificationConfig custom = base;
    custom.custom_effects = {"relief=max(p-140e5,0)"};
    EXPECT_GT(freeRunError(r, base), 2.0 * freeRunError(r, custom));
    const HydraulicEstimate fitted = fitOnCycles(r.grid, r.strokes, custom, -2, 1 << 30);
    EXPECT_NEAR(testing::estimateOf(fitted, "relief_theta") / 3e-10, 1.0, 0.25);
  }
}

// Issue 16: on clean data, the share of recordings in which any candidate is called `missing`, over many
// random plants, is at most the configured significance (Holm's correction keeps the family-wise level;
// the 20 % effect-size threshold adds to it). scripts/false_alarms runs 200 plants; the suite 40.
TEST(EffectRankingResult, FalseAlarmRateOnCleanDataIsAtMostTheSignificance) {
  const char* configured = std::getenv("DCI_FALSE_ALARM_PLANTS");
  const int plants = configured ? std::atoi(configured) : 40;
  ASSERT_GT(plants, 0);
  int alarms = 0;
  double largest_reduction = -1.0;
  for (int i = 0; i < plants; ++i) {
    const std::uint64_t seed = 1000 + static_cast<std::uint64_t>(i);
    const Recording r = record(testing::randomPlant(seed));
    const EffectRankingResult ranking = rankEffects(r.grid, r.strokes, testing::configFor(r.plant, {}));
    bool alarm = false;
    for (const auto& c : ranking.candidates) {
      alarm |= c.verdict == Verdict::kMissing;
      largest_reduction = std::max(largest_reduction, c.error_reduction);
    }
    if (alarm)
      std::printf("  false alarm on plant %llu: %s\n", static_cast<unsigned long long>(seed),
                  ranking.conclusion.c_str());
    alarms += alarm;
  }
  const EffectRankingOptions options;
  const double rate = static_cast<double>(alarms) / plants;
  const double lower = alarms == 0 ? 0.0 : boost::math::ibeta_inv(alarms, plants - alarms + 1, 0.025);
  const double upper = alarms == plants ? 1.0 : boost::math::ibeta_inv(alarms + 1, plants - alarms, 0.975);
  std::printf(
      "false alarms: %d of %d clean recordings (%.1f %%, 95 %% interval %.1f-%.1f %%), significance %.0f %%; "
      "largest error reduction of any candidate %.0f %%\n",
      alarms, plants, 100 * rate, 100 * lower, 100 * upper, 100 * options.significance,
      100 * largest_reduction);
  EXPECT_LE(rate, options.significance);
}

// Too few cycles for a held-out test: nothing is `missing`; a fit outside the physical range still says
// `not_needed` (the data contradict the effect however few cycles there are).
TEST(EffectRankingResult, TooFewCyclesMakeEveryVerdictInconclusive) {
  const Recording r = record(testing::randomPlant(5, {"leakage"}), 2);
  const EffectRankingResult ranking = rankEffects(r.grid, r.strokes, testing::configFor(r.plant, {}));
  for (const auto& c : ranking.candidates) {
    const bool implausible = c.explanation.find("outside its physical range") != std::string::npos;
    EXPECT_EQ(c.verdict, implausible ? Verdict::kNotNeeded : Verdict::kInconclusive)
        << c.effect << ": " << c.explanation;
  }
  EXPECT_NE(ranking.conclusion.find("Too few complete press cycles"), std::string::npos);
}

TEST(ModelAssessment, NamesWhereAMissingLeakageShowsInWords) {
  const Recording r = record(testing::randomPlant(2, {"leakage"}), 4);
  const IdentificationConfig base = testing::configFor(r.plant, {});
  const HydraulicEstimate e = fitOnCycles(r.grid, r.strokes, base, -2, 1 << 30);
  const HydraulicModel model = HydraulicModel::fromNames(base.geometry, {}, {});
  ParameterVector theta(3);
  for (int i = 0; i < 3; ++i) theta(i) = e.parameters[i].value;
  const ModelAssessment a = assessModel(r.grid, r.strokes, model, theta, base.min_pressure);
  ASSERT_FALSE(a.worst_regions.empty());
  // Without the leak the model keeps the pressure up where the real one decays: at the bottom hold.
  const RegionError* hold = nullptr;
  for (const auto& region : a.by_phase) {
    if (region.label == "bottom_hold") hold = &region;
  }
  ASSERT_NE(hold, nullptr);
  EXPECT_LT(hold->mean_residual, 0.0) << "over-predicted";
  EXPECT_GT(hold->rms, a.simulation_error_rms);
  // The stroke phase where the model makes its error: the hold, where only the leak moves the pressure.
  std::string phase_sentence;
  for (const auto& sentence : a.worst_regions) {
    if (sentence.find(" during ") != std::string::npos) phase_sentence = sentence;
  }
  EXPECT_NE(phase_sentence.find("over-predicts the pressure during bottom_hold"), std::string::npos)
      << phase_sentence;
  // 4 strokes, all complete: the recording's last one counts once the cushion is back at the top.
  EXPECT_EQ(r.strokes.cycles, 4);
}

// Issue 26: an error made while drawing is carried through the bottom hold, where the shut valve cannot pull
// the free run back; the free run's error is largest there, but the error is made while drawing, and that is
// where the report says the model fails. A flow gain 5 % high on every press class: the hold's own error (the
// model restarted from the measurement every 50 ms) is under a fifth of the drawing's, and the sentence
// naming a stroke phase names one where the valve is open.
TEST(ModelAssessment, AnErrorMadeWhileDrawingIsNotBlamedOnTheBottomHold) {
  for (PressClass press : allPressClasses()) {
    SCOPED_TRACE(pressClassName(press));
    const SimulatorConfig plant = pressClassPlant(press);
    DieCushionSimulator simulator(plant);
    const std::vector<GridSample> grid = simulateGrid(simulator, 4 * simulator.program().cycleDuration());
    const StrokeSegmentation strokes = segmentStrokes(grid);
    const HydraulicModel model = HydraulicModel::fromNames(plant.geometry, {});
    ParameterVector theta = simulator.trueParameters();
    theta(HydraulicModel::kValveFlowGain) *= 1.05;
    const ModelAssessment a = assessModel(grid, strokes, model, theta, 5e5);
    const RegionError *hold = nullptr, *drawing = nullptr;
    for (const auto& region : a.by_phase) {
      if (region.label == "bottom_hold") hold = &region;
      if (region.label == "drawing") drawing = &region;
    }
    ASSERT_TRUE(hold && drawing);
    EXPECT_GT(hold->rms, 0.8 * drawing->rms) << "the free run carries the drawing's error through the hold";
    EXPECT_LT(hold->made_rms, 0.2 * drawing->made_rms) << "but the hold makes little of it";
    for (const auto& sentence : a.worst_regions) {
      if (sentence.find(" during ") != std::string::npos) {
        EXPECT_EQ(sentence.find("bottom_hold"), std::string::npos) << sentence;
      }
    }
  }
}

}  // namespace
}  // namespace die_cushion_ident

namespace die_cushion_ident {
namespace {

// A candidate's parameters on all cycles come from its two held-out folds' fits combined (information
// added) instead of a third fit. Each fold's grid starts afresh at the seam, so the rows whose windows span
// it (18 of about 1 990 here) are in neither; against the real fit on all cycles every value is within 0.3
// of its std (measured: up to 0.2, the bulk modulus) and every std within 10 % (up to 8 %), for an additive
// effect and for a valve-shape one (relinearised per fold).
// The structured-error floor follows the noise and the recording's own resolution error, no absolute bar
// (issue 47): 1 bar used to be the floor at 0.2 bar of noise, so 1.0 bar left after a library leakage (5 x the
// noise, a sharp-edged leak's) searched no formula, and 0.84 bar at 0.19 bar of noise (4.4 x) was "to within
// the noise". 4 x the noise in quadrature with twice the resolution error; "within the noise" up to 2 x.
TEST(EffectRanking, TheStructuredErrorFloorFollowsTheNoiseAndTheResolutionAndTheWordsSayWhatIsLeft) {
  EffectRankingOptions options;
  EXPECT_NEAR(structuredErrorFloor(0.2e5, options), 0.8e5, 1.0) << "4 x the noise, no 1 bar";
  EXPECT_NEAR(structuredErrorFloor(0.02e5, options), 0.08e5, 1.0) << "a quiet sensor: no absolute bar below";
  options.resolution_error = 0.3e5;
  EXPECT_NEAR(structuredErrorFloor(0.2e5, options), 1.0e5, 1.0) << "hypot(0.8, 2 x 0.3) bar";
  options.resolution_error = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NEAR(structuredErrorFloor(0.2e5, options), 0.8e5, 1.0) << "an unknown resolution adds nothing";

  const EffectRankingOptions plain;
  const std::string structured = errorLeftInWords(0.84e5, 0.19e5, plain);
  EXPECT_EQ(structured.find("within the noise"), std::string::npos) << structured;
  EXPECT_NE(structured.find("4.4 x the noise"), std::string::npos) << structured;
  EXPECT_NE(structured.find("above the 0.76 bar"), std::string::npos) << structured;
  const std::string small = errorLeftInWords(0.6e5, 0.19e5, plain);
  EXPECT_EQ(small.find("within the noise"), std::string::npos) << small;
  EXPECT_NE(small.find("too little to search a formula for"), std::string::npos) << small;
  const std::string noise = errorLeftInWords(0.3e5, 0.19e5, plain);
  EXPECT_NE(noise.find("within the noise"), std::string::npos) << noise;
  EXPECT_EQ(small.find("resolution"), std::string::npos) << "none measured, none named: " << small;

  // Where the recording's own resolution was measured, the words say how much of what is left above the
  // noise it accounts for, and what to record (a clean fast press without a velocity sensor: 0.42 bar at
  // 0.19 bar of noise, 0.35 bar of it the derived velocity's).
  EffectRankingOptions resolved;
  resolved.resolution_error = 0.35e5;
  resolved.resolution_remedy = "record the cushion's velocity with its position (a JointState velocity)";
  const std::string limited = errorLeftInWords(0.42e5, 0.19e5, resolved);
  EXPECT_NE(limited.find("too little to search a formula for"), std::string::npos) << limited;
  EXPECT_NE(limited.find("of the 0.37 bar above the noise, the recording's own resolution accounts for about "
                         "0.35 bar (record the cushion's velocity"),
            std::string::npos)
      << limited;
  // Never more than what is above the noise.
  EffectRankingOptions coarse = resolved;
  coarse.resolution_error = 0.5e5;
  const std::string all = errorLeftInWords(0.45e5, 0.19e5, coarse);
  EXPECT_NE(
      all.find("of the 0.41 bar above the noise, the recording's own resolution accounts for about 0.41 bar"),
      std::string::npos)
      << all;
  EXPECT_EQ(errorLeftInWords(0.3e5, 0.19e5, resolved).find("accounts for"), std::string::npos)
      << "within the noise, nothing to account for";
}

// Holm's step-down over the candidates: the k-th smallest p-value is compared with alpha / (m - k + 1), and
// the first that fails stops the rejections (a smaller alpha / m for the first than Bonferroni's at the end,
// never a later rejection after a kept one).
TEST(EffectRanking, HolmsStepDownRejectsInOrderAndStopsAtTheFirstKept) {
  // 0.005 <= 0.05/4, 0.01 <= 0.05/3, then 0.03 > 0.05/2: stops, and 0.04 is kept though 0.04 < 0.05.
  EXPECT_EQ(holmRejected({0.01, 0.04, 0.03, 0.005}, 0.05), (std::vector<bool>{true, false, false, true}));
  // Both pass their own thresholds (0.001 <= 0.025, 0.02 <= 0.05).
  EXPECT_EQ(holmRejected({0.02, 0.001}, 0.05), (std::vector<bool>{true, true}));
  // Each below alpha, neither below alpha / 2: none (an uncorrected test would reject both).
  EXPECT_EQ(holmRejected({0.03, 0.03}, 0.05), (std::vector<bool>{false, false}));
  // One candidate: the plain level; none: nothing; a NaN p-value is never a rejection.
  EXPECT_EQ(holmRejected({0.049}, 0.05), (std::vector<bool>{true}));
  EXPECT_TRUE(holmRejected({}, 0.05).empty());
  EXPECT_EQ(holmRejected({std::nan(""), 0.001}, 0.05), (std::vector<bool>{false, true}));
}

// The held-out t test's variance counts the fit a fold's cycles share as much as the folds show it: the
// cycles' own spread where the two folds' mean gains agree, the folds' disagreement where it is larger (a
// one-way random-effects model of the folds), and Nadeau and Bengio's bound where only one fold is held out.
TEST(EffectRanking, TheHeldOutTestCountsTheFitAFoldsCyclesShareAsTheFoldsShowIt) {
  HeldOutErrors base, with;
  base.cycle_rms.assign(8, 1.0);
  // No predictions kept: each cycle's gain is 1 - with^2. The first four cycles are one fold, the rest the
  // other.
  const auto gainsOf = [&](const std::vector<double>& gains) {
    with.cycle_rms.clear();
    for (double g : gains) with.cycle_rms.push_back(std::sqrt(1.0 - g));
  };
  const std::vector<GridSample> grid;
  const StrokeSegmentation strokes;

  // Folds that agree (mean 0.25 each): the within-fold variance, 0.1 / 6, alone.
  gainsOf({0.1, 0.2, 0.3, 0.4, 0.4, 0.3, 0.2, 0.1});
  const HeldOutComparison agree = compareHeldOut(grid, strokes, base, with, 0.05);
  EXPECT_EQ(agree.cycles, 8);
  EXPECT_NEAR(agree.t_statistic, -0.25 / std::sqrt(0.1 / 6.0 / 8.0), 1e-9);

  // Folds that disagree (0.25 and 0.65): between them 4 (0.2^2 + 0.2^2) = 0.32 > 0.1 / 6, and for two
  // equal folds the mean's variance is that over n. The naive t would be -5.2, this one is -2.25.
  gainsOf({0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8});
  const HeldOutComparison disagree = compareHeldOut(grid, strokes, base, with, 0.05);
  EXPECT_NEAR(disagree.t_statistic, -0.45 / std::sqrt(0.32 / 8.0), 1e-9);
  EXPECT_GT(disagree.p_value, 0.01);

  // Unequal folds (the first two cycles not run): n = 6, folds of 2 and 4 with means 0.35 and 0.65,
  // within 0.055 / 4, between 2 (0.2)^2 + 4 (0.1)^2 = 0.12, n0 = 6 - 20 / 6, the folds' share 20 / 36.
  with.cycle_rms[0] = with.cycle_rms[1] = std::nan("");
  const HeldOutComparison unequal = compareHeldOut(grid, strokes, base, with, 0.05);
  EXPECT_EQ(unequal.cycles, 6);
  const double within = 0.055 / 4.0, shared = (0.12 - within) / (6.0 - 20.0 / 6.0);
  EXPECT_NEAR(unequal.t_statistic, -0.55 / std::sqrt(within / 6.0 + shared * 20.0 / 36.0), 1e-9);

  // Only the first fold held out: its cycles all share one fit, which cannot be measured; the naive
  // variance doubled (1 + 4 * 4 / (4 * 4)), Nadeau and Bengio's bound.
  gainsOf({0.1, 0.2, 0.3, 0.4, 0.0, 0.0, 0.0, 0.0});
  for (int c = 4; c < 8; ++c) with.cycle_rms[c] = std::nan("");
  const HeldOutComparison one_fold = compareHeldOut(grid, strokes, base, with, 0.05);
  EXPECT_EQ(one_fold.cycles, 4);
  EXPECT_NEAR(one_fold.t_statistic, -0.25 / std::sqrt(0.05 / 3.0 / 4.0 * 2.0), 1e-9);
}

TEST(EffectRanking, TheFoldsCombinedGiveTheFitOnAllCycles) {
  for (const std::string effect : {"leakage", "valve_overlap"}) {
    const SimulatorConfig plant = testing::randomPlant(71, {effect});
    const Recording r = record(plant, 8);
    const IdentificationConfig config = testing::configFor(plant, {effect});
    HydraulicEstimate combined;
    heldOutErrors(r.grid, r.strokes, config, r.strokes.cycles / 2, false, &combined);
    const HydraulicEstimate fitted = fitOnCycles(r.grid, r.strokes, config, 0, r.strokes.cycles - 1);
    ASSERT_EQ(combined.parameters.size(), fitted.parameters.size());
    EXPECT_NEAR(static_cast<double>(combined.updates), static_cast<double>(fitted.updates),
                0.02 * fitted.updates);
    for (std::size_t i = 0; i < fitted.parameters.size(); ++i) {
      const auto& a = combined.parameters[i];
      const auto& b = fitted.parameters[i];
      std::printf("%-14s %-20s combined %.5g +- %.3g, fitted %.5g +- %.3g\n", effect.c_str(), a.name.c_str(),
                  a.value, a.std, b.value, b.std);
      EXPECT_NEAR(a.value, b.value, 0.3 * b.std) << effect << ": " << a.name;
      EXPECT_NEAR(a.std, b.std, 0.1 * b.std) << effect << ": " << a.name;
    }
  }
}

}  // namespace
}  // namespace die_cushion_ident
