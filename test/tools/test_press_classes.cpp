// Every press class (simulate_bag --press), analysed as a user would: analyze_bag choosing its own settings
// from the recording. The short core of scripts/press_matrix, which runs more variations of each class and
// every sensor configuration (DCI_PRESS_MATRIX=full) and the false-alarm rate over at least 100 clean
// recordings (DCI_PRESS_FALSE_ALARMS=N).
//  - clean: the free run within 2x the pressure noise, nothing called missing (no library effect, no
//    formula), the bulk modulus within 10 %;
//  - each library effect hidden: the top candidate, `missing`; once added, the free run within 3x the
//    noise, the bulk modulus within 10 % and the effect's parameter within 20 %.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <boost/math/distributions/beta.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "bag_analysis.h"
#include "command_line.h"
#include "output/csv_file.h"
#include "tool_runner.h"

namespace {

const std::string kTools = TOOL_DIR;
const std::string kWork = die_cushion_ident::testing::workDirectory("test_press_classes");
const std::vector<std::string> kClasses = {"slow_hydraulic", "fast_mechanical", "small_stiff", "large_soft"};
const std::vector<std::string> kEffects = {"leakage", "entrained_air", "valve_overlap", "tank_pressure"};
const std::vector<std::string> kEffectParameter = {"leakage_conductance", "air_volume", "valve_overlap", "tank_pressure"};

bool full() {
  const char* matrix = std::getenv("DCI_PRESS_MATRIX");
  return matrix && std::string(matrix) == "full";
}

die_cushion_ident::testing::CommandResult run(const std::string& command) {
  return die_cushion_ident::testing::runCommand(command, kWork + "/last_output.txt");
}

struct Case {
  std::string press, effect = "none", sensors;
  int variation = 0, seed = 1;
  int onset = 0;  // > 0: the effect acts from this press cycle of 10 on
  int cycles = 8;
  std::string name() const {
    std::string n = press + "_v" + std::to_string(variation) + "_s" + std::to_string(seed) + "_" + effect;
    if (onset > 0) n += "_from" + std::to_string(onset);
    if (cycles != 8) n += "_c" + std::to_string(cycles);
    for (char c : sensors) n += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
    return n;
  }
};

struct Recorded {
  std::string bag, config;
  YAML::Node truth;
};

Recorded record(const Case& c) {
  Recorded r;
  const std::string base = kWork + "/" + c.name();
  r.bag = base + ".bag";
  r.config = base + ".yaml";
  const std::string effects = c.effect == "none" ? "" : " --plant-effects " + c.effect;
  const std::string cycles = c.onset > 0 ? " --cycles 10 --effects-from-cycle " + std::to_string(c.onset)
                                         : " --cycles " + std::to_string(c.cycles);
  const auto result = run(kTools + "/simulate_bag " + r.bag + " --press " + c.press + " --variation " +
                          std::to_string(c.variation) + " --seed " + std::to_string(c.seed) + cycles + effects +
                          " " + c.sensors + " --write-config " + r.config + " --write-truth " + base + "_truth.yaml");
  EXPECT_EQ(result.status, 0) << result.output;
  r.truth = YAML::LoadFile(base + "_truth.yaml");
  if (c.sensors.find("--no-spool") != std::string::npos) {
    // Without a spool sensor the spool is predicted by the configured valve model: a user gives the one
    // a sweep of this valve found (without it analyze_bag warns that the default valve is used).
    std::ofstream config(r.config, std::ios::app);
    for (const char* key : {"valve_natural_frequency", "valve_damping", "valve_gain", "valve_dead_time"}) {
      config << key << ": " << r.truth[key].as<double>() << "\n";
    }
  }
  return r;
}

using Analysis = die_cushion_ident::testing::BagAnalysis;
using die_cushion_ident::testing::summaryParameter;

Analysis analyze(const Recorded& r, const std::string& out, const std::string& extra = "") {
  return die_cushion_ident::testing::analyzeBag(kTools, r.bag, r.config, out, extra, kWork + "/last_output.txt");
}

std::string formattedArguments(const char* format, double a) {
  char text[256];
  std::snprintf(text, sizeof(text), format, a);
  return text;
}

std::string formattedArguments(const char* format, double a, double b) {
  char text[256];
  std::snprintf(text, sizeof(text), format, a, b);
  return text;
}

// Any `missing` verdict: a library effect or a formula.
std::string missingVerdicts(const YAML::Node& summary) {
  std::string found;
  for (const auto& c : summary["candidates"]) {
    if (c["verdict"].as<std::string>() == "missing") found += " " + c["effect"].as<std::string>();
  }
  for (const auto& p : summary["proposals"]) {
    if (p["verdict"].as<std::string>() == "missing") found += " " + p["expression"].as<std::string>();
  }
  return found;
}

const std::vector<std::string> kSensorConfigurations = {"", "--no-velocity", "--no-spool", "--rates 2000,500,1000",
                                                         "--stamp-offsets 0,0.01,0.005"};

// The sensor configurations of the full matrix; the suite runs the full sensor set and, on each class,
// one other configuration (a different one per class).
std::vector<std::string> sensorConfigurations(std::size_t press_index = 0) {
  if (full()) return kSensorConfigurations;
  return {"", kSensorConfigurations[1 + press_index % (kSensorConfigurations.size() - 1)]};
}

std::vector<int> variations() { return full() ? std::vector<int>{0, 1, 2} : std::vector<int>{0}; }

class PressClasses : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { std::system(("rm -rf " + kWork + " && mkdir -p " + kWork).c_str()); }
};

}  // namespace

TEST_F(PressClasses, ACleanPressOfEveryClassReadsRight) {
  for (std::size_t press_index = 0; press_index < kClasses.size(); ++press_index) {
    const std::string& press = kClasses[press_index];
    for (int variation : variations()) {
      for (const std::string& sensors : sensorConfigurations(press_index)) {
        const Case c{press, "none", sensors, variation, 1};
        SCOPED_TRACE(c.name());
        const Recorded r = record(c);
        const Analysis a = analyze(r, kWork + "/" + c.name());
        ASSERT_EQ(a.status, 0) << a.output;
        const double noise = a.summary["adequacy"]["noise_rms"].as<double>();
        const double error = a.summary["fit"]["simulation_error_rms"].as<double>();
        const double bulk = summaryParameter(a.summary, "bulk_modulus") / r.truth["bulk_modulus"].as<double>() - 1.0;
        std::printf("%-48s clean: free run %.2f bar (%.2fx noise), K' %+.1f %%, period %g ms, missing:%s\n",
                    c.name().c_str(), 1e-5 * error, error / noise, 100.0 * bulk,
                    1e3 * a.summary["settings"]["sample_period"]["value"].as<double>(), missingVerdicts(a.summary).c_str());
        EXPECT_LE(error, 2.0 * noise) << "free run within twice the pressure noise";
        EXPECT_EQ(missingVerdicts(a.summary), "") << a.summary["adequacy"]["conclusion"];
        EXPECT_FALSE(a.summary["change_within_recording"]) << "no change named on a steady press";
        EXPECT_LT(std::abs(bulk), 0.10) << "bulk modulus within 10 %";
      }
    }
  }
}

