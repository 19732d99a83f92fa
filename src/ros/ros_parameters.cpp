#include "ros_parameters.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>

namespace die_cushion_ident {

namespace {

// A numeric parameter, if present; a present parameter of another type is a problem, not a default.
void readNumber(const ros::NodeHandle& pnh, const std::string& key, std::vector<std::string>* problems,
                const std::function<void(double)>& set) {
  XmlRpc::XmlRpcValue value;
  if (!pnh.getParam(key, value)) return;
  if (value.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
    set(static_cast<double>(value));
  } else if (value.getType() == XmlRpc::XmlRpcValue::TypeInt) {
    set(static_cast<int>(value));
  } else {
    problems->push_back("~" + key + " is invalid: must be a number");
  }
}

}  // namespace

void readStrings(const ros::NodeHandle& pnh, const std::string& key, std::vector<std::string>* out,
                 std::vector<std::string>* problems) {
  XmlRpc::XmlRpcValue value;
  if (!pnh.getParam(key, value)) return;
  if (value.getType() == XmlRpc::XmlRpcValue::TypeString) {  // "a,b", "a" or "[a, b]" from a command line
    std::string text = value;
    if (text.size() >= 2 && text.front() == '[' && text.back() == ']') text = text.substr(1, text.size() - 2);
    // Split at commas outside parentheses: a custom effect's expression may hold max(p, 0).
    int depth = 0;
    std::string item;
    const auto flush = [&] {
      const auto first = item.find_first_not_of(" \t'\"");
      const auto last = item.find_last_not_of(" \t'\"");
      if (first != std::string::npos) out->push_back(item.substr(first, last - first + 1));
      item.clear();
    };
    for (char c : text) {
      depth += c == '(' ? 1 : c == ')' ? -1 : 0;
      if (c == ',' && depth == 0) {
        flush();
      } else {
        item += c;
      }
    }
    flush();
    return;
  }
  if (value.getType() != XmlRpc::XmlRpcValue::TypeArray) {
    problems->push_back("~" + key + " is invalid: must be a list of strings");
    return;
  }
  for (int i = 0; i < value.size(); ++i) {
    if (value[i].getType() != XmlRpc::XmlRpcValue::TypeString) {
      problems->push_back("~" + key + " is invalid: element " + std::to_string(i) + " is not a string");
      continue;
    }
    out->push_back(static_cast<std::string>(value[i]));
  }
}

std::set<std::string> configuredKeys(const ros::NodeHandle& pnh) {
  std::set<std::string> keys;
  for (const auto& key : numericConfigKeys()) {
    if (pnh.hasParam(key)) keys.insert(key);
  }
  return keys;
}

namespace {

void readConfigAndLimits(const ros::NodeHandle& pnh, IdentificationConfig* config, SweepLimits* limits,
                         std::vector<std::string>* problems) {
  for (const auto& key : numericConfigKeys()) {
    readNumber(pnh, key, problems, [&](double v) {
      const std::string problem = numericConfigProblem(key, v);
      if (problem.empty()) {
        setNumericConfigValue(*config, key, v);
      } else {
        problems->push_back("~" + problem);
      }
    });
  }
  for (const auto& key : sweepLimitKeys()) {
    readNumber(pnh, key, problems, [&](double v) { setSweepLimit(*limits, key, v); });
  }
}

void readNodeSettings(const ros::NodeHandle& pnh, NodeSettings* settings,
                      std::vector<std::string>* problems) {
  readNumber(pnh, "adequacy_warn_error", problems, [&](double v) { settings->adequacy_warn_error = v; });
  readNumber(pnh, "adequacy_error_error", problems, [&](double v) { settings->adequacy_error_error = v; });
  readNumber(pnh, "effect_ranking_window", problems, [&](double v) { settings->effect_ranking_window = v; });
  readNumber(pnh, "effect_ranking_period", problems, [&](double v) { settings->effect_ranking_period = v; });
  readNumber(pnh, "valve_gain", problems, [&](double v) { settings->valve_gain = v; });
  readNumber(pnh, "feed_forward_max_age", problems, [&](double v) { settings->feed_forward_max_age = v; });
  readNumber(pnh, "feed_forward_slew_rate", problems,
             [&](double v) { settings->feed_forward_slew_rate = v; });
  readNumber(pnh, "feed_forward_parameter_rate", problems,
             [&](double v) { settings->feed_forward_parameter_rate = v; });
  readNumber(pnh, "feed_forward_max_lead", problems, [&](double v) { settings->feed_forward_max_lead = v; });
  readNumber(pnh, "feed_forward_rate_window", problems,
             [&](double v) { settings->feed_forward_rate_window = v; });
  readNumber(pnh, "feed_forward_max_setpoint_rate", problems,
             [&](double v) { settings->feed_forward_max_setpoint_rate = v; });
  if (pnh.hasParam("feed_forward_enabled") &&
      !pnh.getParam("feed_forward_enabled", settings->feed_forward_enabled)) {
    problems->push_back("~feed_forward_enabled is invalid: must be true or false");
  }
  readNumber(pnh, "survey_seconds", problems, [&](double v) { settings->survey_seconds = v; });
  if (pnh.hasParam("choose_settings") && !pnh.getParam("choose_settings", settings->choose_settings)) {
    problems->push_back("~choose_settings is invalid: must be true or false");
  }
}

// The model's form and effects, and the cushion's joint.
void readModelAndJoint(const ros::NodeHandle& pnh, IdentificationConfig* config, NodeSettings* settings,
                       std::vector<std::string>* problems) {
  std::string form;
  if (pnh.hasParam("regression_form") &&
      (!pnh.getParam("regression_form", form) || !parseRegressionForm(form, &config->regression_form))) {
    // A number (_regression_form:=5) is no name either: refused, not ignored.
    problems->push_back("~regression_form = " + (form.empty() ? std::string("(not a name)") : form) +
                        " is invalid: allowed integral, derivative");
  }
  if (pnh.hasParam("joint_name") &&
      (!pnh.getParam("joint_name", settings->joint_name) || settings->joint_name.empty())) {
    problems->push_back(
        "~joint_name is invalid: must be the name of a joint in the position topic's JointState");
  }
  readStrings(pnh, "effects", &config->effects, problems);
  readStrings(pnh, "custom_effects", &config->custom_effects, problems);
}

void addInvalid(std::vector<std::string>* problems, const char* key, double v, const char* allowed) {
  std::ostringstream s;
  s << "~" << key << " = " << v << " is invalid: allowed " << allowed;
  problems->push_back(s.str());
}

void checkNodeSettings(const ros::NodeHandle& pnh, const NodeSettings& settings,
                       std::vector<std::string>* problems) {
  const auto invalid = [&](const char* key, double v, const char* allowed) {
    addInvalid(problems, key, v, allowed);
  };
  const auto positive = [&](const char* key, double v) {
    if (!(std::isfinite(v) && v > 0.0)) invalid(key, v, "> 0");
  };
  for (const auto& p : liveThresholdProblems(settings)) problems->push_back(p);
  positive("feed_forward_max_age", settings.feed_forward_max_age);
  positive("feed_forward_slew_rate", settings.feed_forward_slew_rate);
  positive("feed_forward_parameter_rate", settings.feed_forward_parameter_rate);
  positive("feed_forward_max_setpoint_rate", settings.feed_forward_max_setpoint_rate);
  if (!(settings.feed_forward_max_lead > 0.0 && settings.feed_forward_max_lead <= 0.5)) {
    invalid("feed_forward_max_lead", settings.feed_forward_max_lead, "(0, 0.5] s");
  }
  if (!(settings.feed_forward_rate_window >= 1e-3 && settings.feed_forward_rate_window <= 1.0)) {
    invalid("feed_forward_rate_window", settings.feed_forward_rate_window, "[1e-3, 1] s");
  }
  if (pnh.hasParam("valve_gain") && !(std::isfinite(settings.valve_gain) && settings.valve_gain != 0.0)) {
    invalid("valve_gain", settings.valve_gain, "finite and non-zero [1/V]");
  }
  if (!(settings.survey_seconds >= 5.0 && settings.survey_seconds <= 600.0)) {
    invalid("survey_seconds", settings.survey_seconds, "[5, 600] s");
  }
}

}  // namespace

std::vector<std::string> liveThresholdProblems(const NodeSettings& settings) {
  // The same ranges as cfg/LiveThresholds.cfg's (test_parameter_files compares them).
  std::vector<std::string> problems;
  const auto positive = [&](const char* key, double v) {
    if (!(std::isfinite(v) && v > 0.0)) addInvalid(&problems, key, v, "> 0");
  };
  positive("adequacy_warn_error", settings.adequacy_warn_error);
  positive("adequacy_error_error", settings.adequacy_error_error);
  positive("effect_ranking_period", settings.effect_ranking_period);
  if (!(settings.effect_ranking_window >= 5.0 && settings.effect_ranking_window <= 3600.0)) {
    addInvalid(&problems, "effect_ranking_window", settings.effect_ranking_window, "[5, 3600] s");
  }
  return problems;
}

std::vector<std::string> loadParameters(const ros::NodeHandle& pnh, IdentificationConfig* config,
                                        SweepLimits* limits, NodeSettings* settings) {
  std::vector<std::string> problems;
  readConfigAndLimits(pnh, config, limits, &problems);
  readNodeSettings(pnh, settings, &problems);
  readModelAndJoint(pnh, config, settings, &problems);
  for (const auto& p : config->validate()) problems.push_back("~" + p);
  for (const auto& p : limits->validate()) problems.push_back("~" + p);
  checkNodeSettings(pnh, *settings, &problems);
  return problems;
}

FeedForwardOutputLimits feedForwardOutputLimits(const NodeSettings& settings, const SweepLimits& limits) {
  FeedForwardOutputLimits output;
  // Symmetric for the inverse, inside the requested range on both sides; a range that excludes 0 V on one
  // side allows nothing.
  output.max_voltage = std::max(1e-9, std::min(-limits.min_voltage, limits.max_voltage));
  output.slew_rate = settings.feed_forward_slew_rate;
  // Two of the watchdog's periods: the longest a ramp waits for its next command.
  output.max_step_interval = 2.0 * ValveSupervisor::watchPeriod(limits);
  return output;
}

FeedForwardPublisher::Settings feedForwardSettings(const NodeSettings& settings, const SweepLimits& limits) {
  FeedForwardPublisher::Settings ff;
  ff.valve_gain = settings.valve_gain;
  ff.max_voltage = feedForwardOutputLimits(settings, limits).max_voltage;
  ff.setpoint.max_age = settings.feed_forward_max_age;
  ff.setpoint.max_clock_offset = limits.max_clock_offset;
  ff.setpoint.rate_window = settings.feed_forward_rate_window;
  ff.setpoint.max_rate = settings.feed_forward_max_setpoint_rate;
  ff.interlock.parameter_rate = settings.feed_forward_parameter_rate;
  ff.interlock.max_lead = settings.feed_forward_max_lead;
  return ff;
}

LiveMonitorSettings liveMonitorSettings(const NodeSettings& settings) {
  LiveMonitorSettings monitor;
  monitor.ranking_window = settings.effect_ranking_window;
  monitor.ranking_period = settings.effect_ranking_period;
  return monitor;
}

LiveIdentificationSettings liveIdentificationSettings(const NodeSettings& settings,
                                                      const ros::NodeHandle& pnh) {
  LiveIdentificationSettings live;
  live.monitor = liveMonitorSettings(settings);
  live.choose_settings = settings.choose_settings;
  live.survey_seconds = settings.survey_seconds;
  live.configured = configuredKeys(pnh);
  return live;
}

}  // namespace die_cushion_ident
