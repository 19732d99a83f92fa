// A plant that changes while the node watches it (issue 47, item 5): the live ranking used to average the
// cycles before and after a leak began and named it only once its 30 s window had filled with the leaking
// cycles. LiveChangePoint checks the window after every press cycle with the offline onset's test, names the
// effect and the cycle it began in, and the ranking then judges the cycles since. Measured here as press
// cycles from the onset to the first ranking that names it, on the simulator fed through the node's
// pipeline, on two press classes and two effects; and no change on steady plants.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "die_cushion_ident/core/adequacy/model_assessment.h"
#include "die_cushion_ident/core/model/effect_library.h"
#include "die_cushion_ident/core/monitoring/live_model_monitor.h"
#include "die_cushion_ident/core/simulation/press_class.h"
#include "simulation_fixtures.h"

namespace die_cushion_ident {
namespace {

/// A plant of `press` fed through the node's pipeline into a monitor with the node's ranking window and
/// period (30 s, 10 s), the model as configured without effects; `effect` acts from `onset_cycle` on (not at
/// all when negative).
struct ChangingPlant {
  ChangingPlant(PressClass press, const std::string& effect, std::uint64_t variation)
      : plant(
            pressClassPlant(press, variation,
                            effect.empty() ? std::vector<std::string>{} : std::vector<std::string>{effect})),
        simulator(plant),
        config(testing::configFor(plant, {})),
        pipeline(config),
        monitor(config, pipeline.identifier().model(), LiveMonitorSettings{}) {
    // The checks and rankings take milliseconds on their threads, the simulation runs many times faster than
    // the press: each is waited for, so that its result comes with the next grid sample, as it would on the
    // press within a few of them (their durations are reported with the figures).
    pipeline.setGridCallback([this](const GridSample& g, const HydraulicIdentifier& identifier) {
      if (auto r = monitor.addSample(g, identifier)) rankings.push_back({g.t, *r});
      monitor.waitForJobs();
      if (std::isfinite(monitor.changePoint().lastCheckSeconds()))
        longest_check = std::max(longest_check, monitor.changePoint().lastCheckSeconds());
    });
    if (!effect.empty()) {
      parameter = makeLibraryEffect(effect)->parameterFor(plant.geometry).name;
      acting_value = simulator.trueParameter(parameter);
    }
  }
  double cycle() const { return simulator.program().cycleDuration(); }
  /// Runs `cycles` press cycles with the effect acting or not.
  void run(double cycles, bool acting) {
    if (!parameter.empty()) simulator.setTrueParameter(parameter, acting ? acting_value : 0.0);
    testing::feed(simulator, pipeline, cycles * cycle());
  }
  /// The first ranking that carries a change, or null.
  const std::pair<double, LiveRanking>* firstChange() const {
    for (const auto& r : rankings) {
      if (r.second.onset) return &r;
    }
    return nullptr;
  }

