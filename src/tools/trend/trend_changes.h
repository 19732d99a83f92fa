#pragma once

// trend.yaml's changes (analyze_trend): what the trend tracks, the sequential test per parameter, the
// smallest change it can see, and the verdicts that changed between recordings.

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "die_cushion_ident/core/trend/parameter_trend.h"
#include "trend/trend_recording.h"

namespace die_cushion_ident {

// What the trend tracks: the parameters at the reference temperature where the recordings hold the oil's
// temperature (the weather taken out by the oil's law, and what the law leaves by a regression on the
// temperature over the baseline), else as recorded.
struct Tracking {
  bool at_reference = false;
  double reference = std::nan("");
  std::size_t with_temperature = 0;
};

Tracking trackingOf(const std::vector<Recording>& rows);
int emitParameterChanges(const std::vector<Recording>& rows, const std::vector<std::string>& names,
                         std::map<std::string, std::string>& units,
                         const SequentialDetectionOptions& detection, const Tracking& tracking,
                         std::map<std::string, DetectableChange>* detectable, YAML::Emitter& yaml,
                         const std::function<void(const std::string&)>& log);
void emitDetectableChanges(const std::vector<Recording>& rows, const std::vector<std::string>& names,
                           std::map<std::string, std::string>& units, const Tracking& tracking,
                           const std::map<std::string, DetectableChange>& detectable, YAML::Emitter& yaml);
int emitVerdictChanges(const std::vector<Recording>& rows, const std::vector<std::string>& effects,
                       YAML::Emitter& yaml, const std::function<void(const std::string&)>& log);

}  // namespace die_cushion_ident
