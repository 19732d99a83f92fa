// The oil's temperature end to end (issue 46): simulate_bag records the oil temperature topic and makes the
// plant follow it; analyze_bag reads it like the other inputs, names the oil's warming within a recording as
// the missing effect, explains the drift with it, and reports the parameters at the reference temperature;
// bad temperature messages are rejected, counted and said, and lose nothing; analyze_trend compares the
// recordings at the reference temperature and states the smallest change it can see, with and without the
// topic. The 20-series acceptance is scripts/oil_temperature_trend.
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Temperature.h>
#include <std_msgs/Float64.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <functional>
#include <string>

#include "bag_analysis.h"
#include "tool_runner.h"

namespace {

const std::string kTools = TOOL_DIR;
const std::string kWork = die_cushion_ident::testing::workDirectory("test_oil_temperature");
constexpr double kFirstDay = 1772582400.0;  // 2026-03-04T00:00:00Z

using die_cushion_ident::testing::CommandResult;

CommandResult run(const std::string& command) {
  return die_cushion_ident::testing::runCommand(command, kWork + "/last_output.txt");
}

class OilTemperature : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { std::system(("rm -rf " + kWork + " && mkdir -p " + kWork).c_str()); }

  static YAML::Node analyze(const std::string& bag, const std::string& out, const std::string& extra) {
    const CommandResult r =
        run(kTools + "/analyze_bag " + bag + " --out " + kWork + "/" + out + " --quiet " + extra);
    EXPECT_EQ(r.status, 0) << r.output;
    return YAML::LoadFile(kWork + "/" + out + "/summary.yaml");
  }
};

double truthOf(const std::string& truth_file, const std::string& name) {
  return YAML::LoadFile(truth_file)[name].as<double>();
}

// A parameter at the reference temperature (value, and its std into `std`).
double atReference(const YAML::Node& summary, const std::string& name, double* std = nullptr) {
  for (const auto& p : summary["reference_temperature"]["parameters"]) {
    if (p["name"].as<std::string>() != name) continue;
    if (std) *std = p["std"].as<double>();
    return p["value"].as<double>();
  }
  ADD_FAILURE() << "no " << name << " at the reference temperature";
  return NAN;
}

bool anyCandidateMissing(const YAML::Node& summary) {
  for (const auto& c : summary["candidates"]) {
    if (c["verdict"].as<std::string>() == "missing") return true;
  }
  return false;
}

// The oil warms by 20 K while 8 press cycles are recorded (a worn seal in the plant and in the model): the
// oil's temperature is the missing effect, with it the free run is within 2 x the noise and nothing else is
// missing, and the parameters at 40 degC are the plant's (its truth holds there). Two press classes, two
// oils.
TEST_F(OilTemperature, AWarmingOilIsNamedAndWithItTheRecordingReadsClean) {
  struct Case {
    const char* press;
    const char* law;
  };
  for (const Case& c : {Case{"slow_hydraulic", "-0.0045,0.045"}, Case{"fast_mechanical", "-0.003,0.04"}}) {
    SCOPED_TRACE(c.press);
    const std::string name = std::string(kWork) + "/warm_" + c.press;
    ASSERT_EQ(run(kTools + "/simulate_bag " + name + ".bag --press " + c.press +
                  " --variation 3 --cycles 8 --plant-effects leakage --oil-temperature 40,60 --oil-law " +
                  c.law + " --seed 5 --write-config " + name + ".yaml --write-truth " + name + "_truth.yaml")
                  .status,
              0);
    // The model the user configured: a worn seal; its oil's leakage coefficient as the plant's.
    const double beta = std::stod(std::string(c.law).substr(std::string(c.law).find(',') + 1));
    std::ofstream(name + ".yaml", std::ios::app) << "leakage_temperature_coefficient: " << beta << "\n";
    const YAML::Node seal = analyze(name + ".bag", std::string("seal_") + c.press,
                                    "--config " + name + ".yaml --effects leakage");
    // The temperature as read: its topic, the recording's mean and range.
    const YAML::Node topic = seal["input"]["topics"]["oil_temperature"];
    ASSERT_TRUE(topic.IsMap()) << "the topic's health like the other inputs'";
    EXPECT_NEAR(topic["rate"].as<double>(), 2.0, 0.01);
    EXPECT_EQ(topic["rejected"].as<int>(), 0);
    EXPECT_NEAR(seal["oil_temperature"]["mean"].as<double>(), 50.0, 0.5);
    EXPECT_NEAR(seal["oil_temperature"]["min"].as<double>(), 40.0, 0.5);
    EXPECT_NEAR(seal["oil_temperature"]["max"].as<double>(), 60.0, 0.5);
    const YAML::Node top = seal["candidates"][0];
    EXPECT_EQ(top["effect"].as<std::string>(), "oil_temperature");
    EXPECT_EQ(top["verdict"].as<std::string>(), "missing") << top["explanation"];
    EXPECT_NE(
        top["explanation"].as<std::string>().find("the bulk modulus follows the oil temperature at -0."),
        std::string::npos)
        << top["explanation"];
    ASSERT_GE(seal["steps"].size(), 1u);
    EXPECT_EQ(seal["steps"][0]["add"].as<std::string>(), "oil_temperature");

    const YAML::Node oil = analyze(name + ".bag", std::string("oil_") + c.press,
                                   "--config " + name + ".yaml --effects leakage,oil_temperature");
    const double noise = oil["adequacy"]["noise_rms"].as<double>();
    EXPECT_LE(oil["fit"]["simulation_error_rms"].as<double>(), 2.0 * noise)
        << "the free run within 2 x the noise";
    EXPECT_FALSE(anyCandidateMissing(oil)) << oil["adequacy"]["conclusion"];
    EXPECT_EQ(oil["reference_temperature"]["temperature"].as<double>(), 40.0);
    // The plant's truth holds at 40 degC: within 3 of the reported stds, and a few percent.
    for (const char* parameter : {"bulk_modulus", "leakage_conductance"}) {
      double std = 0.0;
      const double value = atReference(oil, parameter, &std);
      const double truth = truthOf(name + "_truth.yaml", parameter);
      EXPECT_NEAR(value, truth, 3.0 * std) << parameter << " at 40 degC";
      EXPECT_NEAR(value / truth, 1.0, 0.04) << parameter << " at 40 degC";
    }
    EXPECT_NEAR(atReference(oil, "bulk_modulus_temperature_coefficient"),
                truthOf(name + "_truth.yaml", "bulk_modulus_temperature_coefficient"), 0.0008)
        << "the coefficient within 0.08 %/K";
  }
}