TEST_F(PressClasses, EveryLibraryEffectIsFoundOnEveryClassAndItsParameterRight) {
  for (const std::string& press : kClasses) {
    for (std::size_t e = 0; e < kEffects.size(); ++e) {
      for (int variation : variations()) {
        for (const std::string& sensors : (full() ? kSensorConfigurations : std::vector<std::string>{""})) {
          const Case c{press, kEffects[e], sensors, variation, 2};
          SCOPED_TRACE(c.name());
          const Recorded r = record(c);
          const Analysis base = analyze(r, kWork + "/" + c.name());
          // A model that lacks an effect may fit implausible parameters (a fast press without its valve's
          // overlap: a negative bulk modulus): then a partial result (5), with the ranking all the same.
          ASSERT_TRUE(base.status == 0 || base.status == 5) << base.output;
          ASSERT_TRUE(base.summary["candidates"].size() > 0) << base.output;
          const YAML::Node& top = base.summary["candidates"][0];
          EXPECT_EQ(top["effect"].as<std::string>(), kEffects[e]);
          EXPECT_EQ(top["verdict"].as<std::string>(), "missing") << top["explanation"];
          const Analysis fixed = analyze(r, kWork + "/" + c.name() + "_fixed", "--effects " + kEffects[e]);
          ASSERT_EQ(fixed.status, 0) << fixed.output;
          const double noise = fixed.summary["adequacy"]["noise_rms"].as<double>();
          const double error = fixed.summary["fit"]["simulation_error_rms"].as<double>();
          const double bulk = summaryParameter(fixed.summary, "bulk_modulus") / r.truth["bulk_modulus"].as<double>() - 1.0;
          const double effect = summaryParameter(fixed.summary, kEffectParameter[e]) / r.truth[kEffectParameter[e]].as<double>() - 1.0;
          std::printf("%-48s top %s %s; added: free run %.2f bar (%.2fx noise), K' %+.1f %%, %s %+.1f %%\n",
                      c.name().c_str(), top["effect"].as<std::string>().c_str(), top["verdict"].as<std::string>().c_str(),
                      1e-5 * error, error / noise, 100.0 * bulk, kEffectParameter[e].c_str(), 100.0 * effect);
          // Or the analysis says that the recording's rate limits it, and what to record instead: a fast
          // press's position at 500 Hz (its 4 ms impact in two messages) left 5 times the noise with the
          // valve's overlap added, and 1.5 times at 1 kHz.
          const bool resolution_limited = fixed.summary["adequacy"]["resolution_limited"].as<bool>();
          if (resolution_limited) {
            EXPECT_NE(fixed.summary["settings"]["resolution_limit"].as<std::string>(""), "");
            EXPECT_NE(fixed.summary["adequacy"]["conclusion"].as<std::string>().find("record the"), std::string::npos)
                << "a resolution-limited verdict names the rate to record at";
          } else {
            EXPECT_LE(error, 3.0 * noise) << "free run within three times the noise once the effect is added";
          }
          EXPECT_LT(std::abs(bulk), 0.10) << "bulk modulus within 10 %";
          EXPECT_LT(std::abs(effect), 0.20) << kEffectParameter[e] << " within 20 %";
        }
      }
    }
  }
}

// A fast press seen through a cell's sensors: the position at 500 Hz among three joints without velocity,
// stamped 12 ms late, the valve 4 ms late. The position's offset, estimated by the integral form 0.08 ms off
// (within its stated std), left 6 times the noise and a dead volume 54 % off; refined by the free run it
// comes to about twice the noise (1.50 times since the free run reads the position's own slope). Nothing is
// called missing; where the rate limits the analysis it says so.
TEST_F(PressClasses, AFastPressThroughACellsSlowLateSensorsReadsRight) {
  const Case c{"fast_mechanical", "none",
               "--no-velocity --joints ram,cushion,holder --rates 2000,500,1000 --stamp-offsets 0,0.012,0.004", 4, 1};
  const Recorded r = record(c);
  const Analysis a = analyze(r, kWork + "/" + c.name());
  ASSERT_EQ(a.status, 0) << a.output;
  const double noise = a.summary["adequacy"]["noise_rms"].as<double>();
  const double error = a.summary["fit"]["simulation_error_rms"].as<double>();
  const double offset = a.summary["input"]["topic_delays"]["position"].as<double>();
  std::printf("%-48s free run %.2fx noise, position offset %.3f ms, position-rate error %.2f bar\n", c.name().c_str(),
              error / noise, 1e3 * offset, 1e-5 * a.summary["settings"]["position_rate_error"].as<double>(0.0));
  EXPECT_EQ(missingVerdicts(a.summary), "") << a.summary["adequacy"]["conclusion"];
  EXPECT_NEAR(offset, 0.012, 1e-4) << "the position's clock offset, refined by the free run";
  EXPECT_LE(error, 3.0 * noise);
  // Where the grid is finer than the position's 2 ms messages the position's rate is studied (since the free
  // run reads the position's own slope, the survey chooses the 2 ms grid here: 0.04 bar from halving it).
  const double period = a.summary["settings"]["sample_period"]["value"].as<double>();
  if (period < 0.002 / 1.5) {
    EXPECT_GT(a.summary["settings"]["position_rate_error"].as<double>(0.0), 0.0)
        << "the position topic's rate is studied where it is slower than the grid";
  }
  for (const char* parameter : {"bulk_modulus", "dead_volume"}) {
    EXPECT_NEAR(summaryParameter(a.summary, parameter) / r.truth[parameter].as<double>(), 1.0, 0.20) << parameter;
  }
}

// A fast press without a velocity whose topics come from other clocks: the survey refines the topics' common
// clock offset against the pressure by the free run, as with a measured velocity, now that the free run reads
// the position's own slope (the derived samples had a timing of their own, which the shift took up, and it
// stayed off). On 120 such recordings of the fast press the bulk modulus's median error fell from 0.85 to
// 0.31 %; on the other classes the free run does not pin the common offset and nothing changes.
TEST_F(PressClasses, AFastPressWithoutAVelocityFindsTheCommonClockOffset) {
  for (const Case& c :
       {Case{"fast_mechanical", "none", "--no-velocity --stamp-offsets 0,0.01,0.005", 0, 1},
        Case{"fast_mechanical", "none", "--no-velocity --stamp-offsets 0,0.01,0.005", 12, 5}}) {
    SCOPED_TRACE(c.name());
    const Recorded r = record(c);
    const Analysis a = analyze(r, kWork + "/" + c.name());
    ASSERT_EQ(a.status, 0) << a.output;
    const YAML::Node refined = a.summary["settings"]["position_delay_refined_by_free_run"];
    ASSERT_TRUE(refined["common_fit_std"]) << "the common offset is refined";
    EXPECT_LT(refined["common_fit_std"].as<double>(), 0.1 * refined["common_prior"].as<double>())
        << "and pinned";
    EXPECT_NE(refined["valve_shift"].as<double>(0.0), 0.0) << "and applied";
    double std = 0.0;
    const double value = summaryParameter(a.summary, "bulk_modulus", &std);
    const double truth = r.truth["bulk_modulus"].as<double>();
    EXPECT_NEAR(value / truth, 1.0, 0.01);
    EXPECT_LT(std::abs(value - truth), 3.0 * std);
  }
}

