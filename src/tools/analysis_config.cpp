#include "analysis_config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <fstream>

#include <sys/stat.h>

namespace die_cushion_ident {

std::vector<std::string> readAnalysisConfig(const YAML::Node& root, const std::string& path,
                                            IdentificationConfig* config, InputTopics* topics,
                                            std::vector<std::string>* keys_given);

namespace {

std::vector<std::string> stringList(const YAML::Node& node, const std::string& key,
                                    std::vector<std::string>* problems) {
  std::vector<std::string> out;
  if (node.IsScalar()) {
    out.push_back(node.as<std::string>());
  } else if (node.IsSequence()) {
    for (const auto& item : node) {
      if (item.IsScalar()) {
        out.push_back(item.as<std::string>());
      } else {
        problems->push_back(key + ": every entry must be a string");
      }
    }
  } else if (!node.IsNull()) {
    problems->push_back(key + ": must be a list of strings");
  }
  return out;
}

}  // namespace

std::vector<std::string> loadAnalysisConfig(const std::string& path, IdentificationConfig* config,
                                            InputTopics* topics, std::vector<std::string>* keys_given) {
  struct stat info;
  if (stat(path.c_str(), &info) != 0) return {"cannot read config file '" + path + "': it does not exist"};
  if (S_ISDIR(info.st_mode)) return {"config file '" + path + "' is a directory, not a YAML file"};
  if (!std::ifstream(path).good()) return {"cannot read config file '" + path + "' (no permission?)"};
  std::ifstream file(path);
  const std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  return parseAnalysisConfig(text, path, config, topics, keys_given);
}

std::vector<std::string> parseAnalysisConfig(const std::string& yaml_text, const std::string& origin,
                                             IdentificationConfig* config, InputTopics* topics,
                                             std::vector<std::string>* keys_given) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    return {"config file '" + origin + "' is not valid YAML: " + e.what()};
  }
  try {
    return readAnalysisConfig(root, origin, config, topics, keys_given);
  } catch (const YAML::Exception& e) {
    // A key or value of an unexpected shape (a mapping as a key, a list where a name belongs).
    return {"config file '" + origin + "': unexpected structure (" + e.what() +
            "); keys must be plain names and values numbers, names or the lists doc/configuration.md shows"};
  }
}

namespace {

// A key of numericConfigKeys(): its number, checked.
void readNumber(const std::string& key, const YAML::Node& value, IdentificationConfig* config,
                std::vector<std::string>* problems) {
  double number = 0.0;
  try {
    number = value.as<double>();
  } catch (const YAML::Exception&) {
    problems->push_back(key + ": '" + (value.IsScalar() ? value.as<std::string>() : "(a list or mapping)") +
                        "' is not a number");
    return;
  }
  const std::string problem = numericConfigProblem(key, number);
  if (!problem.empty()) {
    problems->push_back(problem);
    return;
  }
  setNumericConfigValue(*config, key, number);
}

void readTopics(const YAML::Node& value, InputTopics* topics, std::vector<std::string>* problems) {
  if (!value.IsMap()) {
    problems->push_back(
        "topics: must be a mapping {pressure: ..., position: ..., valve: ..., oil_temperature: ...}");
    return;
  }
  for (const auto& topic : value) {
    const std::string name = topic.first.as<std::string>();
    std::string* target = name == "pressure"          ? &topics->pressure
                          : name == "position"        ? &topics->position
                          : name == "valve"           ? &topics->valve
                          : name == "oil_temperature" ? &topics->oil_temperature
                                                      : nullptr;
    if (!target || !topic.second.IsScalar()) {
      problems->push_back("topics: '" + name + "' is not one of pressure, position, valve, oil_temperature");
      continue;
    }
    *target = topic.second.as<std::string>();
  }
}

void readTopicDelays(const YAML::Node& value, IdentificationConfig* config,
                     std::vector<std::string>* problems) {
  if (!value.IsMap()) {
    problems->push_back("topic_delays: must be a mapping {pressure: s, position: s, valve: s}");
    return;
  }
  for (const auto& delay : value) {
    const std::string name = delay.first.as<std::string>();
    if (name != "pressure" && name != "position" && name != "valve") {
      problems->push_back("topic_delays: '" + name + "' is not one of pressure, position, valve");
      continue;
    }
    try {
      setNumericConfigValue(*config, "topic_delays/" + name, delay.second.as<double>());
    } catch (const YAML::Exception&) {
      problems->push_back("topic_delays: " + name + " must be a number of seconds");
    }
  }
}

// One key that is not a number: false where it is not known.
bool readOtherKey(const std::string& key, const YAML::Node& value, IdentificationConfig* config,
                  InputTopics* topics, std::vector<std::string>* problems) {
  if (key == "effects") {
    config->effects = stringList(value, key, problems);
  } else if (key == "custom_effects") {
    config->custom_effects = stringList(value, key, problems);
  } else if (key == "regression_form") {
    if (!value.IsScalar() || !parseRegressionForm(value.as<std::string>(), &config->regression_form)) {
      problems->push_back("regression_form: allowed integral, derivative");
    }
  } else if (key == "topics") {
    readTopics(value, topics, problems);
  } else if (key == "joint_name") {
    if (!value.IsScalar() || value.as<std::string>().empty()) {
      problems->push_back("joint_name: must be the name of a joint in the position topic's JointState");
    } else {
      topics->joint_name = value.as<std::string>();
    }
  } else if (key == "topic_delays") {
    readTopicDelays(value, config, problems);
  } else {
    return false;
  }
  return true;
}

}  // namespace

std::vector<std::string> readAnalysisConfig(const YAML::Node& root, const std::string& path,
                                            IdentificationConfig* config, InputTopics* topics,
                                            std::vector<std::string>* keys_given) {
  std::vector<std::string> problems;
  if (root.IsNull()) return {};
  if (!root.IsMap()) return {"config file '" + path + "' must be a mapping of keys to values"};
  const auto numeric = numericConfigKeys();
  for (const auto& entry : root) {
    if (!entry.first.IsScalar()) {
      problems.push_back("a key of the config file is not a plain name (a list or mapping as a key)");
      continue;
    }
    const std::string key = entry.first.as<std::string>();
    const YAML::Node& value = entry.second;
    keys_given->push_back(key);
    if (std::find(numeric.begin(), numeric.end(), key) != numeric.end()) {
      readNumber(key, value, config, &problems);
    } else if (!readOtherKey(key, value, config, topics, &problems)) {
      std::string allowed;
      for (const auto& k : numeric) allowed += k + ", ";
      problems.push_back("unknown key '" + key + "' (allowed: " + allowed +
                         "effects, custom_effects, regression_form, topics, joint_name, topic_delays)");
    }
  }
  return problems;
}

}  // namespace die_cushion_ident