// A copy of `in` with its oil temperature messages passed through `change` (index, message; false drops it).
void rewriteTemperature(const std::string& in, const std::string& out,
                        const std::function<bool(int, sensor_msgs::Temperature&)>& change) {
  rosbag::Bag source(in, rosbag::bagmode::Read);
  rosbag::Bag target(out, rosbag::bagmode::Write);
  int index = 0;
  for (const rosbag::MessageInstance& m : rosbag::View(source)) {
    if (m.getTopic() == "/die_cushion/oil_temperature") {
      auto msg = m.instantiate<sensor_msgs::Temperature>();
      if (change(index++, *msg)) target.write(m.getTopic(), m.getTime(), *msg);
    } else {
      target.write(m.getTopic(), m.getTime(), m, m.getConnectionHeader());
    }
  }
}

// NaN and absurd temperatures, a spike, a silent minute and a topic of the wrong type: each rejected,
// counted and said; the analysis goes on with the good messages and its parameters at the reference
// temperature stay those of the clean recording.
TEST_F(OilTemperature, BadTemperatureMessagesAreRejectedCountedSaidAndLoseNothing) {
  const std::string bag = kWork + "/steady";
  ASSERT_EQ(run(kTools + "/simulate_bag " + bag +
                ".bag --press small_stiff --variation 2 --cycles 5 "
                "--plant-effects leakage --oil-temperature 55 --seed 9 --write-config " +
                bag + ".yaml")
                .status,
            0);
  // The last temperature holds 1 s (default 10 s): a silence of 2.5 s in the 9 s recording leaves 0.5 s
  // unknown.
  std::ofstream(bag + ".yaml", std::ios::app) << "oil_temperature_max_age: 1\n";
  const YAML::Node clean = analyze(bag + ".bag", "clean", "--config " + bag + ".yaml --effects leakage");
  EXPECT_EQ(clean["input"]["topics"]["oil_temperature"]["messages"].as<int>(), 18) << "2 Hz over 9 s";
  rewriteTemperature(bag + ".bag", bag + "_bad.bag", [](int i, sensor_msgs::Temperature& m) {
    if (i == 3 || i == 4) m.temperature = std::nan("");
    if (i == 7) m.temperature = 1e6;     // absurd
    if (i == 9) m.temperature = -300.0;  // below absolute zero
    if (i == 12) m.temperature += 25.0;  // a spike the next message does not confirm
    return !(i >= 13 && i < 17);         // 2.5 s silent
  });
  const YAML::Node bad = analyze(bag + "_bad.bag", "bad", "--config " + bag + ".yaml --effects leakage");
  const YAML::Node topic = bad["input"]["topics"]["oil_temperature"];
  EXPECT_EQ(topic["implausible"].as<int>(), 3) << "two out of range, one spike";
  EXPECT_EQ(topic["rejected"].as<int>(), 5) << "and two NaN";
  EXPECT_GE(topic["gaps"].as<int>(), 1) << "the silence";
  const std::string rejected = die_cushion_ident::testing::warningWithCode(bad, "messages_rejected");
  EXPECT_NE(rejected.find("oil temperature messages rejected"), std::string::npos) << rejected;
  EXPECT_NE(rejected.find("2 not finite (NaN)"), std::string::npos) << rejected;
  EXPECT_NE(rejected.find("1 jumping faster"), std::string::npos) << rejected;
  const std::string silent = die_cushion_ident::testing::warningWithCode(bad, "oil_temperature");
  EXPECT_NE(silent.find("silent for"), std::string::npos) << silent;
  EXPECT_NEAR(bad["oil_temperature"]["mean"].as<double>(), clean["oil_temperature"]["mean"].as<double>(),
              0.05);
  for (const char* parameter : {"bulk_modulus", "leakage_conductance"}) {
    double std = 0.0;
    const double value = atReference(bad, parameter, &std);
    EXPECT_NEAR(value, atReference(clean, parameter), 0.2 * std) << parameter << ": nothing lost";
  }
  EXPECT_EQ(bad["candidates"][0]["effect"].as<std::string>(),
            clean["candidates"][0]["effect"].as<std::string>());

  // A topic of another type under the name: the temperature is not read, the analysis is the one without it.
  rewriteTemperature(bag + ".bag", bag + "_plain.bag", [](int, sensor_msgs::Temperature&) { return false; });
  {
    rosbag::Bag wrong(bag + "_wrong.bag", rosbag::bagmode::Write);
    rosbag::Bag source(bag + "_plain.bag", rosbag::bagmode::Read);
    for (const rosbag::MessageInstance& m : rosbag::View(source))
      wrong.write(m.getTopic(), m.getTime(), m, m.getConnectionHeader());
    std_msgs::Float64 value;
    value.data = 55.0;
    wrong.write("/die_cushion/oil_temperature", ros::Time(1.7e9 + 1.0), value);
  }
  const YAML::Node plain =
      analyze(bag + "_plain.bag", "plain", "--config " + bag + ".yaml --effects leakage");
  const YAML::Node wrong =
      analyze(bag + "_wrong.bag", "wrong", "--config " + bag + ".yaml --effects leakage");
  EXPECT_NE(
      die_cushion_ident::testing::warningWithCode(wrong, "oil_temperature").find("has type std_msgs/Float64"),
      std::string::npos);
  EXPECT_FALSE(wrong["oil_temperature"]) << "no temperature section without a temperature";
  EXPECT_FALSE(plain["reference_temperature"]);
  EXPECT_EQ(wrong["model"]["parameters"][0]["value"].as<double>(),
            plain["model"]["parameters"][0]["value"].as<double>())
      << "the same analysis as without the topic";
  for (const auto& c : plain["candidates"]) EXPECT_NE(c["effect"].as<std::string>(), "oil_temperature");
}