// A ram three times faster than the fast mechanical press's (1.5 m/s into the cushion, simulate_bag
// --ram-speed): the drawing a third as long, the valve passing three times the flow. A clean press still
// reads clean: nothing missing, the free run near the noise (measured 1.00-1.08 times on variations 3, 7,
// 12), the bulk modulus and dead volume within their stated uncertainty band (measured -0.8 to -1.3 % and
// -2.1 to -3.0 %, |z| below 2.2), with and without the topics' stamps from other clocks. At five times (2.5
// m/s) the impact drives the chamber to 200-400 bar and the analysis says the error left there is structured
// and not the library's (5.9 times the noise): not asserted here.
TEST_F(PressClasses, ARamThreeTimesFasterStillReadsClean) {
  for (const std::string sensors : {"--ram-speed 1.5", "--ram-speed 1.5 --stamp-offsets 0,0.01,0.005"}) {
    const Case c{"fast_mechanical", "none", sensors, 7, 11};
    SCOPED_TRACE(c.name());
    const Recorded r = record(c);
    const Analysis a = analyze(r, kWork + "/" + c.name());
    ASSERT_EQ(a.status, 0) << a.output;
    const double noise = a.summary["adequacy"]["noise_rms"].as<double>();
    const double error = a.summary["fit"]["simulation_error_rms"].as<double>();
    std::printf("%-60s free run %.2fx noise\n", c.name().c_str(), error / noise);
    EXPECT_EQ(missingVerdicts(a.summary), "") << a.summary["adequacy"]["conclusion"];
    EXPECT_LE(error, 1.5 * noise);
    for (const char* parameter : {"bulk_modulus", "dead_volume"}) {
      double std = 0.0;
      const double value = summaryParameter(a.summary, parameter, &std);
      const double truth = r.truth[parameter].as<double>();
      EXPECT_NEAR(value / truth, 1.0, 0.05) << parameter;
      EXPECT_LE(std::abs(value - truth), 3.0 * std) << parameter << ": within three of its stds";
    }
  }
}

// A tank pressure's flow sqrt(p - p_T) varies the free run's integrator steps where the chamber nears p_T:
// the refined parameters' stds must be the data's, not that integrator's. Two small stiff presses with a
// tank pressure (one the calibration had at z -5.3 and -10.8 for the dead volume and the bulk modulus, the
// free run's std 20-90 times below the equation error's, before the Jacobian's step was raised to 1e-3 of
// each parameter): every parameter within three of its stds, and the dead volume's std at least 0.2 %
// (over 12 noise seeds of the first press its estimate scatters 0.53 %; it was 0.09 %).
TEST_F(PressClasses, ATankPressuresStdsAreTheDatas) {
  for (const Case& c : {Case{"small_stiff", "tank_pressure", "", 58, 45726},
                        Case{"small_stiff", "tank_pressure", "--rates 2000,500,1000", 16, 97607}}) {
    SCOPED_TRACE(c.name());
    const Recorded r = record(c);
    const Analysis a = analyze(r, kWork + "/" + c.name(), "--effects tank_pressure");
    ASSERT_EQ(a.status, 0) << a.output;
    for (const char* parameter : {"bulk_modulus", "dead_volume", "tank_pressure", "valve_flow_gain"}) {
      double std = 0.0;
      const double value = summaryParameter(a.summary, parameter, &std);
      const double truth = r.truth[parameter].as<double>();
      std::printf("%-50s %-16s error %+.3f %%, std %.3f %%\n", c.name().c_str(), parameter,
                  100.0 * (value - truth) / truth, 100.0 * std / truth);
      EXPECT_LE(std::abs(value - truth), 3.0 * std) << parameter << ": within three of its stds";
      if (std::string(parameter) == "dead_volume") {
        EXPECT_GE(std / value, 0.002) << "the dead volume's std";
      }
    }
  }
}

// A velocity derived from the positions (a linear encoder, no velocity in the JointState): the free run reads
// the position's own slope, so the volume it sweeps is the position's change. When it read the derived
// samples (least-squares slopes over 2 ms: the impact's compression spread over their neighbours) the
// refined bulk modulus came out 2.4-4.9 % low on fast presses and 0.6-1.2 % on small stiff ones (4-8 of its
// stds). The position's noise now enters the free run as the chamber's volume (K A sigma_x / V: a small stiff
// press ran 1.58 times the noise against 1.10 with a velocity, a fast one 1.31 against 1.03), within what
// the product calls the noise. On two press classes, against the same plant and noise with a velocity.
TEST_F(PressClasses, ADerivedVelocityLeavesTheParametersUnbiased) {
  for (const std::string press : {"fast_mechanical", "small_stiff"}) {
    const Case derived{press, "none", "--no-velocity", 0, 1};
    const Case measured{press, "none", "", 0, 1};
    SCOPED_TRACE(derived.name());
    const Recorded r = record(derived);
    const Analysis a = analyze(r, kWork + "/" + derived.name());
    const Analysis b = analyze(record(measured), kWork + "/" + measured.name());
    ASSERT_EQ(a.status, 0) << a.output;
    ASSERT_EQ(b.status, 0) << b.output;
    const double noise = a.summary["adequacy"]["noise_rms"].as<double>();
    const double error = a.summary["fit"]["simulation_error_rms"].as<double>();
    const double with_velocity = b.summary["fit"]["simulation_error_rms"].as<double>();
    std::printf("%-40s free run %.2fx noise (%.2fx with a velocity)\n", derived.name().c_str(), error / noise,
                with_velocity / noise);
    EXPECT_LT(error, 1.6 * with_velocity);
    EXPECT_LT(error, 2.0 * noise) << "within the noise, as the conclusion calls it";
    for (const char* name : {"bulk_modulus", "dead_volume", "valve_flow_gain"}) {
      const double truth = r.truth[name].as<double>();
      double std = 0.0;
      const double value = summaryParameter(a.summary, name, &std);
      std::printf("  %s %+.2f %% (%.2f stds)\n", name, 100.0 * (value / truth - 1.0), (value - truth) / std);
      EXPECT_LT(std::abs(value - truth), 3.0 * std) << name;
      EXPECT_NEAR(value / truth, 1.0, 0.01) << name;
    }
    EXPECT_EQ(missingVerdicts(a.summary), "") << a.summary["adequacy"]["conclusion"];
    EXPECT_EQ(a.summary["settings"]["resolution_limit"].as<std::string>("").find("velocity"),
              std::string::npos);
  }
}

