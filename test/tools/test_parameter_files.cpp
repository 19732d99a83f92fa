// The example parameter files in params/ are the documented defaults: every key they show, set or commented
// out, holds the value the code uses when the key is not given, and the files load without a problem.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <map>
#include <regex>
#include <string>

#include "analysis_config.h"
#include "die_cushion_ident/LiveThresholdsConfig.h"
#include "die_cushion_ident/core/estimation/identification_config.h"
#include "die_cushion_ident/core/valve/valve_sweep.h"
#include "live_thresholds.h"
#include "ros_parameters.h"

namespace die_cushion_ident {
namespace {

const std::string kParams = PARAMS_DIR;

// Every `key: value` line of the file, also those commented out ("# key: value  # why").
std::map<std::string, YAML::Node> shownValues(const std::string& path) {
  std::map<std::string, YAML::Node> shown;
  std::ifstream in(path);
  const std::regex line(R"(^#?\s*([a-z_]+):\s*([^#]*[^#\s])\s*(#.*)?$)");
  std::smatch m;
  for (std::string text; std::getline(in, text);) {
    if (!std::regex_match(text, m, line) || m[2].str().empty()) continue;
    shown[m[1].str()] = YAML::Load(m[2].str());
  }
  return shown;
}

bool same(double shown, double actual) {
  return (std::isnan(shown) && std::isnan(actual)) || shown == actual;
}

TEST(ParameterFiles, IdentificationDefaultsAreTheCodes) {
  const std::string path = kParams + "/identification.yaml";
  IdentificationConfig config;
  InputTopics topics;
  std::vector<std::string> keys;
  const std::vector<std::string> problems = loadAnalysisConfig(path, &config, &topics, &keys);
  EXPECT_TRUE(problems.empty()) << problems.front();
  EXPECT_TRUE(config.validate().empty());
  const std::map<std::string, YAML::Node> shown = shownValues(path);
  const IdentificationConfig defaults;
  for (const std::string& key : numericConfigKeys()) {
    if (key.rfind("topic_delays/", 0) == 0) {
      EXPECT_TRUE(shown.count("topic_delays")) << "topic_delays is not shown";
      continue;
    }
    ASSERT_TRUE(shown.count(key)) << key << " is not shown in " << path;
    EXPECT_TRUE(same(shown.at(key).as<double>(), numericConfigValue(defaults, key)))
        << key << ": the file shows " << shown.at(key).as<std::string>() << ", the code uses "
        << numericConfigValue(defaults, key);
  }
  EXPECT_EQ(shown.at("regression_form").as<std::string>(), regressionFormName(defaults.regression_form));
  // Loaded, the file changes nothing: the configuration is the default one.
  for (const std::string& key : numericConfigKeys()) {
    EXPECT_TRUE(same(numericConfigValue(config, key), numericConfigValue(defaults, key))) << key;
  }
}

TEST(ParameterFiles, NodeSettingsAndSweepLimitsAreTheCodes) {
  const std::string path = kParams + "/node.yaml";
  const std::map<std::string, YAML::Node> shown = shownValues(path);
  const SweepLimits limits;
  for (const std::string& key : sweepLimitKeys()) {
    ASSERT_TRUE(shown.count(key)) << key << " is not shown in " << path;
    EXPECT_TRUE(same(shown.at(key).as<double>(), sweepLimitValue(limits, key))) << key;
  }
  const NodeSettings settings;
  const std::map<std::string, double> numbers = {
      {"survey_seconds", settings.survey_seconds},
      {"effect_ranking_window", settings.effect_ranking_window},
      {"effect_ranking_period", settings.effect_ranking_period},
      {"adequacy_warn_error", settings.adequacy_warn_error},
      {"adequacy_error_error", settings.adequacy_error_error},
      {"valve_gain", settings.valve_gain},
      {"feed_forward_max_age", settings.feed_forward_max_age},
      {"feed_forward_slew_rate", settings.feed_forward_slew_rate},
      {"feed_forward_parameter_rate", settings.feed_forward_parameter_rate},
      {"feed_forward_max_lead", settings.feed_forward_max_lead},
      {"feed_forward_rate_window", settings.feed_forward_rate_window},
      {"feed_forward_max_setpoint_rate", settings.feed_forward_max_setpoint_rate}};
  for (const auto& [key, value] : numbers) {
    ASSERT_TRUE(shown.count(key)) << key << " is not shown in " << path;
    EXPECT_TRUE(same(shown.at(key).as<double>(), value)) << key;
  }
  EXPECT_EQ(shown.at("choose_settings").as<bool>(), settings.choose_settings);
  EXPECT_EQ(shown.at("feed_forward_enabled").as<bool>(), settings.feed_forward_enabled);
  // Every key the file sets is one the node reads (a typo would be a silently ignored parameter).
  std::size_t known = sweepLimitKeys().size() + numbers.size() + 2;
  EXPECT_EQ(shown.size(), known) << "a key in " << path << " the test does not know";
}

// cfg/LiveThresholds.cfg repeats the node's defaults, names and ranges for dynamic_reconfigure (which clamps
// to its own ranges before the node sees a value): a drift would start the server from other values than the
// node's, or clamp a value the node allows.
TEST(ParameterFiles, LiveThresholdsReconfigureTheNodesOwnSettingsWithinItsRanges) {
  const LiveThresholdsConfig defaults = LiveThresholdsConfig::__getDefault__();
  const LiveThresholdsConfig lowest = LiveThresholdsConfig::__getMin__();
  const LiveThresholdsConfig highest = LiveThresholdsConfig::__getMax__();
  const NodeSettings settings;
  EXPECT_EQ(defaults.adequacy_warn_error, settings.adequacy_warn_error);
  EXPECT_EQ(defaults.adequacy_error_error, settings.adequacy_error_error);
  EXPECT_EQ(defaults.effect_ranking_window, settings.effect_ranking_window);
  EXPECT_EQ(defaults.effect_ranking_period, settings.effect_ranking_period);
  // The window's bounds are the node's own, both allowed; the others are positive and unbounded above.
  NodeSettings at_bounds = settings;
  at_bounds.effect_ranking_window = lowest.effect_ranking_window;
  EXPECT_TRUE(liveThresholdProblems(at_bounds).empty()) << liveThresholdProblems(at_bounds).front();
  at_bounds.effect_ranking_window = highest.effect_ranking_window;
  EXPECT_TRUE(liveThresholdProblems(at_bounds).empty()) << liveThresholdProblems(at_bounds).front();
  at_bounds.effect_ranking_window = std::nextafter(highest.effect_ranking_window, 1e9);
  EXPECT_FALSE(liveThresholdProblems(at_bounds).empty());
  for (const double bound :
       {lowest.adequacy_warn_error, lowest.adequacy_error_error, lowest.effect_ranking_period}) {
    EXPECT_EQ(bound, 0.0) << "the node allows every positive value";
  }
  for (const double bound :
       {highest.adequacy_warn_error, highest.adequacy_error_error, highest.effect_ranking_period}) {
    EXPECT_TRUE(std::isinf(bound)) << "the node allows every positive value";
  }
  // Each is a parameter of the node, shown in params/node.yaml.
  const std::map<std::string, YAML::Node> shown = shownValues(kParams + "/node.yaml");
  for (const auto& parameter : LiveThresholdsConfig::__getParamDescriptions__()) {
    EXPECT_TRUE(shown.count(parameter->name)) << parameter->name << " is no parameter of the node";
  }
}

// A dynamic_reconfigure request is applied whole or not at all: a value the node would refuse at start-up
// keeps every threshold as it was, and the server is told the values that stay.
TEST(ParameterFiles, ALiveThresholdRequestIsAppliedOnlyWhenTheNodeAcceptsIt) {
  NodeSettings settings;
  LiveThresholdsConfig config = LiveThresholdsConfig::__getDefault__();
  config.adequacy_warn_error = 1.5e5;
  config.effect_ranking_period = 2.0;
  EXPECT_TRUE(applyLiveThresholds(&config, &settings).empty());
  EXPECT_EQ(settings.adequacy_warn_error, 1.5e5);
  EXPECT_EQ(settings.effect_ranking_period, 2.0);

  config.adequacy_error_error = 7e5;
  config.effect_ranking_window = 2.0;  // below the 5 s the node allows
  const std::vector<std::string> problems = applyLiveThresholds(&config, &settings);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems.front().find("effect_ranking_window = 2"), std::string::npos) << problems.front();
  EXPECT_EQ(settings.adequacy_error_error, NodeSettings().adequacy_error_error) << "nothing of it applied";
  EXPECT_EQ(config.adequacy_error_error, settings.adequacy_error_error) << "the server shows what holds";
  EXPECT_EQ(config.effect_ranking_window, settings.effect_ranking_window);
  EXPECT_EQ(config.adequacy_warn_error, 1.5e5);
}

}  // namespace
}  // namespace die_cushion_ident
