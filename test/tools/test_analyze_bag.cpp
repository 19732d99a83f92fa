// analyze_bag end to end: bags recorded from the simulator by simulate_bag, the contract's summary.yaml,
// analysis.bag and CSV, the whole story (missing effect found, error falls when it is added), the valve
// section without metadata, and a clear error for every kind of bad input.
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/JointState.h>
#include <std_msgs/Float64.h>
#include <sys/wait.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <random>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "bag_analysis.h"
#include "die_cushion_ident/FrequencyResponse.h"
#include "killed_recording.h"
#include "tool_runner.h"

namespace {

const std::string kTools = TOOL_DIR;
const std::string kWork = die_cushion_ident::testing::workDirectory("test_analyze_bag");

using die_cushion_ident::testing::CommandResult;

CommandResult run(const std::string& command) {
  return die_cushion_ident::testing::runCommand(command, kWork + "/last_output.txt");
}

class AnalyzeBag : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::system(("rm -rf " + kWork + " && mkdir -p " + kWork).c_str());
    // A worn seal, eight press cycles, then the valve sweep at rest.
    ASSERT_EQ(run(kTools + "/simulate_bag " + kWork +
                  "/leak.bag --cycles 8 --plant-effects leakage --sweep --seed 4 "
                  "--set leakage_conductance=1.8e-11")
                  .status,
              0);
  }

  static YAML::Node analyze(const std::string& bag, const std::string& out, const std::string& extra = "") {
    const CommandResult r = run(kTools + "/analyze_bag " + bag + " --out " + out + " " + extra);
    EXPECT_EQ(r.status, 0) << r.output;
    return YAML::LoadFile(out + "/summary.yaml");
  }
};

double parameter(const YAML::Node& parameters, const std::string& name) {
  for (const auto& p : parameters) {
    if (p["name"].as<std::string>() == name) return p["value"].as<double>();
  }
  ADD_FAILURE() << "no parameter " << name;
  return NAN;
}

// The fit by stroke phase; the phase where the missing leak makes its error (within 50 ms of the
// measurement): the bottom hold, where the valve is shut and only the leak moves the pressure.
void expectTheFitByPhaseWithTheLeaksHold(const YAML::Node& s) {
  EXPECT_GT(s["fit"]["samples"].as<int>(), 10000);
  EXPECT_GT(s["fit"]["equation_error_rms"].as<double>(), 0.0);
  std::set<std::string> phases;
  for (const auto& p : s["fit"]["by_phase"]) {
    phases.insert(p["phase"].as<std::string>());
    EXPECT_GT(p["samples"].as<int>(), 0);
    EXPECT_TRUE(p["simulation_error_rms"]);
  }
  EXPECT_EQ(phases, (std::set<std::string>{"rest", "impact", "drawing", "bottom_hold", "release", "return"}));
  ASSERT_GE(s["fit"]["worst_regions"].size(), 1u);
  std::string worst_phase;
  for (const auto& sentence : s["fit"]["worst_regions"]) {
    if (sentence.as<std::string>().find(" during ") != std::string::npos) worst_phase = sentence.as<std::string>();
  }
  EXPECT_NE(worst_phase.find("bottom_hold"), std::string::npos) << worst_phase;
  for (const auto& p : s["fit"]["by_phase"]) EXPECT_TRUE(p["made_error_rms"]) << p["phase"];
}

// The valve, found without metadata, and its model the one the fits judged the port side with.
void expectTheSweepsValve(const YAML::Node& s) {
  ASSERT_TRUE(s["valve"]);
  EXPECT_EQ(s["model"]["valve_model"].as<std::string>(), "sweep");
  EXPECT_NEAR(s["valve"]["natural_frequency"].as<double>(), 80.0, 80.0 * 0.03);
  EXPECT_NEAR(s["valve"]["damping"].as<double>(), 0.7, 0.07);
  EXPECT_NEAR(s["valve"]["gain"].as<double>(), 0.1, 0.002);
  EXPECT_NEAR(s["valve"]["dead_time"].as<double>(), 0.002, 0.3e-3);
  ASSERT_EQ(s["valve"]["points"].size(), 16u);
  for (const auto& p : s["valve"]["points"]) {
    for (const char* key : {"frequency", "magnitude", "phase"}) EXPECT_TRUE(p[key]) << key;
  }
}

TEST_F(AnalyzeBag, SummaryFollowsTheContractAndFindsTheMissingLeakage) {
  const YAML::Node s = analyze(kWork + "/leak.bag", kWork + "/base");
  // model
  ASSERT_TRUE(s["model"]["effects"].IsSequence());
  EXPECT_EQ(s["model"]["effects"].size(), 0u);
  ASSERT_EQ(s["model"]["parameters"].size(), 3u);
  for (const auto& p : s["model"]["parameters"]) {
    for (const char* key : {"name", "value", "std", "unit"}) EXPECT_TRUE(p[key]) << key;
  }
  const double base_error = s["fit"]["simulation_error_rms"].as<double>();
  expectTheFitByPhaseWithTheLeaksHold(s);
  // The settings chosen from the recording, with their reasons.
  ASSERT_TRUE(s["settings"]);
  EXPECT_TRUE(s["settings"]["chosen_from_recording"].as<bool>());
  for (const char* key : {"sample_period", "moving_average_width", "derivative_width", "identification_period",
                          "velocity_window"}) {
    EXPECT_TRUE(s["settings"][key]["value"]) << key;
    EXPECT_FALSE(s["settings"][key]["reason"].as<std::string>().empty()) << key;
  }
  EXPECT_DOUBLE_EQ(s["settings"]["sample_period"]["value"].as<double>(), 0.002) << "the paper's press: the paper's grid";
  // candidates: leakage first and missing, every other one named with a verdict and an explanation
  ASSERT_EQ(s["candidates"].size(), 4u);
  EXPECT_EQ(s["candidates"][0]["effect"].as<std::string>(), "leakage");
  EXPECT_EQ(s["candidates"][0]["verdict"].as<std::string>(), "missing");
  EXPECT_NEAR(parameter(s["candidates"][0]["parameters"], "leakage_conductance") / 1.8e-11, 1.0, 0.25);
  for (const auto& c : s["candidates"]) {
    const std::string verdict = c["verdict"].as<std::string>();
    EXPECT_TRUE(verdict == "missing" || verdict == "not_needed" || verdict == "inconclusive") << verdict;
    EXPECT_FALSE(c["explanation"].as<std::string>().empty());
    EXPECT_TRUE(c["error_reduction"]);
  }
  expectTheSweepsValve(s);

  // Adding the effect: the error falls at least twofold and the leak comes out in physical units.
  const YAML::Node with = analyze(kWork + "/leak.bag", kWork + "/with_leakage", "--effects leakage");
  EXPECT_EQ(with["model"]["effects"][0].as<std::string>(), "leakage");
  EXPECT_LT(2.0 * with["fit"]["simulation_error_rms"].as<double>(), base_error);
  EXPECT_NEAR(parameter(with["model"]["parameters"], "leakage_conductance") / 1.8e-11, 1.0, 0.1);
  for (const auto& c : with["candidates"]) EXPECT_NE(c["verdict"].as<std::string>(), "missing");
}

