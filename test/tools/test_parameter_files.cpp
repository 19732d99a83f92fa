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
#include "die_cushion_ident/core/estimation/identification_config.h"
#include "die_cushion_ident/core/valve/valve_sweep.h"
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

}  // namespace
}  // namespace die_cushion_ident
