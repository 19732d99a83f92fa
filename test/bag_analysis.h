#pragma once
// analyze_bag run from a test as a user runs it, and what its summary.yaml says.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <string>

#include "tool_runner.h"

namespace die_cushion_ident {
namespace testing {

/// analyze_bag's exit status, what it printed, and its summary.yaml (a null node when it wrote none).
struct BagAnalysis {
  int status = -1;
  YAML::Node summary;
  std::string output;
};

/// `tools`/analyze_bag BAG --out OUT --config CONFIG --quiet EXTRA, its output collected in `log_path`.
inline BagAnalysis analyzeBag(const std::string& tools, const std::string& bag, const std::string& config,
                              const std::string& out, const std::string& extra, const std::string& log_path) {
  const CommandResult r = runCommand(
      tools + "/analyze_bag " + bag + " --out " + out + " --config " + config + " --quiet " + extra, log_path);
  BagAnalysis a;
  a.status = r.status;
  a.output = r.output;
  std::ifstream probe(out + "/summary.yaml");
  if (probe.good()) a.summary = YAML::LoadFile(out + "/summary.yaml");
  return a;
}

/// A parameter's value in summary.yaml's model (its std into `std`); a test failure where there is none.
inline double summaryParameter(const YAML::Node& summary, const std::string& name, double* std = nullptr) {
  for (const auto& p : summary["model"]["parameters"]) {
    if (p["name"].as<std::string>() == name) {
      if (std) *std = p["std"].as<double>();
      return p["value"].as<double>();
    }
  }
  ADD_FAILURE() << "no parameter " << name;
  return NAN;
}

/// The first of summary.yaml's warnings whose code (warning_codes, same order) is `code`; "" where none is.
inline std::string warningWithCode(const YAML::Node& summary, const std::string& code) {
  const YAML::Node warnings = summary["warnings"], codes = summary["warning_codes"];
  EXPECT_EQ(warnings.size(), codes.size()) << "a code for every warning";
  for (std::size_t i = 0; i < warnings.size() && i < codes.size(); ++i) {
    if (codes[i].as<std::string>() == code) return warnings[i].as<std::string>();
  }
  return "";
}

}  // namespace testing
}  // namespace die_cushion_ident
