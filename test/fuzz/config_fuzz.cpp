#include "config_fuzz.h"

#include <exception>
#include <vector>

#include "analysis_config.h"
#include "die_cushion_ident/core/estimation/identification_pipeline.h"

namespace die_cushion_ident {
namespace fuzz {

namespace {

const char* const kKeys[] = {"piston_area", "stroke_length", "supply_pressure", "sample_period", "max_gap",
                             "moving_average_width", "derivative_width", "identification_period",
                             "forgetting_factor", "min_pressure", "valve_command_hold", "velocity_window",
                             "topic_delays", "topics", "joint_name", "effects", "custom_effects",
                             "regression_form", "max_plausible_pressure", "plausible_stroke_margin",
                             "topic_delay_search", "no_such_key"};
const char* const kValues[] = {"0.05", "31", "31.5", "-1", "0", "1e300", ".nan", ".inf", "-.inf", "lots", "~",
                               "[leakage, entrained_air]", "[1, 2]", "{pressure: 0.01, position: x}",
                               "{pressure: /p, valve: [a]}", "'relief=max(p-140e5,0)'", "['a=1/(p-p)']",
                               "integral", "derivative", "cushion", "\"\"", "{a: {b: c}}", "[[1]]", "2.5e-3"};

}  // namespace

void runConfigCase(const std::uint8_t* data, std::size_t size,
                   const std::function<void(const std::string&)>& fail) {
  // Mostly structured YAML from the real keys; one case in eight the raw bytes themselves.
  std::string text;
  if (size > 0 && data[0] % 8 == 0) {
    text.assign(reinterpret_cast<const char*>(data + 1), size - 1);
  } else {
    for (std::size_t i = 1; i + 1 < size; i += 2) {
      const char* key = kKeys[data[i] % (sizeof(kKeys) / sizeof(kKeys[0]))];
      const char* value = kValues[data[i + 1] % (sizeof(kValues) / sizeof(kValues[0]))];
      if (data[i] & 0x80) text += "[" + std::string(key) + "]";  // a list as a key
      else text += key;
      text += ": " + std::string(value) + "\n";
    }
  }
  IdentificationConfig config;
  InputTopics topics;
  std::vector<std::string> keys;
  std::vector<std::string> problems;
  try {
    problems = parseAnalysisConfig(text, "fuzz.yaml", &config, &topics, &keys);
  } catch (const std::exception& e) {
    fail(std::string("an exception escaped the config loader: ") + e.what());
    return;
  }
  for (const auto& p : problems) {
    if (p.size() < 10) fail("a problem without a sentence: '" + p + "'");
  }
  if (!problems.empty()) return;
  const auto invalid = config.validate();
  if (!invalid.empty()) return;  // analyze_bag refuses it with these reasons (exit 2)
  try {
    IdentificationPipeline pipeline(config);
  } catch (const std::exception& e) {
    fail(std::string("a config that validates was refused by the pipeline: ") + e.what());
  }
}

}  // namespace fuzz
}  // namespace die_cushion_ident