// The same recording with every stamp moved by 0.5 ms (simulate_bag --epoch: the same plant, noise and
// commands) is the same recording. Its grid's points were k T: a fast press's position and velocity were read
// between their messages by a cubic, which misreads its 4 ms impact by up to 1 % of its speed in a pattern
// set by where the messages fall, and the bulk modulus moved from +0.14 to -1.07 % (variation 2) with the
// shift, over 250 recordings the fast presses' coverage fell to 52 %. The grid on the position's messages
// (grid_phase) reads both alike. A small stiff press's 15 ms impact keeps its grid and its 2 ms.
TEST_F(PressClasses, AFastPressReadsTheSameWhereverItsMessagesFall) {
  for (int variation : {1, 2}) {
    double bulk[2] = {0.0, 0.0};
    for (int shifted = 0; shifted < 2; ++shifted) {
      const Case c{"fast_mechanical", "none", shifted ? "--epoch 1700000000.0005" : "", variation, 5};
      SCOPED_TRACE(c.name());
      const Recorded r = record(c);
      const Analysis a = analyze(r, kWork + "/" + c.name());
      ASSERT_EQ(a.status, 0) << a.output;
      EXPECT_TRUE(a.summary["settings"]["grid_phase"]) << "the grid on the position's messages";
      double std = 0.0;
      const double truth = r.truth["bulk_modulus"].as<double>();
      const double value = summaryParameter(a.summary, "bulk_modulus", &std);
      std::printf("%-48s bulk modulus %+.2f %% (%.2f stds)\n", c.name().c_str(),
                  100.0 * (value / truth - 1.0), (value - truth) / std);
      EXPECT_LT(std::abs(value - truth), 3.0 * std);
      bulk[shifted] = value / truth - 1.0;
    }
    EXPECT_NEAR(bulk[1], bulk[0], 2e-4) << "the same recording read alike";
  }
  const Case stiff{"small_stiff", "none", "", 1, 5};
  const Analysis a = analyze(record(stiff), kWork + "/" + stiff.name());
  ASSERT_EQ(a.status, 0) << a.output;
  EXPECT_FALSE(a.summary["settings"]["grid_phase"]);
  EXPECT_EQ(a.summary["settings"]["sample_period"]["value"].as<double>(), 0.002);
}

// A valve topic slower than its amplifier (a 1 kHz controller reported at 250 Hz, on a fast press with the
// position at 500 Hz and both topics stamped late; scripts/press_matrix runs every class, four plants, 500
// and 250 Hz): the commands between the messages are not in the recording, and on a fast press the valve's
// fit to the spool then fails or bends, its free run 20-60 times the noise (and not converging as the period
// halves). A clean press is never told that physics is missing: the survey measures what the valve's rate
// leaves (valve_rate_error), and where the error left is beyond the noise it is called resolution-limited,
// with the valve rate to record at, not "structured".
TEST_F(PressClasses, AValveSlowerThanItsAmplifierIsNeverTakenForMissingPhysics) {
  std::vector<Case> cases = {
      {"fast_mechanical", "none", "--rates 2000,500,250 --stamp-offsets 0,0.012,0.006", 2, 510},
      {"small_stiff", "none", "--rates 1000,1000,250", 3, 1}};
  if (full()) {
    for (const std::string& press : kClasses) {
      for (int variation : {0, 1, 2, 3}) {
        for (const char* rate : {"500", "250"})
          cases.push_back({press, "none", std::string("--rates 1000,1000,") + rate, variation, 1});
      }
    }
  }
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name());
    const Analysis a = analyze(record(c), kWork + "/" + c.name());
    ASSERT_EQ(a.status, 0) << a.output;
    const YAML::Node& adequacy = a.summary["adequacy"];
    const double noise = adequacy["noise_rms"].as<double>();
    const double error = adequacy["best_error_rms"].as<double>();
    const bool limited = adequacy["resolution_limited"].as<bool>();
    std::printf("%-64s held-out %.2fx noise, valve-rate error %.3f bar, %s\n", c.name().c_str(),
                error / noise, 1e-5 * a.summary["settings"]["valve_rate_error"].as<double>(0.0),
                limited ? "resolution-limited" : "no limit named");
    EXPECT_EQ(missingVerdicts(a.summary), "") << adequacy["conclusion"];
    EXPECT_FALSE(adequacy["residual_unexplained"].as<bool>()) << adequacy["conclusion"];
    if (error > 4.0 * noise) {
      EXPECT_TRUE(limited) << adequacy["conclusion"];
      EXPECT_NE(adequacy["conclusion"].as<std::string>().find("record the valve topic at"), std::string::npos)
          << adequacy["conclusion"];
    }
  }
}

// The same valve rate with an effect in the plant (a fast press's valve overlap, the valve at 250 Hz): the
// effect is named, and what is left (14 bar, the valve's rate alone had been 3.9 bar on the model without
// the overlap) is not handed to a custom effect without the recording's own share and what to record.
TEST_F(PressClasses, WhatASlowValveTopicLeavesAfterAnEffectIsNamedAsTheRecordings) {
  const Case c{"fast_mechanical", "valve_overlap", "--rates 1000,1000,250", 1, 9};
  const Analysis a = analyze(record(c), kWork + "/" + c.name());
  ASSERT_TRUE(a.status == 0 || a.status == 5) << a.output;
  ASSERT_TRUE(a.summary["candidates"].size() > 0) << a.output;
  EXPECT_EQ(a.summary["candidates"][0]["effect"].as<std::string>(), "valve_overlap");
  const std::string conclusion = a.summary["adequacy"]["conclusion"].as<std::string>();
  if (a.summary["adequacy"]["residual_unexplained"].as<bool>()) {
    EXPECT_NE(conclusion.find("Part of it is the recording's own resolution"), std::string::npos)
        << conclusion;
    EXPECT_NE(conclusion.find("record the valve topic at"), std::string::npos) << conclusion;
  }
}

