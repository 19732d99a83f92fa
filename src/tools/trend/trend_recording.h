#pragma once

#include <cmath>
#include <map>
#include <string>
#include <vector>

namespace die_cushion_ident {

struct Parameter {
  std::string name, unit;
  double value = 0.0, std = 0.0;
};

// One recording's row of the trend, from its summary.yaml.
struct Recording {
  std::string bag;
  double start = 0.0, duration = 0.0, simulation_error_rms = 0.0;
  std::vector<Parameter> parameters;  // the model's, then the valve's (valve_*) when a sweep was found
  /// [degC] the oil temperature the parameters hold at (NaN: none recorded), and the model's parameters at
  /// the reference temperature (their std the recording's own part: the coefficients' is regressed out).
  double oil_temperature = std::nan("");
  double reference_temperature = std::nan("");
  std::map<std::string, Parameter> at_reference;
  std::map<std::string, std::string> verdicts;
  std::string conclusion;
};

}  // namespace die_cushion_ident