// Near the spool's kink the fits judge the port side by a valve model, and the free run is driven by its spool
// (doc/equations.md). With a sweep in the recording it is the sweep's; without one, where the spool is
// measured, the one fitted to the recording's operation: either way a configured valve 30 % off in its
// natural frequency changes nothing. Only without a measured spool is the configured model used, and a
// wrong one shows.
TEST_F(AnalyzeBag, TheRecordingsOwnValveModelIsUsedNotTheConfiguredOne) {
  const std::string wrong = kWork + "/wrong_valve.yaml";
  std::ofstream(wrong) << "piston_area: 0.05\nstroke_length: 0.25\nsupply_pressure: 120e5\n"
                          "valve_natural_frequency: 104\nvalve_damping: 0.5\n";
  const auto same_parameters = [](const YAML::Node& a, const YAML::Node& b) {
    double largest = 0.0;
    for (const char* name : {"bulk_modulus", "valve_flow_gain", "dead_volume"}) {
      largest = std::max(largest, std::abs(parameter(a["model"]["parameters"], name) /
                                           parameter(b["model"]["parameters"], name) - 1.0));
    }
    return largest;
  };
  const YAML::Node told = analyze(kWork + "/leak.bag", kWork + "/valve_told", "--config " + wrong);
  const YAML::Node swept = analyze(kWork + "/leak.bag", kWork + "/valve_swept");
  EXPECT_EQ(told["model"]["valve_model"].as<std::string>(), "sweep");
  EXPECT_EQ(swept["model"]["valve_model"].as<std::string>(), "sweep");
  EXPECT_LT(same_parameters(told, swept), 1e-3);

  ASSERT_EQ(run(kTools + "/simulate_bag " + kWork + "/no_sweep.bag --cycles 6 --seed 9").status, 0);
  const YAML::Node operated = analyze(kWork + "/no_sweep.bag", kWork + "/valve_operated", "--config " + wrong);
  const YAML::Node nominal = analyze(kWork + "/no_sweep.bag", kWork + "/valve_nominal");
  EXPECT_EQ(operated["model"]["valve_model"].as<std::string>(), "operation");
  EXPECT_TRUE(operated["settings"]["valve_from_operation"]["used"].as<bool>());
  EXPECT_NEAR(operated["settings"]["valve_from_operation"]["natural_frequency"].as<double>(), 80.0, 4.0);
  EXPECT_LT(same_parameters(operated, nominal), 2e-3) << "the recording's operation, not the configuration";
  EXPECT_NE(
      die_cushion_ident::testing::warningWithCode(operated, "valve_model").find("configured valve model"),
      std::string::npos)
      << "the configured model that does not follow the spool is named";

  ASSERT_EQ(run(kTools + "/simulate_bag " + kWork + "/no_spool.bag --cycles 6 --seed 9 --no-spool").status, 0);
  const YAML::Node configured = analyze(kWork + "/no_spool.bag", kWork + "/valve_configured", "--config " + wrong);
  const YAML::Node right = analyze(kWork + "/no_spool.bag", kWork + "/valve_right");
  EXPECT_EQ(configured["model"]["valve_model"].as<std::string>(), "configured");
  // The wrong valve's timing is taken up by the valve topic's offset (-1.4 ms, 2026-12-07) and the parameters
  // stay within 0.1 %; its free run shows it (10 % more error, the release phase 2.7 times the noise).
  EXPECT_GT(same_parameters(configured, right), 2e-4)
      << "without a measured spool the configured model is the one used";
  EXPECT_GT(configured["fit"]["simulation_error_rms"].as<double>(),
            1.05 * right["fit"]["simulation_error_rms"].as<double>())
      << "the configured model's free run is the worse one";
}

// --fixed-settings has no survey to fit the valve model to the operation: a configured valve model drives
// the free run as it is. A clean fast press analysed with the settings and valve model the survey chose then
// reads as with the survey (before, the measured spool's noise drove it: 3.9 bar against 0.21, and "the
// remaining error is structured"); without a configured valve model the summary says what drives it. The
// clock offsets come from the survey's messages at the finest period they support, not the fixed grid: on
// the paper's 2 ms a clean small stiff press's position came out -0.55 ms, was applied, and its free run ran
// 6.8 times the noise, "structured".
TEST_F(AnalyzeBag, FixedSettingsWithTheChosenValuesReadAsTheSurvey) {
  const std::string bag = kWork + "/fast_fixed.bag", geometry = kWork + "/fast_fixed.yaml";
  for (const char* press : {"small_stiff --variation 1 --seed 1", "fast_mechanical --seed 4"}) {
    SCOPED_TRACE(press);
    ASSERT_EQ(
        run(kTools + "/simulate_bag " + bag + " --cycles 8 --press " + press + " --write-config " + geometry)
            .status,
        0);
    const YAML::Node surveyed = analyze(bag, kWork + "/fast_surveyed", "--config " + geometry);
    const YAML::Node settings = surveyed["settings"];
    const YAML::Node valve = settings["valve_from_operation"];
    ASSERT_TRUE(valve["used"].as<bool>());
    const std::string chosen = kWork + "/fast_chosen.yaml";
    {
      std::ofstream out(chosen);
      out << std::ifstream(geometry).rdbuf();
      for (const char* key : {"sample_period", "moving_average_width", "derivative_width",
                              "identification_period", "velocity_window"})
        out << key << ": " << settings[key]["value"].as<double>() << "\n";
      out << "valve_natural_frequency: " << valve["natural_frequency"].as<double>() << "\n"
          << "valve_damping: " << valve["damping"].as<double>() << "\n"
          << "valve_gain: " << valve["gain"].as<double>() << "\n"
          << "valve_dead_time: " << valve["dead_time"].as<double>() << "\n";
    }
    const YAML::Node fixed = analyze(bag, kWork + "/fast_fixed", "--config " + chosen + " --fixed-settings");
    const double noise = surveyed["adequacy"]["noise_rms"].as<double>();
    EXPECT_LT(surveyed["fit"]["simulation_error_rms"].as<double>(), 2.0 * noise);
    EXPECT_LT(fixed["fit"]["simulation_error_rms"].as<double>(), 2.0 * noise);
    EXPECT_EQ(fixed["adequacy"]["conclusion"].as<std::string>().find("structured"), std::string::npos);
    EXPECT_EQ(fixed["input"]["topic_delays"]["position"].as<double>(), 0.0) << "clean stamps left alone";
    EXPECT_EQ(die_cushion_ident::testing::warningWithCode(fixed, "valve_model"), "");
    EXPECT_EQ(die_cushion_ident::testing::warningWithCode(fixed, "resolution_limited"), "")
        << "1 kHz valve messages";
  }

  const YAML::Node unmodelled =
      analyze(bag, kWork + "/fast_unmodelled", "--config " + geometry + " --fixed-settings");
  EXPECT_NE(
      die_cushion_ident::testing::warningWithCode(unmodelled, "valve_model").find("measured spool drives"),
      std::string::npos);
}

