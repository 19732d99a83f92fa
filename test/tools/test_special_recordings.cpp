// Recordings without press strokes, analysed by analyze_bag on the default path (the settings chosen from
// the recording, no --fixed-settings), as a user records them with the cushion at rest: a valve command
// step (for the pressure's t63) and a valve sine sweep (for the valve model). Each is recognised as such
// (warning no_press_stroke, no parameters listed, never an "implausible" press model: at rest the bulk
// modulus and the dead volume cannot be told apart) and judged for what it holds (issue 47, item 1).
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bag_analysis.h"
#include "die_cushion_ident/core/simulation/die_cushion_simulator.h"
#include "die_cushion_ident/core/simulation/press_class.h"
#include "die_cushion_ident/core/valve/step_response.h"
#include "tool_runner.h"

namespace die_cushion_ident {
namespace {

const std::string kTools = TOOL_DIR;
const std::string kWork = "/tmp/die_cushion_ident_test_special_recordings";

testing::CommandResult run(const std::string& command) {
  return testing::runCommand(command, kWork + "/last_output.txt");
}

// The true t63 of simulate_bag's step test (the class's nominal press, seed 1): the same plant at rest, its
// own noise-free pressure after the same schedule (0.7 s under the controller, the command held until
// 1.0 s, then stepped for 1.5 s), timed as findStepResponses times the recording.
double trueT63(PressClass press, double step_voltage) {
  SimulatorConfig plant = pressClassPlant(press, 0, {}, 1);
  plant.cycle.rest_time = 1e9;
  DieCushionSimulator cushion(plant);
  std::vector<SimulatedMeasurement> messages;
  std::vector<double> t, p;
  const auto run = [&](double until, bool trace) {
    while (cushion.state().t < until - 1e-12) {
      messages.clear();
      cushion.step(&messages);
      if (trace) {
        t.push_back(cushion.state().t);
        p.push_back(cushion.state().p);
      }
    }
  };
  run(0.7, false);
  cushion.setValveCommandOverride(cushion.state().u);
  run(1.0, false);
  const double start = cushion.state().t, initial = cushion.state().p;
  cushion.setValveCommandOverride(cushion.state().u + step_voltage);
  run(2.5, true);
  return timeTo63Percent(t, p, start, initial, 0.2);
}

class SpecialRecordings : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { std::system(("rm -rf " + kWork + " && mkdir -p " + kWork).c_str()); }

  // simulate_bag with the cushion at rest (no press cycle), then analyze_bag on the default path.
  static testing::BagAnalysis recordAndAnalyze(const std::string& name, const std::string& what) {
    const std::string bag = kWork + "/" + name + ".bag", config = kWork + "/" + name + ".yaml";
    const testing::CommandResult recorded =
        run(kTools + "/simulate_bag " + bag + " --cycles 0 --seed 1 --write-config " + config + " " + what);
    EXPECT_EQ(recorded.status, 0) << recorded.output;
    return testing::analyzeBag(kTools, bag, config, kWork + "/" + name, "", kWork + "/" + name + ".log");
  }

  // Recognised as a recording at rest: exit 5 (the press's comparison and ranking could not run, as the
  // contract says), the warning no_press_stroke, no parameters, no implausible press model.
  static void expectJudgedAsARecordingAtRest(const testing::BagAnalysis& a) {
    ASSERT_TRUE(a.summary) << a.output;
    EXPECT_EQ(a.status, 5) << a.output;
    EXPECT_NE(testing::warningWithCode(a.summary, "no_press_stroke"), "") << a.output;
    EXPECT_EQ(testing::warningWithCode(a.summary, "implausible_parameter"), "") << a.output;
    EXPECT_EQ(a.summary["model"]["parameters"].size(), 0u) << "no press model from a recording at rest";
    const std::string conclusion = a.summary["adequacy"]["conclusion"].as<std::string>("");
    EXPECT_NE(conclusion.find("without press strokes"), std::string::npos) << conclusion;
  }
};

// The open-loop step the issue found lost on the default path (command -0.5 V, 1 kHz topics): t63 within
// 3 % of the plant's noise-free trace (the fixed settings gave 0.3752 s against 0.3743 s), on a slow press
// (t63 ~0.11 s: the paper's 2 ms kept) and a fast one (t63 ~19 ms: the survey takes the 1 ms grid, a tenth
// of it being 1.9 ms; on 2 ms the step was "sampling too coarse").
TEST_F(SpecialRecordings, AStepTestGivesItsT63OnTheDefaultPath) {
  for (const PressClass press : {PressClass::kSlowHydraulic, PressClass::kFastMechanical}) {
    const std::string name = std::string("step_") + pressClassName(press);
    SCOPED_TRACE(name);
    const testing::BagAnalysis a =
        recordAndAnalyze(name, std::string("--step-test -0.5 --press ") + pressClassName(press));
    expectJudgedAsARecordingAtRest(a);
    ASSERT_TRUE(a.summary["step_response"]) << a.output;
    const double t63 = a.summary["step_response"]["t63"].as<double>(), truth = trueT63(press, -0.5);
    const double period = a.summary["settings"]["sample_period"]["value"].as<double>();
    std::printf(
        "%s step test on the default path: t63 %.4f s, noise-free trace %.4f s; sample period %.4g s\n",
        pressClassName(press), t63, truth, period);
    EXPECT_NEAR(t63 / truth, 1.0, 0.03) << "t63 within 3 % of the plant's noise-free trace";
    EXPECT_NEAR(a.summary["step_response"]["step_voltage"].as<double>(), -0.5, 1e-5);
    EXPECT_LE(period, 0.1 * t63) << "the grid resolves the pressure build-up";
    EXPECT_EQ(testing::warningWithCode(a.summary, "sampling_too_coarse"), "");
  }
}

// A sweep with the cushion at rest gives the valve model (the nominal slow press's valve: 80 Hz, D 0.7,
// K 0.1 1/V, 2 ms dead time), as a sweep after press cycles does (test_analyze_bag).
TEST_F(SpecialRecordings, ASweepOnlyRecordingGivesItsValveModelOnTheDefaultPath) {
  const testing::BagAnalysis a = recordAndAnalyze("sweep", "--sweep");
  expectJudgedAsARecordingAtRest(a);
  const YAML::Node& valve = a.summary["valve"];
  ASSERT_TRUE(valve) << a.output;
  std::printf("sweep on the default path: %.2f Hz, D %.3f, K %.4f 1/V, dead time %.2f ms\n",
              valve["natural_frequency"].as<double>(), valve["damping"].as<double>(),
              valve["gain"].as<double>(), 1e3 * valve["dead_time"].as<double>());
  EXPECT_NEAR(valve["natural_frequency"].as<double>(), 80.0, 80.0 * 0.03);
  EXPECT_NEAR(valve["damping"].as<double>(), 0.7, 0.07);
  EXPECT_NEAR(valve["gain"].as<double>(), 0.1, 0.002);
  EXPECT_NEAR(valve["dead_time"].as<double>(), 0.002, 0.3e-3);
  EXPECT_EQ(valve["points"].size(), 16u);
}

}  // namespace
}  // namespace die_cushion_ident
