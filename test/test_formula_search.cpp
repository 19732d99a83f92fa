// Issue 12's acceptance for the formula search, on random simulated plants with realistic sensor noise:
// four effects outside the library (doc/formula_search.md) are each proposed on the right signal, with
// the breakpoint within 10 % of the truth, and as a custom effect lower the held-out free-run error at
// least five-fold or to within three times the sensor noise; clean data and data with a library effect get
// no proposal called missing.
#include <gtest/gtest.h>

#include <cmath>

#include "die_cushion_ident/core/formula_search.h"
#include "simulation_fixtures.h"

namespace die_cushion_ident {
namespace {

struct Recording {
  SimulatorConfig plant;
  std::vector<GridSample> grid;
  StrokeSegmentation strokes;
};

Recording record(const SimulatorConfig& plant, int cycles = 8) {
  Recording r;
  r.plant = plant;
  DieCushionSimulator simulator(plant);
  std::vector<SimulatedMeasurement> messages;
  simulator.run(cycles * simulator.program().cycleDuration(), &messages);
  UniformResampler resampler({});
  for (const auto& m : messages) resampler.push(m.stream, m.sample, &r.grid);
  resampler.flush(&r.grid);
  r.strokes = segmentStrokes(r.grid);
  return r;
}

struct OutOfLibrary {
  const char* name;
  const char* truth;       // the plant's law, NAME=EXPR
  const char* parameter;   // NAME_theta
  double theta;
  char signal;             // the signal the proposal must use
  double breakpoint;       // NaN: none
};

std::ostream& operator<<(std::ostream& out, const OutOfLibrary& e) { return out << e.name; }

class OutOfLibraryEffect : public ::testing::TestWithParam<OutOfLibrary> {};

TEST_P(OutOfLibraryEffect, IsProposedOnTheRightSignalAndProvenOnHeldOutCycles) {
  const OutOfLibrary& effect = GetParam();
  for (std::uint64_t seed : {21, 22}) {
    SCOPED_TRACE(std::string(effect.name) + ", seed " + std::to_string(seed));
    SimulatorConfig plant = testing::randomPlant(seed);
    plant.custom_effects = {effect.truth};
    plant.parameters[effect.parameter] = effect.theta;
    const Recording r = record(plant);
    const IdentificationConfig config = testing::configFor(r.plant, {});
    const EffectRankingResult ranking = rankEffects(r.grid, r.strokes, config);
    const std::vector<FormulaProposal> proposals =
        proposeFormulas(r.grid, r.strokes, config, ranking.recommended_held_out, 0.0);
    ASSERT_FALSE(proposals.empty());
    { IdentificationConfig t = config; t.custom_effects = {effect.truth};
      std::printf("DBG truth held-out %.3g bar, base %.3g bar, noise %.3g\n", heldOutErrors(r.grid, r.strokes, t, r.strokes.cycles/2).rms*1e-5, ranking.recommended_held_out.rms*1e-5, ranking.noise_rms*1e-5); }
    const FormulaProposal& top = proposals.front();
    for (const auto& p : proposals) {
      std::printf("  %s  %s reduction %.3f held-out %.3g bar  %s\n", p.spec().c_str(), p.verdict.c_str(),
                  p.error_reduction, p.held_out_error_rms * 1e-5, p.explanation.c_str());
    }
    EXPECT_EQ(top.signal, effect.signal) << top.spec();
    EXPECT_EQ(top.verdict, "missing") << top.explanation;
    if (!std::isnan(effect.breakpoint)) {
      EXPECT_NEAR(top.breakpoint / effect.breakpoint, 1.0, 0.10) << top.spec();
    }
    const double noise = r.plant.sensors.pressure_noise;
    EXPECT_TRUE(top.held_out_error_rms * 5.0 <= ranking.recommended_held_out.rms ||
                top.held_out_error_rms <= 3.0 * noise)
        << top.held_out_error_rms << " Pa against " << ranking.recommended_held_out.rms << " Pa before";
  }
}

INSTANTIATE_TEST_SUITE_P(
    Simulated, OutOfLibraryEffect,
    ::testing::Values(
        // A pressure relief valve cracking at 140 bar: a flow in p beyond a threshold.
        OutOfLibrary{"relief_valve", "relief_valve=max(p-140e5,0)", "relief_valve_theta", 3e-10, 'p', 140e5},
        // A groove the piston seal passes at 120 mm of stroke: a pressure-driven leak beyond x0.
        OutOfLibrary{"seal_groove", "seal_groove=p*(x>0.12)", "seal_groove_theta", 3e-11, 'x', 0.12},
        // A notch in the spool: the drain edge passes more oil beyond 30 % opening.
        OutOfLibrary{"spool_notch", "spool_notch=max(y-0.3,0)*sqrt(max(p,0))", "spool_notch_theta", 3e-6, 'y', 0.3},
        // A spring-loaded accumulator that takes oil above 80 bar: a compliance switching in at p0.
        OutOfLibrary{"spring_accumulator", "spring_accumulator=dp*(p>80e5)", "spring_accumulator_theta", 6e-12,
                     'p', 80e5}),
    [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace die_cushion_ident