namespace {

// The simulated press's own valve model (simulate_bag --write-truth) appended to its config, as a user gives
// the one a sweep of the valve found.
void configureTheTrueValve(const std::string& truth, const std::string& config) {
  const YAML::Node valve = YAML::LoadFile(truth);
  std::ofstream out(config, std::ios::app);
  for (const char* key : {"valve_natural_frequency", "valve_damping", "valve_gain", "valve_dead_time"})
    out << key << ": " << valve[key].as<double>() << "\n";
}

}  // namespace

// --fixed-settings finds the topics' clock offsets as the survey does, refined by the free run: a large soft
// press's position 10 ms late came to 9.62-9.78 ms without the refinement (the free run up to 2.2 times the
// noise), 9.79-9.92 ms with it, as with the survey.
TEST_F(AnalyzeBag, FixedSettingsFindTheClockOffsetsAsTheSurveyDoes) {
  const std::string bag = kWork + "/soft_late.bag", config = kWork + "/soft_late.yaml",
                    truth = kWork + "/soft_late_truth.yaml";
  ASSERT_EQ(run(kTools + "/simulate_bag " + bag + " --press large_soft --variation 2 --seed 22 --cycles 8" +
                " --stamp-offsets 0,0.01,0.005 --write-config " + config + " --write-truth " + truth)
                .status,
            0);
  configureTheTrueValve(truth, config);
  const YAML::Node fixed = analyze(bag, kWork + "/soft_late", "--config " + config + " --fixed-settings");
  EXPECT_NEAR(fixed["input"]["topic_delays"]["position"].as<double>(), 0.010, 3e-4);
  EXPECT_NEAR(fixed["input"]["topic_delays"]["valve"].as<double>(), 0.005, 3e-4);
  EXPECT_LT(fixed["fit"]["simulation_error_rms"].as<double>(),
            2.0 * fixed["adequacy"]["noise_rms"].as<double>());
}

// --fixed-settings on a valve reported at half its controller's rate: the commands between the messages are
// not in the recording and nothing without the survey measures what they change (given the true valve model,
// a clean fast press ran 3.9 bar off and was told "structured"): the summary says so, and what to do.
TEST_F(AnalyzeBag, FixedSettingsOnAValveSlowerThanItsAmplifierSayWhatTheyCannotMeasure) {
  const std::string bag = kWork + "/fast_slow_valve.bag", config = kWork + "/fast_slow_valve.yaml",
                    truth = kWork + "/fast_slow_valve_truth.yaml";
  ASSERT_EQ(run(kTools + "/simulate_bag " + bag +
                " --press fast_mechanical --cycles 8 --seed 4 --rates 1000,1000,500" + " --write-config " +
                config + " --write-truth " + truth)
                .status,
            0);
  configureTheTrueValve(truth, config);
  const YAML::Node fixed =
      analyze(bag, kWork + "/fast_slow_valve", "--config " + config + " --fixed-settings");
  const std::string warning = die_cushion_ident::testing::warningWithCode(fixed, "resolution_limited");
  EXPECT_NE(warning.find("the valve topic comes every 2 ms"), std::string::npos) << warning;
  EXPECT_NE(warning.find("Leave out --fixed-settings"), std::string::npos) << warning;
}

TEST_F(AnalyzeBag, AnalysisBagAndCsvAreTimeAlignedWithTheInput) {
  analyze(kWork + "/leak.bag", kWork + "/outputs");
  rosbag::Bag input(kWork + "/leak.bag"), output(kWork + "/outputs/analysis.bag");
  rosbag::View in_view(input), out_view(output);
  std::set<std::string> topics;
  for (const auto* c : out_view.getConnections()) topics.insert(c->topic);
  for (const char* t : {"/die_cushion_ident/estimate", "/die_cushion_ident/model_comparison",
                        "/die_cushion_ident/frequency_response", "/die_cushion_ident/valve_model"}) {
    EXPECT_TRUE(topics.count(t)) << t;
  }
  EXPECT_GE(out_view.getBeginTime().toSec(), in_view.getBeginTime().toSec() - 1e-3);
  EXPECT_LE(out_view.getEndTime().toSec(), in_view.getEndTime().toSec() + 1e-3);
  for (const char* csv : {"estimates.csv", "model_comparison.csv", "frequency_response.csv", "valve_fit.csv"}) {
    std::ifstream file(kWork + "/outputs/" + csv);
    std::string header, first;
    EXPECT_TRUE(std::getline(file, header) && std::getline(file, first)) << csv;
  }
  // The fitted curve in valve_fit.csv is the bag's FrequencyResponse curve, row by row.
  for (const rosbag::MessageInstance& m : rosbag::View(output, rosbag::TopicQuery("/die_cushion_ident/frequency_response"))) {
    const auto response = m.instantiate<die_cushion_ident::FrequencyResponse>();
    ASSERT_TRUE(response);
    std::ifstream file(kWork + "/outputs/valve_fit.csv");
    std::string line;
    std::getline(file, line);
    std::size_t rows = 0;
    while (std::getline(file, line)) {
      ASSERT_LT(rows, response->fit_frequency.size());
      EXPECT_NEAR(std::stod(line.substr(line.find(',') + 1)), response->fit_magnitude[rows], 1e-9 * response->fit_magnitude[rows]);
      ++rows;
    }
    EXPECT_EQ(rows, response->fit_frequency.size());
  }
}