// A grid finer than the pressure's messages holds interpolations between them, whose second differences read
// the noise 7 times too small (0.03 against 0.21 bar at 0.5 ms from 1 kHz): a clean fast press's free run was
// "7.6 times the noise". The ranking and the refinement judge by the noise the grid's samples hold: the
// messages' own, times the root mean of w^2 + (1 - w)^2 over the grid (every second sample the mean of two
// messages at 0.5 ms: sqrt(3/4) of it, MessageNoise).
TEST_F(PressClasses, AGridFinerThanThePressureMessagesIsJudgedByTheNoiseItsSamplesHold) {
  for (const char* press : {"fast_mechanical", "small_stiff"}) {
    const Case c{press, "none", "--rates 1000,2000,1000", 1, 1};
    const Recorded r = record(c);
    std::ofstream(r.config, std::ios::app) << "sample_period: 0.0005\n";
    const Analysis a = analyze(r, kWork + "/" + c.name() + "_fine");
    ASSERT_EQ(a.status, 0) << a.output;
    const double noise = a.summary["adequacy"]["noise_rms"].as<double>();
    const double error = a.summary["adequacy"]["best_error_rms"].as<double>();
    std::printf("%-40s at 0.5 ms: noise %.3f bar, held-out error %.2fx noise\n", c.name().c_str(), 1e-5 * noise,
                error / noise);
    EXPECT_NEAR(noise, std::sqrt(0.75) * 0.2e5, 0.1 * 0.2e5)
        << "the simulated sensor's 0.2 bar, interpolated";
    EXPECT_LE(error, 2.0 * noise);
    EXPECT_EQ(missingVerdicts(a.summary), "") << a.summary["adequacy"]["conclusion"];
  }
}

// Power for an effect outside the library (issue 27): a leak as large as the library's leakage on that press
// (its conductance, effectParametersFor) but open only beyond 40 % of the stroke, like a groove the seal
// passes, `p*(x>x0)`, scaled by `size`. Found: the first `missing` formula is a stroke leak (x); explained:
// what the conclusion recommends (library effects and formulas) runs within 3 times the noise.
// DCI_FORMULA_POWER=N (scripts/formula_power) runs N plant variations of every class at sizes 1, 0.1, 0.03
// and 0.01 and 4, 6 and 8 cycles and prints the power curve; the suite runs one variation at size 1, 4 cycles.
TEST_F(PressClasses, AnEffectOutsideTheLibraryIsFoundOnFourToSixCycles) {
  const char* requested = std::getenv("DCI_FORMULA_POWER");
  const int variations = requested ? std::max(1, std::atoi(requested)) : 1;
  const std::vector<double> sizes = requested ? std::vector<double>{1.0, 0.1, 0.03, 0.01} : std::vector<double>{1.0};
  const std::vector<int> cycle_counts = requested ? std::vector<int>{4, 6, 8} : std::vector<int>{4};
  int full_size_found = 0, full_size_runs = 0;
  std::printf("%-16s %5s %6s %6s %10s %12s\n", "class", "size", "cycles", "found", "explained", "base/noise");
  for (const std::string& press : kClasses) {
    // Each plant's own library leak (its conductance) and 40 % of its stroke, from its truth, once.
    std::vector<std::pair<double, double>> leaks;  // per variation: conductance [m^3/(s Pa)], x0 [m]
    for (int variation = 1; variation <= variations; ++variation) {
      const Recorded leak = record(Case{press, "leakage", "", variation, 1});
      leaks.emplace_back(leak.truth["leakage_conductance"].as<double>(),
                         0.4 * YAML::LoadFile(leak.config)["stroke_length"].as<double>());
    }
    for (double size : sizes) {
      for (int cycles : cycle_counts) {
        int found = 0, explained = 0;
        std::vector<double> base_over_noise;
        for (int variation = 1; variation <= variations; ++variation) {
          const auto [conductance, x0] = leaks[variation - 1];
          Case c{press, "none",
                 formattedArguments("--custom-effect 'groove=p*(x>%g)' --set groove_theta=%g", x0, size * conductance),
                 variation, 1};
          c.cycles = cycles;
          const Analysis a = analyze(record(c), kWork + "/" + c.name());
          ASSERT_EQ(a.status, 0) << a.output;
          const YAML::Node adequacy = a.summary["adequacy"];
          const double noise = adequacy["noise_rms"].as<double>();
          base_over_noise.push_back(adequacy["held_out_error_rms"].as<double>() / noise);
          // What the conclusion recommends (library steps, then the first missing formula) runs within 3 times
          // the noise on held-out cycles.
          double recommended = adequacy["best_error_rms"].as<double>();
          bool right = false;
          for (const auto& p : a.summary["proposals"]) {
            if (p["verdict"].as<std::string>() != "missing") continue;
            const std::string expression = p["expression"].as<std::string>();
            right = expression.find("(x>") != std::string::npos || expression.find("(x<") != std::string::npos;
            recommended = std::min(recommended, p["held_out_error_rms"].as<double>());
            break;  // the first missing one is the one the conclusion recommends
          }
          explained += recommended <= 3.0 * noise ? 1 : 0;
          found += right ? 1 : 0;
          if (size == 1.0) {
            ++full_size_runs;
            full_size_found += right ? 1 : 0;
          }
        }
        std::sort(base_over_noise.begin(), base_over_noise.end());
        std::printf("%-16s %5.2f %6d %3d/%-2d %7d/%-2d %12.1f\n", press.c_str(), size, cycles, found, variations,
                    explained, variations, base_over_noise[base_over_noise.size() / 2]);
      }
    }
  }
  std::printf("as large as the library's leak, 4-8 cycles: found in %d of %d\n", full_size_found, full_size_runs);
  EXPECT_GE(full_size_found, 0.8 * full_size_runs);
}