// Eleven daily recordings of a press whose oil is at another temperature each day (25-60 degC) and whose
// seal's leakage at 40 degC rises 10 % from day 8: compared at 40 degC the rise is reported within 3
// recordings, dated to day 8 +- 1; trend.yaml says what it tracked and, on the 8 recordings before the rise,
// the smallest change it can see. The same recordings read without their temperature topic: the
// oil's swing is in the scatter, the smallest detectable change is stated from it (and larger), and
// trend.yaml says why.
TEST_F(OilTemperature, TheTrendComparesAtTheReferenceTemperatureAndStatesWhatItCanSee) {
  const double oil[] = {31.0, 52.0, 27.0, 44.0, 58.0, 36.0, 49.0, 29.0, 55.0, 41.0, 33.0};
  constexpr int kDays = 11, kRise = 8;
  const std::string bags = kWork + "/days";
  ASSERT_EQ(std::system(("mkdir -p " + bags).c_str()), 0);
  double leakage = 0.0;
  for (int day = 0; day < kDays; ++day) {
    char command[512];
    std::snprintf(
        command, sizeof(command),
        "%s/simulate_bag %s/day%02d.bag --press fast_mechanical --variation 4 --cycles 4 --plant-effects "
        "leakage --oil-temperature %.1f --seed %d --epoch %.0f --write-config %s/press.yaml "
        "--write-truth %s/truth.yaml",
        kTools.c_str(), bags.c_str(), day, oil[day], 100 + day, kFirstDay + 86400.0 * day, kWork.c_str(),
        kWork.c_str());
    std::string line = command;
    if (day == 0) {
      ASSERT_EQ(run(line).status, 0);
      leakage = truthOf(kWork + "/truth.yaml", "leakage_conductance");
    }
    char rise[64];
    std::snprintf(rise, sizeof(rise), " --set leakage_conductance=%.6g", 1.1 * leakage);
    if (day >= kRise) line += rise;
    ASSERT_EQ(run(line).status, 0);
  }
  const auto trend = [&](const std::string& out, const std::string& config) {
    const CommandResult r = run(kTools + "/analyze_trend " + bags + " --out " + kWork + "/" + out +
                                " --effects leakage --config " + config + " --jobs 2");
    EXPECT_EQ(r.status, 0) << r.output;
    return YAML::LoadFile(kWork + "/" + out + "/trend.yaml");
  };
  const YAML::Node warm = trend("trend", kWork + "/press.yaml");
  EXPECT_EQ(warm["oil_temperature"]["tracked"].as<std::string>(), "at_reference_temperature");
  EXPECT_EQ(warm["oil_temperature"]["recordings_with"].as<int>(), kDays);
  ASSERT_EQ(warm["changes"].size(), 1u) << warm;
  const YAML::Node change = warm["changes"][0];
  EXPECT_EQ(change["parameter"].as<std::string>(), "leakage_conductance");
  const int start_day =
      static_cast<int>(std::lround((change["start_stamp"].as<double>() - kFirstDay) / 86400.0));
  std::tm alarm{};
  ASSERT_TRUE(strptime(change["alarm"].as<std::string>().c_str(), "%Y-%m-%dT%H:%M:%SZ", &alarm));
  const int alarm_day =
      static_cast<int>(std::lround((static_cast<double>(timegm(&alarm)) - kFirstDay) / 86400.0));
  EXPECT_GE(alarm_day, kRise) << "nothing before the rise";
  EXPECT_LE(alarm_day, kRise + 2) << "reported within 3 recordings of the rise";
  EXPECT_NEAR(start_day, kRise, 1) << "dated to the onset +- 1 recording";
  EXPECT_EQ(change["at_temperature"].as<double>(), 40.0);
  EXPECT_NEAR(change["after"].as<double>() / change["before"].as<double>(), 1.10, 0.04)
      << "the rise at 40 degC";
  // What the test can see before the rise (the first 8 recordings), with and without the temperature topic
  // (the config reads another: as recorded, the oil's swing of +4.5 %/K over 31 K is in the scatter).
  std::string history;
  for (int day = 0; day < kRise; ++day) history += " " + bags + "/day0" + std::to_string(day) + ".bag";
  const auto smallest = [&](const std::string& out, const std::string& config) {
    const CommandResult r = run(kTools + "/analyze_trend" + history + " --out " + kWork + "/" + out +
                                " --effects leakage --config " + config + " --jobs 2");
    EXPECT_EQ(r.status, 0) << r.output;
    const YAML::Node t = YAML::LoadFile(kWork + "/" + out + "/trend.yaml");
    EXPECT_EQ(t["changes"].size(), 0u) << "nothing before the rise";
    for (const auto& d : t["detectable_changes"]) {
      if (d["parameter"].as<std::string>() == "leakage_conductance")
        return std::make_pair(d["relative"].as<double>(NAN), t);
    }
    return std::make_pair(static_cast<double>(NAN), t);
  };
  const double leakage_detectable = smallest("trend", kWork + "/press.yaml").first;
  std::ofstream(kWork + "/blind.yaml")
      << YAML::LoadFile(kWork + "/press.yaml") << "\ntopics: {oil_temperature: /none}\n";
  const auto [blind_detectable, blind] = smallest("trend_blind", kWork + "/blind.yaml");
  EXPECT_EQ(blind["oil_temperature"]["tracked"].as<std::string>(), "as_recorded");
  EXPECT_NE(blind["oil_temperature"]["note"].as<std::string>().find("no recording holds an oil temperature"),
            std::string::npos);
  std::printf(
      "smallest detectable leakage change after 8 recordings: %.1f %% at 40 degC, %.1f %% as recorded\n",
      100.0 * leakage_detectable, 100.0 * blind_detectable);
  // After 8 recordings it promises a 30 % rise within 3 recordings in 9 of 10 futures: a recording made on a
  // cold day has a leakage 2.5 times smaller and its std 5 times larger (here 0.35-2.6 %), and a 10 % rise
  // shows only on warm days (found here on the second, at 41 degC).
  EXPECT_LT(leakage_detectable, 0.5);
  EXPECT_GT(blind_detectable, 3.0 * leakage_detectable) << "the weather hides what wears";
  EXPECT_GT(blind_detectable, 0.3) << "stated from the scatter the oil's swing makes";
}

}  // namespace