TEST_F(AnalyzeBag, ACustomEffectOutsideTheLibraryLowersTheErrorTwofold) {
  ASSERT_EQ(run(kTools + "/simulate_bag " + kWork +
                "/relief.bag --cycles 8 --seed 2 "
                "--custom-effect 'relief=max(p-140e5,0)' --set relief_theta=3e-10")
                .status,
            0);
  const YAML::Node base = analyze(kWork + "/relief.bag", kWork + "/relief_base");
  EXPECT_TRUE(base["adequacy"]["residual_unexplained"].as<bool>());
  EXPECT_NE(base["adequacy"]["conclusion"].as<std::string>().find("custom effect"), std::string::npos);
  const YAML::Node custom =
      analyze(kWork + "/relief.bag", kWork + "/relief_custom", "--custom-effect 'relief=max(p-140e5,0)'");
  EXPECT_EQ(custom["model"]["effects"][0].as<std::string>(), "relief");
  EXPECT_LT(2.0 * custom["fit"]["simulation_error_rms"].as<double>(),
            base["fit"]["simulation_error_rms"].as<double>());
  EXPECT_NEAR(parameter(custom["model"]["parameters"], "relief_theta") / 3e-10, 1.0, 0.25);
}

TEST_F(AnalyzeBag, ABadCommandLineOrConfigurationExitsWithTwoNamingTheProblem) {
  const std::string tool = kTools + "/analyze_bag ";
  // Command line.
  CommandResult r = run(tool + kWork + "/leak.bag");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--out DIR is required"), std::string::npos) << r.output;
  r = run(tool + kWork + "/leak.bag --out " + kWork + "/x --bogus");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("unknown option --bogus"), std::string::npos) << r.output;
  r = run(tool + kWork + "/leak.bag --out " + kWork + "/x --effects leakage,bogus");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("bogus"), std::string::npos) << r.output;
  // Configuration file.
  {
    std::ofstream config(kWork + "/bad.yaml");
    config << "piston_area: -0.05\nforgetting_factor: lots\nfiltre_width: 31\n";
  }
  r = run(tool + kWork + "/leak.bag --out " + kWork + "/x --config " + kWork + "/bad.yaml");
  EXPECT_EQ(r.status, 2);
  for (const char* expected :
       {"piston_area", "forgetting_factor: 'lots' is not a number", "unknown key 'filtre_width'"}) {
    EXPECT_NE(r.output.find(expected), std::string::npos) << expected << "\n" << r.output;
  }
  r = run(tool + kWork + "/leak.bag --out " + kWork + "/x --config " + kWork + "/missing.yaml");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("cannot read config file"), std::string::npos) << r.output;
}

TEST_F(AnalyzeBag, AnUnusableBagExitsWithThreeAndACutOneWithAPartialResult) {
  const std::string tool = kTools + "/analyze_bag ";
  CommandResult r = run(tool + kWork + "/no_such.bag --out " + kWork + "/x");
  EXPECT_EQ(r.status, 3);
  EXPECT_NE(r.output.find("cannot open bag"), std::string::npos) << r.output;
  {
    std::ofstream text(kWork + "/not_a.bag");
    text << "this is not a bag\n";
  }
  r = run(tool + kWork + "/not_a.bag --out " + kWork + "/x");
  EXPECT_EQ(r.status, 3);
  EXPECT_NE(r.output.find("is not a ROS bag"), std::string::npos) << r.output;
  {
    std::ifstream whole(kWork + "/leak.bag", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(whole)), std::istreambuf_iterator<char>());
    std::ofstream cut(kWork + "/truncated.bag", std::ios::binary);
    cut.write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  }
  // A bag cut off while recording: a clear error, and a partial result for what could be recovered.
  r = run(tool + kWork + "/truncated.bag --out " + kWork + "/truncated");
  EXPECT_EQ(r.status, 5) << r.output;
  EXPECT_NE(r.output.find("cut off while recording"), std::string::npos) << r.output;
  {
    const YAML::Node partial = YAML::LoadFile(kWork + "/truncated/summary.yaml");
    EXPECT_GT(partial["fit"]["samples"].as<int>(), 1000);
    EXPECT_NE(die_cushion_ident::testing::warningWithCode(partial, "bag_damaged").find("cut off"),
              std::string::npos)
        << "a warning says that the bag was cut off";
  }
  { rosbag::Bag empty(kWork + "/empty.bag", rosbag::bagmode::Write); }
  r = run(tool + kWork + "/empty.bag --out " + kWork + "/x");
  EXPECT_EQ(r.status, 3);
  EXPECT_NE(r.output.find("the bag is empty"), std::string::npos) << r.output;
  {
    rosbag::Bag wrong(kWork + "/wrong_type.bag", rosbag::bagmode::Write);
    std_msgs::Float64 value;
    value.data = 1e6;
    wrong.write("/die_cushion/pressure", ros::Time(1.0), value);
  }
  r = run(tool + kWork + "/wrong_type.bag --out " + kWork + "/x");
  EXPECT_EQ(r.status, 3);
  EXPECT_NE(r.output.find("has type std_msgs/Float64, expected sensor_msgs/FluidPressure"), std::string::npos)
      << r.output;
}

// A copy of `in` with each pressure message passed through `change` (index, message); the other topics as
// they are.
void rewritePressure(const std::string& in, const std::string& out,
                     const std::function<void(int, sensor_msgs::FluidPressure&)>& change, bool drop_valve = false) {
  rosbag::Bag source(in, rosbag::bagmode::Read);
  rosbag::Bag target(out, rosbag::bagmode::Write);
  int index = 0;
  for (const rosbag::MessageInstance& m : rosbag::View(source)) {
    if (m.getTopic() == "/die_cushion/pressure") {
      auto msg = m.instantiate<sensor_msgs::FluidPressure>();
      change(index++, *msg);
      target.write(m.getTopic(), m.getTime(), *msg);
    } else if (!(drop_valve && m.getTopic() == "/die_cushion/valve")) {
      target.write(m.getTopic(), m.getTime(), m, m.getConnectionHeader());
    }
  }
}