// Two laws the library lacks (issue 47): a leak through a sharp edge, `sqrt(p)`, passing the press's library
// leak's flow at half the supply pressure, and a supply notch, the valve's supply edge passing 30 % more than
// its drain edge beyond an opening of -0.3, `-max(-0.3-y,0)*sqrt(pS-p)`. The search runs on what the
// recommended library model leaves above the structured-error floor; what the conclusion recommends (library
// steps, then the first missing formula) ends within 3 x the noise on held-out cycles, and the conclusion
// says what is left: "within the noise" only up to 2 x it. DCI_OUT_OF_LIBRARY=N (scripts/out_of_library_shapes)
// runs N plant variations of every class and prints the table; the suite runs three recordings.
TEST_F(PressClasses, ASharpEdgedLeakAndASupplyNotchEndWithinThreeTimesTheNoise) {
  const char* requested = std::getenv("DCI_OUT_OF_LIBRARY");
  const int variations = requested ? std::max(1, std::atoi(requested)) : 1;
  struct Shape {
    std::string name, press;
  };
  std::vector<Shape> runs;
  if (requested) {
    for (const std::string& press : kClasses) {
      for (const char* shape : {"orifice", "supply_notch"}) runs.push_back({shape, press});
    }
  } else {
    runs = {{"orifice", "small_stiff"}, {"orifice", "large_soft"}, {"supply_notch", "slow_hydraulic"}};
  }
  std::printf("%-13s %-16s %3s %10s %10s %10s  %s\n", "shape", "class", "var", "base/noise", "library",
              "recommended", "first missing proposal");
  for (const Shape& shape : runs) {
    for (int variation = 0; variation < variations; ++variation) {
      Case plant{shape.press, "leakage", "", variation, 1};
      plant.cycles = 1;
      const Recorded truth = record(plant);
      const double supply = YAML::LoadFile(truth.config)["supply_pressure"].as<double>();
      const std::string law =
          shape.name == "orifice"
              ? formattedArguments("--custom-effect 'orifice=sqrt(max(p,0))' --set orifice_theta=%g",
                                   truth.truth["leakage_conductance"].as<double>() * std::sqrt(0.5 * supply))
              : formattedArguments("--custom-effect 'notch=-max(-0.3-y,0)*sqrt(max(%.9g-p,0))' --set notch_theta=%g",
                                   supply, 0.3 * truth.truth["valve_flow_gain"].as<double>());
      const Case c{shape.press, "none", law, variation, 3};  // the law rides on the command line
      SCOPED_TRACE(c.name());
      const Analysis a = analyze(record(c), kWork + "/" + c.name());
      if (requested && a.status != 0) {  // the table says so (a large notch can make the base fit implausible)
        std::printf("%-13s %-16s %3d exit %d: %s\n", shape.name.c_str(), shape.press.c_str(), variation, a.status,
                    a.summary ? a.summary["warnings"][0].as<std::string>("").substr(0, 90).c_str() : "");
        continue;
      }
      ASSERT_EQ(a.status, 0) << a.output;
      const YAML::Node adequacy = a.summary["adequacy"];
      const double noise = adequacy["noise_rms"].as<double>(), library = adequacy["best_error_rms"].as<double>();
      double recommended = library;
      std::string proposal = "-";
      for (const auto& p : a.summary["proposals"]) {
        if (p["verdict"].as<std::string>() != "missing") continue;
        proposal = p["expression"].as<std::string>();
        recommended = std::min(recommended, p["held_out_error_rms"].as<double>());
        break;  // the first missing one is the one the conclusion recommends
      }
      const std::string conclusion = adequacy["conclusion"].as<std::string>();
      std::printf("%-13s %-16s %3d %10.1f %10.2f %10.2f  %s\n", shape.name.c_str(), shape.press.c_str(), variation,
                  adequacy["held_out_error_rms"].as<double>() / noise, library / noise, recommended / noise,
                  proposal.c_str());
      if (requested) continue;  // the nightly table states what it measured; the suite's three are asserted
      EXPECT_NE(proposal, "-") << conclusion;
      EXPECT_LE(recommended, 3.0 * noise) << conclusion;
      EXPECT_NE(conclusion.find("x the noise"), std::string::npos) << "what is left, against the noise: " << conclusion;
      EXPECT_EQ(conclusion.find("within the noise") != std::string::npos, recommended <= 2.0 * noise) << conclusion;
    }
  }
}

// Over many clean recordings across the classes, the share told that something is missing stays at or below
// the configured significance (5 %), judged by its 95 % Clopper-Pearson interval. DCI_PRESS_FALSE_ALARMS
// recordings (scripts/press_matrix: 100); the suite runs 8.
TEST_F(PressClasses, FalseAlarmsOnCleanPressesStayAtTheSignificance) {
  const char* requested = std::getenv("DCI_PRESS_FALSE_ALARMS");
  const int recordings = requested ? std::max(4, std::atoi(requested)) : 8;
  // DCI_PRESS_FALSE_ALARMS_FROM=N: start at the N-th recording (other plants and seeds, to check a figure on
  // recordings it was not measured on).
  const char* from = std::getenv("DCI_PRESS_FALSE_ALARMS_FROM");
  const int first = from ? std::max(0, std::atoi(from)) : 0;
  int alarms = 0;
  std::vector<double> p_values;  // every library candidate's held-out test, before Holm
  std::map<std::string, std::vector<double>> by_class;
  for (int k = first; k < first + recordings; ++k) {
    const Case c{kClasses[k % kClasses.size()], "none", "", 10 + k / static_cast<int>(kClasses.size()), 100 + k};
    const Recorded r = record(c);
    const Analysis a = analyze(r, kWork + "/" + c.name());
    ASSERT_EQ(a.status, 0) << a.output;
    for (const auto& candidate : a.summary["candidates"]) {
      if (!candidate["p_value"]) continue;
      p_values.push_back(candidate["p_value"].as<double>());
      by_class[c.press].push_back(p_values.back());
    }
    const std::string missing = missingVerdicts(a.summary);
    if (!missing.empty()) {
      ++alarms;
      std::printf("false alarm on %s:%s (%s)\n", c.name().c_str(), missing.c_str(),
                  a.summary["adequacy"]["conclusion"].as<std::string>().c_str());
    }
  }
  const double low = alarms == 0 ? 0.0 : boost::math::ibeta_inv(alarms, recordings - alarms + 1, 0.025);
  const double high = alarms == recordings ? 1.0 : boost::math::ibeta_inv(alarms + 1, recordings - alarms, 0.975);
  std::printf("false alarms: %d of %d clean recordings (%.1f %%, 95 %% interval %.1f-%.1f %%) at a significance of 5 %%\n",
              alarms, recordings, 100.0 * alarms / recordings, 100.0 * low, 100.0 * high);
  // The size of the held-out t test itself on clean plants (what a nominal level means here).
  for (double level : {0.05, 0.01}) {
    const int rejected = static_cast<int>(std::count_if(p_values.begin(), p_values.end(), [&](double p) { return p < level; }));
    const int tests = static_cast<int>(p_values.size());
    const double lo = rejected == 0 ? 0.0 : boost::math::ibeta_inv(rejected, tests - rejected + 1, 0.025);
    const double hi = rejected == tests ? 1.0 : boost::math::ibeta_inv(rejected + 1, tests - rejected, 0.975);
    std::printf("held-out t test on clean presses: p < %.2f in %d of %d candidate tests (%.1f %%, 95 %% interval "
                "%.1f-%.1f %%)\n", level, rejected, tests, 100.0 * rejected / std::max(tests, 1), 100.0 * lo,
                100.0 * hi);
    for (const auto& [press, ps] : by_class) {
      const auto below = std::count_if(ps.begin(), ps.end(), [&](double p) { return p < level; });
      std::printf("  %-16s p < %.2f in %d of %d\n", press.c_str(), level, static_cast<int>(below),
                  static_cast<int>(ps.size()));
    }
  }
  EXPECT_LE(low, 0.05) << "the rate is not above the significance";
  if (recordings < 40) {
    EXPECT_EQ(alarms, 0) << "none in the suite's few";
  }
}

