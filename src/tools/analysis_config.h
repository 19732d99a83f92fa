#pragma once

#include <string>
#include <vector>

#include "die_cushion_ident/core/estimation/identification_config.h"

namespace die_cushion_ident {

/// The three input topics read from a bag.
struct InputTopics {
  std::string pressure = "/die_cushion/pressure";
  std::string position = "/die_cushion/position";
  std::string valve = "/die_cushion/valve";
  /// The optional oil temperature (sensor_msgs/Temperature, degC).
  std::string oil_temperature = "/die_cushion/oil_temperature";
  std::string joint_name;  ///< the cushion's joint in the position topic's JointState; "" = the only one
};

/// Reads an analyze_bag config file (YAML: the configuration keys of doc/configuration.md, `effects`,
/// `custom_effects`, `regression_form`, `topics: {pressure, position, valve, oil_temperature}`, `joint_name`,
/// `topic_delays: {pressure, position, valve}`). Returns every problem found ("key: ..."), including unknown
/// keys (a typo must not silently fall back to a default).
std::vector<std::string> loadAnalysisConfig(const std::string& path, IdentificationConfig* config,
                                            InputTopics* topics, std::vector<std::string>* keys_given);
/// The same from YAML text (`origin` names it in messages); never throws.
std::vector<std::string> parseAnalysisConfig(const std::string& yaml_text, const std::string& origin,
                                             IdentificationConfig* config, InputTopics* topics,
                                             std::vector<std::string>* keys_given);

}  // namespace die_cushion_ident