std::string fileText(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

bool anyWarningSays(const YAML::Node& summary, const std::string& text) {
  for (const auto& w : summary["warnings"]) {
    if (w.as<std::string>().find(text) != std::string::npos) return true;
  }
  return false;
}

// analyze_bag reads bags itself (BagStreamReader): chunks compressed with lz4 or bz2 give exactly the
// results of the uncompressed bag.
// A recording longer than max_analysed_samples (issue 30): the fits, the free run and the ranking judge every
// 2nd, 4th, ... press cycle, say so, and read as the whole recording does: the worn seal named missing, and
// with it in the model the parameters within 3 of their stds and nothing missing; the online estimate still
// covers every sample. Two press classes; the bound at its lowest (100 000 samples) so that a few minutes of
// recording exceed it.
TEST_F(AnalyzeBag, ALongRecordingIsJudgedOnEvenlySpacedCyclesAndReadsAsTheWhole) {
  const std::string bag = kWork + "/long.bag", config = kWork + "/long.yaml", thin = kWork + "/long_thin.yaml";
  // The fast press in the suite, the small stiff one too with DCI_LONG_RECORDING_CLASSES=all (the core's
  // EvenlyThinnedCycles tests thin both; the nightly-style scripts/long_recordings every class).
  std::vector<std::string> presses = {"fast_mechanical --variation 1 --seed 5 --cycles 300"};
  if (const char* all = std::getenv("DCI_LONG_RECORDING_CLASSES"); all && std::string(all) == "all") {
    presses.push_back("small_stiff --variation 2 --seed 6 --cycles 160");
  }
  for (const std::string& press : presses) {
    SCOPED_TRACE(press);
    ASSERT_EQ(run(kTools + "/simulate_bag " + bag + " --press " + press + " --plant-effects leakage" +
                  " --write-config " + config)
                  .status,
              0);
    {
      std::ofstream out(thin);
      out << std::ifstream(config).rdbuf() << "max_analysed_samples: 100000\n";
    }
    const YAML::Node whole = analyze(bag, kWork + "/long_whole", "--config " + config);
    const YAML::Node thinned = analyze(bag, kWork + "/long_thinned", "--config " + thin);
    EXPECT_FALSE(whole["fit"]["thinned"]);
    EXPECT_EQ(die_cushion_ident::testing::warningWithCode(whole, "cycles_thinned"), "");
    const YAML::Node kept = thinned["fit"]["thinned"];
    ASSERT_TRUE(kept);
    const int stride = kept["stride"].as<int>(), seen = kept["cycles_seen"].as<int>();
    EXPECT_GE(stride, 2);
    EXPECT_GE(seen, whole["fit"]["cycles"].as<int>()) << "every impact, the last cycle complete or not";
    EXPECT_LE(seen, whole["fit"]["cycles"].as<int>() + 1);
    EXPECT_EQ(kept["cycles_kept"].as<int>(), (seen + stride - 1) / stride);
    EXPECT_NE(die_cushion_ident::testing::warningWithCode(thinned, "cycles_thinned").find("evenly spaced"),
              std::string::npos);
    for (const YAML::Node* s : {&whole, &thinned}) {
      EXPECT_EQ((*s)["candidates"][0]["effect"].as<std::string>(), "leakage");
      EXPECT_EQ((*s)["candidates"][0]["verdict"].as<std::string>(), "missing");
    }
    EXPECT_EQ(fileText(kWork + "/long_thinned/estimates.csv"), fileText(kWork + "/long_whole/estimates.csv"));

    const YAML::Node sealed = analyze(bag, kWork + "/long_whole", "--config " + config + " --effects leakage");
    const YAML::Node sealed_thinned =
        analyze(bag, kWork + "/long_thinned", "--config " + thin + " --effects leakage");
    for (const char* name : {"bulk_modulus", "valve_flow_gain", "dead_volume", "leakage_conductance"}) {
      double std = NAN;
      const double value = die_cushion_ident::testing::summaryParameter(sealed_thinned, name, &std);
      EXPECT_NEAR(value, die_cushion_ident::testing::summaryParameter(sealed, name), 3.0 * std) << name;
    }
    for (const auto& candidate : sealed_thinned["candidates"])
      EXPECT_NE(candidate["verdict"].as<std::string>(), "missing") << candidate["effect"].as<std::string>();
  }
}

TEST_F(AnalyzeBag, CompressedBagsGiveTheSameResults) {
  const YAML::Node plain = analyze(kWork + "/leak.bag", kWork + "/plain");
  for (const char* compression : {"lz4", "bz2"}) {
    const std::string bag = kWork + "/leak_" + compression + ".bag";
    ASSERT_EQ(run("cp " + kWork + "/leak.bag " + bag + " && rosbag compress --" + compression + " -q " + bag).status, 0);
    const YAML::Node packed = analyze(bag, kWork + "/packed_" + compression);
    EXPECT_EQ(packed["input"]["messages"].as<int>(), plain["input"]["messages"].as<int>()) << compression;
    for (std::size_t i = 0; i < plain["model"]["parameters"].size(); ++i) {
      EXPECT_EQ(packed["model"]["parameters"][i]["value"].as<double>(),
                plain["model"]["parameters"][i]["value"].as<double>())
          << compression;
    }
    EXPECT_EQ(packed["valve"]["natural_frequency"].as<double>(), plain["valve"]["natural_frequency"].as<double>());
  }
}

const std::string kGeometry = "piston_area: 0.05\nstroke_length: 0.25\nsupply_pressure: 120e5\n";

// A config file in the work folder, as the option that names it.
std::string configFile(const std::string& name, const std::string& text) {
  std::ofstream(kWork + "/" + name) << text;
  return " --config " + kWork + "/" + name;
}

// The outputs a finished run wrote hold no non-finite value.
void expectFinite(const std::string& directory) {
  const std::regex non_finite(R"((\.nan|\.inf|\bnan\b|\binf\b))", std::regex::icase);
  for (const char* file : {"summary.yaml", "estimates.csv", "model_comparison.csv"}) {
    const std::string text = fileText(directory + "/" + file);
    EXPECT_FALSE(text.empty()) << file;
    EXPECT_FALSE(std::regex_search(text, non_finite))
        << directory << "/" << file << " holds a non-finite value";
  }
}

// The hostile-input review's cases: each gets a clear message, the right exit code and finite outputs.
TEST_F(AnalyzeBag, HostileConfigurationsAreRefusedNamingTheKey) {
  const std::string tool = kTools + "/analyze_bag ";
  // Configurations that used to abort the program or be misreported.
  std::system(("mkdir -p " + kWork + "/a_directory").c_str());
  CommandResult r = run(tool + kWork + "/leak.bag --out " + kWork + "/x --config " + kWork + "/a_directory");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("is a directory"), std::string::npos) << r.output;
  r = run(tool + kWork + "/leak.bag --out " + kWork + "/x" +
          configFile("nonscalar.yaml", "[a, b]: 1\ntopics: {pressure: [1, 2]}\n"));
  EXPECT_EQ(r.status, 2) << r.output;
  r = run(tool + kWork + "/leak.bag --out " + kWork + "/x" +
          configFile("width.yaml", "moving_average_width: 31.5\n"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("moving_average_width = 31.5"), std::string::npos) << r.output;
  r = run(tool + kWork + "/leak.bag --out " + kWork + "/x" +
          configFile("period.yaml", "sample_period: 100\n"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("sample_period = 100"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("max_gap"), std::string::npos) << "only the wrong key is named:\n" << r.output;
  for (const char* custom : {"a=1/(p-p)", "b=log(0)", "c=exp(p)", "d=0", "e=(p>100e5)?1e300:0"}) {
    r = run(tool + kWork + "/leak.bag --out " + kWork + "/x --custom-effect '" + custom + "'");
    EXPECT_EQ(r.status, 2) << custom << "\n" << r.output;
    EXPECT_NE(r.output.find(custom + 2), std::string::npos) << r.output;
  }
}

TEST_F(AnalyzeBag, AbsurdValuesAreRejectedCountedAndNothingNonFiniteIsWritten) {
  const std::string tool = kTools + "/analyze_bag ";
  // Absurd values in the recording: rejected like NaN, counted, and nothing non-finite written.
  rewritePressure(kWork + "/leak.bag", kWork + "/absurd.bag", [](int i, sensor_msgs::FluidPressure& m) {
    if (i >= 5000 && i < 5020) m.fluid_pressure = 1e300;
    if (i >= 9000 && i < 9020) m.fluid_pressure = 1e9;
    if (i == 12000) m.fluid_pressure = -1e300;
  });
  const CommandResult r =
      run(tool + kWork + "/absurd.bag --out " + kWork + "/absurd" + configFile("geometry.yaml", kGeometry));
  EXPECT_EQ(r.status, 0) << r.output;
  {
    const YAML::Node s = YAML::LoadFile(kWork + "/absurd/summary.yaml");
    EXPECT_EQ(s["input"]["topics"]["pressure"]["implausible"].as<int>(), 41);
    EXPECT_TRUE(anyWarningSays(s, "outside the physically plausible range")) << fileText(kWork + "/absurd/summary.yaml");
    EXPECT_GT(s["model"]["parameters"][0]["value"].as<double>(), 1e8) << "no negative bulk modulus";
    EXPECT_EQ(s["candidates"][0]["effect"].as<std::string>(), "leakage") << "the conclusion does not flip";
    EXPECT_EQ(s["candidates"][0]["verdict"].as<std::string>(), "missing");
  }
  expectFinite(kWork + "/absurd");
}

TEST_F(AnalyzeBag, PositionMessagesWithoutAPositionAreCountedAndSaid) {
  const std::string tool = kTools + "/analyze_bag ";
  // Position messages without a position are rejected and counted like the node counts them, and said.
  {
    rosbag::Bag source(kWork + "/leak.bag", rosbag::bagmode::Read);
    rosbag::Bag target(kWork + "/no_position.bag", rosbag::bagmode::Write);
    int index = 0;
    for (const rosbag::MessageInstance& m : rosbag::View(source)) {
      if (m.getTopic() == "/die_cushion/position") {
        auto msg = m.instantiate<sensor_msgs::JointState>();
        if (index++ % 100 == 7) msg->position.clear();
        target.write(m.getTopic(), m.getTime(), *msg);
      } else {
        target.write(m.getTopic(), m.getTime(), m, m.getConnectionHeader());
      }
    }
  }
  const CommandResult r = run(tool + kWork + "/no_position.bag --out " + kWork + "/no_position" +
                              configFile("geometry.yaml", kGeometry));
  EXPECT_EQ(r.status, 0) << r.output;
  {
    const YAML::Node s = YAML::LoadFile(kWork + "/no_position/summary.yaml");
    const int messages = s["input"]["topics"]["position"]["messages"].as<int>();
    EXPECT_EQ(s["input"]["topics"]["position"]["rejected"].as<int>(), (messages + 92) / 100);
    EXPECT_TRUE(anyWarningSays(s, "without a position")) << fileText(kWork + "/no_position/summary.yaml");
    EXPECT_EQ(s["candidates"][0]["effect"].as<std::string>(), "leakage");
  }
}

TEST_F(AnalyzeBag, PressureInBarOrNoValveTopicIdentifiesNothingAndSaysWhy) {
  const std::string tool = kTools + "/analyze_bag ";
  // Pressure recorded in bar: nothing can be identified, and the summary says why instead of showing the
  // initial values with std 0 and "within the noise".
  rewritePressure(kWork + "/leak.bag", kWork + "/bar.bag",
                  [](int, sensor_msgs::FluidPressure& m) { m.fluid_pressure *= 1e-5; });
  CommandResult r =
      run(tool + kWork + "/bar.bag --out " + kWork + "/bar" + configFile("geometry.yaml", kGeometry));
  EXPECT_EQ(r.status, 5) << r.output;
  {
    const YAML::Node s = YAML::LoadFile(kWork + "/bar/summary.yaml");
    EXPECT_EQ(s["model"]["parameters"].size(), 0u) << "no initial values shown as estimates";
    EXPECT_FALSE(s["fit"]["simulation_error_rms"]) << "no error that was not measured";
    EXPECT_TRUE(anyWarningSays(s, "recorded in bar")) << fileText(kWork + "/bar/summary.yaml");
    EXPECT_EQ(s["adequacy"]["conclusion"].as<std::string>().find("within the noise"), std::string::npos);
  }
  expectFinite(kWork + "/bar");

  // The valve topic missing: partial, said, no parameters.
  rewritePressure(kWork + "/leak.bag", kWork + "/novalve.bag", [](int, sensor_msgs::FluidPressure&) {}, true);
  r = run(tool + kWork + "/novalve.bag --out " + kWork + "/novalve" + configFile("geometry.yaml", kGeometry));
  EXPECT_EQ(r.status, 5) << r.output;
  EXPECT_EQ(YAML::LoadFile(kWork + "/novalve/summary.yaml")["model"]["parameters"].size(), 0u);
}

TEST_F(AnalyzeBag, CorruptedBytesAreNamedWhereTheyAreAndALostIndexLosesNothing) {
  const std::string tool = kTools + "/analyze_bag ";
  // Corrupted bytes in the middle: partial, with the share that was read.
  {
    std::string bytes = fileText(kWork + "/leak.bag");
    // Over the header of a message record a third into the file (not an index record, whose damage the
    // stream reader does not need to notice): "op=" 0x02 marks message data.
    const std::size_t record = bytes.find(std::string("op=\x02", 4), bytes.size() / 3);
    ASSERT_NE(record, std::string::npos);
    for (std::size_t i = 0; i < 200; ++i) bytes[record - 20 + i] = static_cast<char>(0xA5);
    std::ofstream(kWork + "/corrupt.bag", std::ios::binary) << bytes;
  }
  CommandResult r =
      run(tool + kWork + "/corrupt.bag --out " + kWork + "/corrupt" + configFile("geometry.yaml", kGeometry));
  EXPECT_EQ(r.status, 5) << r.output;
  {
    // Named where it is, and the reading goes on after it: a few messages lost, not the rest of the bag.
    const YAML::Node s = YAML::LoadFile(kWork + "/corrupt/summary.yaml");
    EXPECT_TRUE(anyWarningSays(s, "the bag is damaged (")) << fileText(kWork + "/corrupt/summary.yaml");
    EXPECT_TRUE(anyWarningSays(s, "at byte ")) << fileText(kWork + "/corrupt/summary.yaml");
    EXPECT_TRUE(anyWarningSays(s, "the reading went on at the next record that holds together"));
  }

  // A bag that lost only its index: every message is read from its chunks (no repair, no temporary copy).
  const std::string tmp = kWork + "/tmp";
  std::system(("rm -rf " + tmp + " && mkdir -p " + tmp).c_str());
  {
    const std::string bytes = fileText(kWork + "/leak.bag");
    std::ofstream(kWork + "/noindex.bag", std::ios::binary) << bytes.substr(0, bytes.size() - 2000);
  }
  r = run("TMPDIR=" + tmp + " " + tool + kWork + "/noindex.bag --out " + kWork + "/noindex" +
          configFile("geometry.yaml", kGeometry));
  EXPECT_EQ(r.status, 0) << r.output;
  {
    const YAML::Node s = YAML::LoadFile(kWork + "/noindex/summary.yaml");
    EXPECT_EQ(s["input"]["messages"].as<int>(),
              analyze(kWork + "/leak.bag", kWork + "/indexed")["input"]["messages"].as<int>())
        << "every message was read";
    EXPECT_TRUE(anyWarningSays(s, "lost its index"));
  }
  EXPECT_EQ(run("ls -A " + tmp).output, "") << "no temporary copy";
}

// A recording killed with SIGKILL (rosbag record's NAME.bag.active, issue 45): the open chunk's records
// are read as its messages up to the last whole one, the record the kill cut is counted, the summary says
// how many records could not be read and never that every message was read. (The same with a real
// `rosbag record`: the rostest killed_recording.)
TEST_F(AnalyzeBag, AKilledRecordingIsReadToItsLastMessageAndSaysWhatItCouldNotRead) {
  const std::string bag = kWork + "/killed.bag.active";
  ASSERT_TRUE(die_cushion_ident::testing::writeKilledRecording(bag, [&](rosbag::Bag& out) {
    rosbag::Bag source(kWork + "/leak.bag", rosbag::bagmode::Read);
    for (const rosbag::MessageInstance& m : rosbag::View(source)) {
      out.write(m.getTopic(), m.getTime(), m, m.getConnectionHeader());
    }
  }));
  // Where the recorder's last flush ended is fixed by the bytes; 37 bytes less cut a record for certain.
  {
    const std::string bytes = fileText(bag);
    std::ofstream(bag, std::ios::binary) << bytes.substr(0, bytes.size() - 37);
  }
  const auto holds = die_cushion_ident::testing::walkKilledRecording(fileText(bag));
  ASSERT_TRUE(holds.open_chunk);
  ASSERT_TRUE(holds.ends_inside_a_record);
  ASSERT_GT(holds.open_chunk_messages, 1000u) << "the open chunk holds seconds of the recording";
  const CommandResult r = run(kTools + "/analyze_bag " + bag + " --out " + kWork + "/killed" +
                              configFile("geometry.yaml", kGeometry));
  EXPECT_EQ(r.status, 5) << "partial: one record could not be read\n" << r.output;
  const YAML::Node s = YAML::LoadFile(kWork + "/killed/summary.yaml");
  std::uint64_t read = 0;
  for (const char* topic : {"pressure", "position", "valve"})
    read += s["input"]["topics"][topic]["messages"].as<std::uint64_t>();
  EXPECT_EQ(read, holds.messages) << "every whole message the file holds";
  EXPECT_EQ(s["input"]["records_unreadable"].as<int>(), 1);
  EXPECT_TRUE(anyWarningSays(s, "1 record")) << fileText(kWork + "/killed/summary.yaml");
  EXPECT_TRUE(anyWarningSays(s, "not closed")) << fileText(kWork + "/killed/summary.yaml");
  EXPECT_FALSE(anyWarningSays(s, "every message was read")) << fileText(kWork + "/killed/summary.yaml");
  EXPECT_FALSE(anyWarningSays(s, "unknown kind")) << fileText(kWork + "/killed/summary.yaml");
  expectFinite(kWork + "/killed");
}

TEST_F(AnalyzeBag, AReusedOutputFolderKeepsNoStaleFileAndListsWhatItHolds) {
  const std::string tool = kTools + "/analyze_bag ";
  // A reused output folder keeps no stale file of the previous run.
  ASSERT_EQ(run(tool + kWork + "/leak.bag --out " + kWork + "/reused").status, 0);
  ASSERT_TRUE(std::ifstream(kWork + "/reused/frequency_response.csv").good());
  ASSERT_EQ(
      run(tool + kWork + "/leak.bag --out " + kWork + "/reused" + configFile("geometry.yaml", kGeometry))
          .status,
      0);
  EXPECT_TRUE(std::ifstream(kWork + "/reused/frequency_response.csv").good())
      << "a sweep again: written again";
  ASSERT_EQ(run(kTools + "/simulate_bag " + kWork + "/nosweep.bag --cycles 3 --seed 2").status, 0);
  ASSERT_EQ(
      run(tool + kWork + "/nosweep.bag --out " + kWork + "/reused" + configFile("geometry.yaml", kGeometry))
          .status,
      0);
  EXPECT_FALSE(std::ifstream(kWork + "/reused/frequency_response.csv").good()) << "no stale valve results";
  EXPECT_FALSE(std::ifstream(kWork + "/reused/valve_fit.csv").good()) << "no stale valve results";

  // A complete run lists what it wrote, and each is there.
  const YAML::Node whole = YAML::LoadFile(kWork + "/reused/summary.yaml");
  ASSERT_TRUE(whole["outputs"].IsSequence());
  for (const auto& name : whole["outputs"]) {
    EXPECT_TRUE(std::ifstream(kWork + "/reused/" + name.as<std::string>()).good()) << name.as<std::string>();
  }
}

// A full disk (a file-size limit here), hit while writing different files: exit 4 with the reason, never
// an abort, and no file left under a final name or half-written under a temporary one (issue 28).
TEST_F(AnalyzeBag, AFullDiskExitsWithFourAndLeavesNoFile) {
  const std::string tool = kTools + "/analyze_bag ";
  for (const int kilobytes : {20, 200, 1000}) {
    const std::string out = kWork + "/full" + std::to_string(kilobytes);
    std::system(("mkdir -p " + out).c_str());
    const CommandResult r =
        run("bash -c 'trap \"\" XFSZ; ulimit -f " + std::to_string(kilobytes) + "; " + tool + kWork +
            "/leak.bag --out " + out + configFile("geometry.yaml", kGeometry) + "'");
    EXPECT_EQ(r.status, 4) << r.output;
    EXPECT_NE(r.output.find("cannot write"), std::string::npos) << r.output;
    for (const std::string name : {"summary.yaml", "analysis.bag", "estimates.csv", "model_comparison.csv",
                                   "frequency_response.csv", "valve_fit.csv", "proposals.csv"}) {
      EXPECT_FALSE(std::ifstream(out + "/" + name).good()) << kilobytes << " kB: " << name;
      EXPECT_FALSE(std::ifstream(out + "/" + name + ".partial").good()) << kilobytes << " kB: " << name;
    }
  }
}

// Generated hostile bags, the review's cases and more like them: random mixtures of absurd values, NaN,
// wild and zero stamps, lost topics, corrupted bytes and cut-off ends. Whatever the bag, analyze_bag ends
// with an exit code of the contract (never a signal), writes nothing non-finite, and a partial result
// always says why.
// A hostile copy of `source` as case `c`: absurd values in bursts, wild and zero stamps, a lost topic,
// pressure in bar, no velocity, corrupted bytes or a cut-off end, drawn from `rng`.
void writeHostileCopy(const std::string& source_path, const std::string& bag, int c, std::mt19937& rng) {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const double kAbsurd[] = {1e300, -1e300, NAN, INFINITY, 1e9, -1e9, 0.0};
  const double burst = uniform(rng), wild = uniform(rng) * 0.01, drop = uniform(rng);
  const double scale = c % 4 == 1 ? 1e-5 : 1.0;
  {
    rosbag::Bag source(source_path, rosbag::bagmode::Read);
    rosbag::Bag target(bag, rosbag::bagmode::Write);
    int index = 0;
    for (const rosbag::MessageInstance& m : rosbag::View(source)) {
      ++index;
      const bool absurd = uniform(rng) < 0.002 || (index % 3000 < 20 && burst < 0.5);
      const double value = kAbsurd[index % 7];
      const double stamp_shift = uniform(rng) < wild ? (uniform(rng) < 0.5 ? -100.0 : 1000.0) : 0.0;
      const auto stamped = [&](std_msgs::Header& h) {
        h.stamp = h.stamp.toSec() + stamp_shift > 0 ? ros::Time(h.stamp.toSec() + stamp_shift) : ros::Time(0);
        if (uniform(rng) < 0.001) h.stamp = ros::Time(0);
      };
      if (m.getTopic() == "/die_cushion/pressure") {
        auto msg = m.instantiate<sensor_msgs::FluidPressure>();
        msg->fluid_pressure = absurd ? value : msg->fluid_pressure * scale;
        stamped(msg->header);
        target.write(m.getTopic(), m.getTime(), *msg);
      } else if (m.getTopic() == "/die_cushion/position") {
        if (drop < 0.1) continue;  // the position topic lost
        auto msg = m.instantiate<sensor_msgs::JointState>();
        if (absurd) msg->position[0] = value;
        if (c % 3 == 2) msg->velocity.clear();
        stamped(msg->header);
        target.write(m.getTopic(), m.getTime(), *msg);
      } else {
        if (drop > 0.9) continue;  // the valve topic lost
        target.write(m.getTopic(), m.getTime(), m, m.getConnectionHeader());
      }
    }
  }
  if (c % 5 == 3) {  // corrupted bytes in the middle, or a cut-off end
    std::string bytes = fileText(bag);
    for (int k = 0; k < 200; ++k) bytes[bytes.size() / 2 + k] = static_cast<char>(rng());
    std::ofstream(bag, std::ios::binary) << bytes;
  } else if (c % 5 == 4) {
    const std::string bytes = fileText(bag);
    std::ofstream(bag, std::ios::binary)
        << bytes.substr(0, static_cast<std::size_t>(bytes.size() * (0.3 + 0.69 * uniform(rng))));
  }
}

// Whatever the bag: an exit code of the contract, nothing non-finite written, a partial result says why.
void expectTheContract(const CommandResult& r, const std::string& out) {
  const std::regex non_finite(R"((\.nan|\.inf|\bnan\b|\binf\b))", std::regex::icase);
  EXPECT_TRUE(r.status == 0 || r.status == 3 || r.status == 5) << "exit " << r.status << "\n" << r.output;
  if (r.status == 0 || r.status == 5) {
    const std::string text = fileText(out + "/summary.yaml");
    EXPECT_FALSE(std::regex_search(text, non_finite)) << text;
    const YAML::Node summary = YAML::Load(text);
    if (r.status == 5) {
      EXPECT_GT(summary["warnings"].size(), 0u) << "a partial result says why";
    }
    EXPECT_FALSE(std::regex_search(fileText(out + "/model_comparison.csv"), non_finite));
  } else {
    EXPECT_NE(r.output.find("analyze_bag: "), std::string::npos) << "a refusal says why";
  }
}

TEST_F(AnalyzeBag, GeneratedHostileBagsKeepTheContract) {
  const std::string tool = kTools + "/analyze_bag ";
  ASSERT_EQ(run(kTools + "/simulate_bag " + kWork + "/base3.bag --cycles 3 --seed 9 --sweep").status, 0);
  std::mt19937 rng(20261123);
  const char* more = std::getenv("DCI_GENERATED_BAGS");  // a longer run: DCI_GENERATED_BAGS=200
  const int cases = more ? std::max(1, std::atoi(more)) : 10;
  for (int c = 0; c < cases; ++c) {
    SCOPED_TRACE("generated case " + std::to_string(c));
    const std::string bag = kWork + "/generated_" + std::to_string(c) + ".bag";
    writeHostileCopy(kWork + "/base3.bag", bag, c, rng);
    const std::string out = kWork + "/generated_" + std::to_string(c);
    expectTheContract(run(tool + bag + " --out " + out), out);
  }
}

}  // namespace

namespace {

// Issue 15: the workspace lives inside the repository; rosrun searches the package with `find -L`, which
// walked back into it and printed "File system loop detected" twice on every command.
TEST(Rosrun, FindsTheToolsWithoutAFileSystemLoop) {
  if (!std::getenv("ROS_PACKAGE_PATH")) GTEST_SKIP() << "not in a sourced workspace";
  std::system(("mkdir -p " + kWork).c_str());
  const CommandResult result = run("rosrun die_cushion_ident analyze_bag --help");
  EXPECT_EQ(result.status, 0) << result.output;
  EXPECT_EQ(result.output.find("File system loop"), std::string::npos) << result.output;
  EXPECT_EQ(result.output.find("More than one"), std::string::npos) << result.output;
}

}  // namespace