// The reported stds mean what they say on recordings of every class, sensor configuration and effect (the
// right model configured): |estimate - truth| / std has a median near a Gaussian's 0.67 and 95 % of the
// errors lie within 1.96 std. Random plants (variations 1-60) and noise seeds; recordings the analysis
// flags as partial (exit 5: an implausible fit) are left out, as a user is told not to read them.
// DCI_PRESS_CALIBRATION=N recordings (scripts/uncertainty_calibration: 250, the median within 0.55-0.8 and
// the coverage within 93-97 %, pooled and on each press class); the suite runs 20, one per class and sensor
// configuration, with pooled bounds that hold for so few (about 19 estimates a class say little).
double medianOf(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// The share of |error| / std ratios within 1.96 (95 % for a Gaussian error with its true std).
double coverage(const std::vector<double>& v) {
  return static_cast<double>(std::count_if(v.begin(), v.end(), [](double r) { return r <= 1.96; })) /
         v.size();
}

TEST_F(PressClasses, StandardDeviationsAreCalibratedOverClassesSensorsAndEffects) {
  const char* requested = std::getenv("DCI_PRESS_CALIBRATION");
  const int recordings = requested ? std::max(20, std::atoi(requested)) : 20;
  // DCI_PRESS_CALIBRATION_EFFECTS=a,b (none: the base model) and DCI_PRESS_CALIBRATION_SENSORS (one sensor
  // configuration's simulate_bag options, "all" for all sensors): a part of the matrix alone.
  const char* effects_requested = std::getenv("DCI_PRESS_CALIBRATION_EFFECTS");
  const std::vector<std::string> effects =
      effects_requested
          ? die_cushion_ident::splitList(effects_requested)
          : std::vector<std::string>{"none", "leakage", "entrained_air", "valve_overlap", "tank_pressure"};
  ASSERT_FALSE(effects.empty());
  const char* sensors_requested = std::getenv("DCI_PRESS_CALIBRATION_SENSORS");
  const std::vector<std::string> sensor_configurations =
      sensors_requested
          ? std::vector<std::string>{std::string(sensors_requested) == "all" ? "" : sensors_requested}
          : kSensorConfigurations;
  // DCI_PRESS_CALIBRATION_SEED: another draw of plants and noise (to check the figures on recordings they
  // were not measured on).
  const char* seed = std::getenv("DCI_PRESS_CALIBRATION_SEED");
  std::mt19937 random(seed ? static_cast<std::uint32_t>(std::strtoul(seed, nullptr, 10)) : 20261125u);
  // DCI_PRESS_CALIBRATION_CSV=FILE: every estimate with its truth, its std and the std's parts, a line each
  // (to try another combination of the parts offline).
  const char* csv_path = std::getenv("DCI_PRESS_CALIBRATION_CSV");
  std::optional<die_cushion_ident::CsvFile> csv;
  if (csv_path) {
    csv.emplace(csv_path);
    // The estimate, its truth and its std's parts; then what the recording says of its own reconstruction
    // (the free run's error before and after the refinement, the settings' resolution errors, the valve fit).
    for (const char* column :
         {"recording", "press", "sensors", "effect", "variation", "seed", "parameter", "truth", "value",
          "std", "regression", "cycles", "free_run", "misfit", "method", "valve_model", "clock_offsets"})
      csv->text(column);
    for (const char* column : {"refined_used",         "free_run_error_before",  "free_run_error_after",
                               "free_run_samples",     "survey_pressure_noise",  "noise_rms",
                               "resolution_error",     "position_rate_error",    "valve_rate_error",
                               "numerical_error",      "free_run_spool",         "velocity_source",
                               "valve_fit_used",       "valve_fit_residual_rms", "valve_fit_noise",
                               "position_delay_shift", "position_delay_fit_std", "position_delay",
                               "valve_delay",          "common_fit_std",         "common_prior",
                               "valve_shift",          "equation_error_rms",     "simulation_error_rms",
                               "cycles_fitted"})
      csv->text(column);
    csv->endLine();
  }
  std::vector<double> ratios;
  std::map<std::string, std::vector<double>> by_group, by_class;
  int flagged = 0;
  const std::size_t configurations = sensor_configurations.size();
  for (int k = 0; k < recordings; ++k) {
    Case c;
    c.press = kClasses[(k / configurations) % kClasses.size()];
    c.sensors = sensor_configurations[k % configurations];
    c.effect = effects[(k / (configurations * kClasses.size()) + k) % effects.size()];
    c.variation = std::uniform_int_distribution<int>(1, 60)(random);
    c.seed = std::uniform_int_distribution<int>(1, 100000)(random);
    SCOPED_TRACE(c.name());
    const Recorded r = record(c);
    const Analysis a = analyze(r, kWork + "/calibration", c.effect == "none" ? "" : "--effects " + c.effect);
    if (a.status == 5) {
      ++flagged;
      continue;
    }
    ASSERT_EQ(a.status, 0) << a.output;
    const std::string sensors = c.sensors.empty() ? "all sensors" : c.sensors;
    for (const auto& p : a.summary["model"]["parameters"]) {
      const std::string name = p["name"].as<std::string>();
      if (!r.truth[name]) continue;
      const double ratio = std::abs(p["value"].as<double>() - r.truth[name].as<double>()) / p["std"].as<double>();
      ratios.push_back(ratio);
      by_class[c.press].push_back(ratio);
      by_group[sensors].push_back(ratio);
      by_group[name].push_back(ratio);
      by_group[c.press + ", " + sensors].push_back(ratio);
      if (csv) {
        const YAML::Node parts = p["std_parts"];
        csv->integer(k).text(c.press).quoted(sensors).text(c.effect).integer(c.variation).integer(c.seed);
        csv->text(name).number(r.truth[name].as<double>()).number(p["value"].as<double>());
        csv->number(p["std"].as<double>());
        for (const char* part :
             {"regression", "cycles", "free_run", "misfit", "method", "valve_model", "clock_offsets"})
          csv->number(parts[part].as<double>());
        // What the recording says of its own reconstruction, empty where the summary has no such value: to
        // scale a part for a reconstructed input's bias offline. `at`: the node at a path of keys, or a null
        // one where any of them is missing (reset rebinds the handle; assigning would write into the
        // summary).
        const auto at = [](const YAML::Node& root, std::initializer_list<const char*> keys) {
          YAML::Node n;
          n.reset(root);
          for (const char* key : keys) {
            if (!n.IsMap()) return YAML::Node();
            const YAML::Node& map = n;
            const YAML::Node child = map[key];
            if (!child) return YAML::Node();
            n.reset(child);
          }
          return n;
        };
        const auto number = [&](std::initializer_list<const char*> keys) {
          const YAML::Node n = at(a.summary, keys);
          return n && n.IsScalar() ? n.as<double>() : std::numeric_limits<double>::quiet_NaN();
        };
        const auto word = [&](std::initializer_list<const char*> keys) {
          const YAML::Node n = at(a.summary, keys);
          return n && n.IsScalar() ? n.as<std::string>() : std::string("-");
        };
        const auto flag = [&](std::initializer_list<const char*> keys) {
          const YAML::Node n = at(a.summary, keys);
          return n && n.IsScalar() && n.as<bool>() ? 1 : 0;
        };
        csv->integer(flag({"model", "refined_by_free_run", "used"}));
        csv->number(number({"model", "refined_by_free_run", "free_run_error_before"}));
        csv->number(number({"model", "refined_by_free_run", "free_run_error_after"}));
        csv->number(number({"model", "refined_by_free_run", "samples"}));
        csv->number(number({"settings", "survey", "pressure_noise"}))
            .number(number({"adequacy", "noise_rms"}));
        for (const char* key :
             {"resolution_error", "position_rate_error", "valve_rate_error", "numerical_error"})
          csv->number(number({"settings", key}));
        csv->text(word({"settings", "free_run_spool"})).quoted(word({"input", "velocity"}));
        csv->integer(flag({"settings", "valve_from_operation", "used"}));
        csv->number(number({"settings", "valve_from_operation", "residual_rms"}));
        csv->number(number({"settings", "valve_from_operation", "noise"}));
        csv->number(number({"settings", "position_delay_refined_by_free_run", "shift"}));
        csv->number(number({"settings", "position_delay_refined_by_free_run", "fit_std"}));
        csv->number(number({"input", "topic_delays", "position"}));
        csv->number(number({"input", "topic_delays", "valve"}));
        csv->number(number({"settings", "position_delay_refined_by_free_run", "common_fit_std"}));
        csv->number(number({"settings", "position_delay_refined_by_free_run", "common_prior"}));
        csv->number(number({"settings", "position_delay_refined_by_free_run", "valve_shift"}));
        csv->number(number({"fit", "equation_error_rms"})).number(number({"fit", "simulation_error_rms"}));
        csv->number(number({"fit", "cycles"}));
        csv->endLine();
      }
    }
  }
  if (csv) csv->close();
  for (const auto& [group, v] : by_group) {
    std::printf("  %-48s %4zu estimates: median |error|/std %.2f, within 1.96 std %.1f %%\n", group.c_str(),
                v.size(), medianOf(v), 100.0 * coverage(v));
  }
  for (const auto& [press, v] : by_class) {
    std::printf("  class %-16s %4zu estimates: median |error|/std %.2f, within 1.96 std %.1f %%\n",
                press.c_str(), v.size(), medianOf(v), 100.0 * coverage(v));
  }
  ASSERT_FALSE(ratios.empty());
  std::printf(
      "|error| / std over %d recordings (%d flagged partial and left out), %zu estimates: median %.2f, "
      "within 1.96 std %.1f %%\n",
      recordings, flagged, ratios.size(), medianOf(ratios), 100.0 * coverage(ratios));
  if (recordings >= 200) {
    EXPECT_GE(medianOf(ratios), 0.55);
    EXPECT_LE(medianOf(ratios), 0.80);
    EXPECT_GE(coverage(ratios), 0.93);
    EXPECT_LE(coverage(ratios), 0.97);
    // Each press class on its own (about 240 estimates each): a class whose stds are too wide for most of
    // its estimates and too short for a few can hide in the pooled figures.
    for (const auto& [press, v] : by_class) {
      EXPECT_GE(medianOf(v), 0.55) << press;
      EXPECT_LE(medianOf(v), 0.80) << press;
      EXPECT_GE(coverage(v), 0.93) << press;
      EXPECT_LE(coverage(v), 0.97) << press;
    }
  } else {
    // ~75 estimates: the median's and the coverage's own scatter.
    EXPECT_GE(medianOf(ratios), 0.35);
    EXPECT_LE(medianOf(ratios), 1.0);
    EXPECT_GE(coverage(ratios), 0.85);
  }
  EXPECT_LE(flagged, std::max(1, recordings / 50));
}

// A library effect that starts within the recording (simulate_bag --effects-from-cycle) is named, with the
// press cycle it starts in: the first cycle whose impact comes after it started, within one either side.
// DCI_PRESS_ONSETS=N recordings of a leak starting at a random cycle (3-7 of 10) on random plants of every
// class and sensor configuration (scripts/press_matrix: 50; at least 90 % named with their cycle); the
// suite runs one leak per class and, on two classes, air and a valve overlap.
TEST_F(PressClasses, AnEffectThatStartsWithinTheRecordingIsNamedWithItsCycle) {
  const char* requested = std::getenv("DCI_PRESS_ONSETS");
  const int recordings = requested ? std::max(4, std::atoi(requested)) : 6;
  std::mt19937 random(27);
  int named = 0;
  for (int k = 0; k < recordings; ++k) {
    Case c;
    // The suite's air on the paper's press, its overlap on a small stiff chamber (on a fast press an overlap
    // that starts was taken for air in 2 of 6 recordings: its free run after the step tells them apart
    // less well than the chamber's).
    c.press = requested || k < 4 ? kClasses[k % kClasses.size()] : k == 4 ? "slow_hydraulic" : "small_stiff";
    c.effect = requested || k < 4 ? "leakage" : k == 4 ? "entrained_air" : "valve_overlap";
    c.sensors = requested ? kSensorConfigurations[(k / kClasses.size()) % kSensorConfigurations.size()] : "";
    c.variation = std::uniform_int_distribution<int>(1, 60)(random);
    c.seed = std::uniform_int_distribution<int>(1, 100000)(random);
    c.onset = std::uniform_int_distribution<int>(3, 7)(random);
    SCOPED_TRACE(c.name());
    const Recorded r = record(c);
    const Analysis a = analyze(r, kWork + "/onset");
    ASSERT_TRUE(a.status == 0 || a.status == 5) << a.output;
    const YAML::Node change = a.summary["change_within_recording"];
    bool right = false;
    if (change) {
      // The cycle the truth falls in, counted from the named one by the cycles' period.
      const double cycles_off = (r.truth["effects_from_time"].as<double>() - change["from_time"].as<double>()) /
                                change["cycle_period"].as<double>();
      const int expected = change["from_cycle"].as<int>() + static_cast<int>(std::ceil(cycles_off - 1e-9));
      right = change["effect"].as<std::string>() == c.effect && std::abs(expected - change["from_cycle"].as<int>()) <= 1;
      std::printf("%-56s named %s from cycle %d (truth: cycle %d), t = %.1f\n", c.name().c_str(),
                  change["effect"].as<std::string>().c_str(), change["from_cycle"].as<int>(), expected,
                  change["t_statistic"].as<double>());
    } else {
      std::printf("%-56s nothing named\n", c.name().c_str());
    }
    named += right ? 1 : 0;
    if (!requested) {
      EXPECT_TRUE(right) << (change ? change["explanation"].as<std::string>() : std::string("none"));
    }
  }
  std::printf("effects starting within the recording named with their cycle: %d of %d\n", named, recordings);
  EXPECT_GE(named, 0.9 * recordings);
}