  SimulatorConfig plant;
  DieCushionSimulator simulator;
  IdentificationConfig config;
  IdentificationPipeline pipeline;
  LiveModelMonitor monitor;
  std::string parameter;
  double acting_value = 0.0;
  std::vector<std::pair<double, LiveRanking>> rankings;  // [s] the grid time it was returned at, the ranking
  double longest_check = 0.0;                            // [s] wall-clock, of the change checks
};

struct Case {
  PressClass press;
  const char* effect;
};

// The window (30 s) holds at least 6 cycles of every class before the change, so the test can see it; the
// effect starts at a cycle's start (its rest), and acts from that cycle's impact on.
constexpr int kCyclesBefore = 12;
// A change is named once two cycles after it are complete (two cycles each side of a step, as offline), the
// check and the ranking after it running on their own threads: within 3 cycles of the onset (issue 47).
constexpr double kMaxCyclesToName = 3.0;
// Enough for the periodic ranking (every 10 s) to judge the cycles since on the slower presses as well.
constexpr double kCyclesAfter = 8.0;

TEST(LiveChangePoint, AnEffectThatBeginsMidRunIsNamedWithItsCycleWithinThreeCycles) {
  // Leakage on every class; a tank pressure and a valve overlap on the paper's press and the fast one. (Air
  // is named on some presses only: its step in the one-cycle fits stays below the live threshold on the fast
  // mechanical press, doc/ros_interface.md.)
  for (const Case c :
       {Case{PressClass::kSlowHydraulic, "leakage"}, Case{PressClass::kFastMechanical, "leakage"},
        Case{PressClass::kSmallStiff, "leakage"}, Case{PressClass::kLargeSoft, "leakage"},
        Case{PressClass::kSlowHydraulic, "tank_pressure"}, Case{PressClass::kFastMechanical, "tank_pressure"},
        Case{PressClass::kSlowHydraulic, "valve_overlap"},
        Case{PressClass::kFastMechanical, "valve_overlap"}}) {
    const std::string what = std::string(pressClassName(c.press)) + ", " + c.effect;
    ChangingPlant live(c.press, c.effect, 1);
    live.run(kCyclesBefore, false);
    EXPECT_EQ(live.firstChange(), nullptr) << what << ": a change claimed before the plant changed";
    const double onset_time = live.simulator.state().t;
    live.run(kCyclesAfter, true);
    const auto* named = live.firstChange();
    if (!named) {
      for (const auto& [t, r] : live.rankings) std::printf("%.1f: %s\n", t, r.result.conclusion.c_str());
    }
    ASSERT_NE(named, nullptr) << what << ": not named within " << kCyclesAfter << " cycles";
    const LiveOnset& onset = *named->second.onset;
    EXPECT_EQ(onset.onset.effect, c.effect) << what << ": " << onset.onset.explanation;
    // The named cycle is the first the effect acts in: its impact after the onset, within the cycle.
    EXPECT_GE(onset.stamp, onset_time) << what << ": named before it began; " << onset.onset.explanation;
    EXPECT_LT(onset.stamp, onset_time + live.cycle()) << what << ": " << onset.onset.explanation;
    EXPECT_EQ(onset.onset.cycle, kCyclesBefore) << what << ": cycles count from the first impact seen, 0";
    const double cycles_to_name = (named->first - onset_time) / live.cycle();
    EXPECT_LE(cycles_to_name, kMaxCyclesToName) << what;
    // The ranking that names it judged only the cycles since.
    EXPECT_LE(named->second.cycles, 3) << what;
    EXPECT_NE(named->second.result.conclusion.find(std::string(c.effect) + " from press cycle"),
              std::string::npos)
        << named->second.result.conclusion;
    // The ranking on the cycles since, once it has enough of them, with the effect its missing step.
    double cycles_to_missing = NAN;
    for (const auto& [t, r] : live.rankings) {
      if (r.onset && !r.result.steps.empty() && r.result.steps.front().add == c.effect) {
        cycles_to_missing = (t - onset_time) / live.cycle();
        break;
      }
    }
    std::printf(
        "[ measured ] %s: named %.2f cycles after the onset (cycle %.2f s; check %.0f ms at most, "
        "ranking %.0f ms), onset cycle %d, t = %.1f, p = %.2g; ranked missing after %.2f cycles\n",
        what.c_str(), cycles_to_name, live.cycle(), 1e3 * live.longest_check, 1e3 * named->second.seconds,
        onset.onset.cycle, onset.onset.t_statistic, onset.onset.p_value, cycles_to_missing);
    live.monitor.resync();
    EXPECT_FALSE(live.monitor.changePoint().onset()) << what << ": a bag that restarts forgets its change";
    EXPECT_EQ(live.monitor.changeWithinWindow(), nullptr) << what;
  }
}

// Edge cases of the check itself: nothing to check, too few cycles, impacts that do not match the window's.
TEST(LiveChangePoint, ACheckWithoutEnoughCyclesNamesNothing) {
  const SimulatorConfig plant = pressClassPlant(PressClass::kSlowHydraulic, 1, {"leakage"});
  const IdentificationConfig config = testing::configFor(plant, {});
  EXPECT_FALSE(LiveChangePoint::check({}, config, {}, 0, 0.0)) << "empty window";
  const testing::Recording five = testing::record(plant, 5);
  std::vector<double> impacts;
  for (std::size_t i : five.strokes.cycle_start) impacts.push_back(five.grid[i].t);
  EXPECT_FALSE(LiveChangePoint::check(five.grid, config, impacts, 0, 0.0))
      << "5 cycles: fewer than the onset's test needs (" << kOnsetMinimumCycles << ")";
  EXPECT_FALSE(LiveChangePoint::check(five.grid, config, {}, 0, 0.0)) << "no impact to number the cycles by";
}

TEST(LiveChangePoint, NoChangeOnASteadyPlant) {
  for (const PressClass press : {PressClass::kSlowHydraulic, PressClass::kFastMechanical}) {
    for (const char* effect : {"", "leakage"}) {
      ChangingPlant live(press, effect, 2);
      live.run(25.0, true);
      const auto* claimed = live.firstChange();
      EXPECT_EQ(claimed, nullptr) << pressClassName(press) << ", " << effect << ": "
                                  << claimed->second.onset->onset.explanation;
      EXPECT_GE(live.rankings.size(), 2u) << "the ranking goes on";
    }
  }
}

}  // namespace
}  // namespace die_cushion_ident
