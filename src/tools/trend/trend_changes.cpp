#include "trend/trend_changes.h"

#include <algorithm>
#include <limits>

#include "die_cushion_ident/core/adequacy/verdict.h"
#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {

// One parameter's series as tracked: at the reference temperature with the oil temperature as covariate
// (recordings without one left out), or as recorded.
std::vector<TrendPoint> seriesOf(const std::vector<Recording>& rows, const std::string& name,
                                 const Tracking& tracking) {
  std::vector<TrendPoint> series;
  for (const auto& r : rows) {
    const auto p = r.at_reference.find(name);
    if (tracking.at_reference && p != r.at_reference.end() && std::isfinite(r.oil_temperature)) {
      series.push_back({r.start, p->second.value, p->second.std, r.oil_temperature});
      continue;
    }
    // A recording without an oil temperature cannot be compared at the reference one.
    if (tracking.at_reference && !std::isfinite(r.oil_temperature)) continue;
    // As recorded (the valve's sweep parameters are not carried: the orifice barely depends on the oil), with
    // the oil temperature as the covariate where there is one.
    for (const auto& q : r.parameters) {
      if (q.name == name) series.push_back({r.start, q.value, q.std, r.oil_temperature});
    }
  }
  return series;
}

}  // namespace

Tracking trackingOf(const std::vector<Recording>& rows) {
  Tracking t;
  for (const auto& r : rows) {
    if (r.at_reference.empty() || !std::isfinite(r.oil_temperature)) continue;
    ++t.with_temperature;
    t.reference = r.reference_temperature;
  }
  t.at_reference = t.with_temperature > 0;
  return t;
}

// Changes: a sequential test per parameter (each recording tested once, when it arrives). Returns how many;
// each parameter's smallest detectable change goes to `detectable`.
int emitParameterChanges(const std::vector<Recording>& rows, const std::vector<std::string>& names,
                         std::map<std::string, std::string>& units,
                         const SequentialDetectionOptions& detection, const Tracking& tracking,
                         std::map<std::string, DetectableChange>* detectable, YAML::Emitter& yaml,
                         const std::function<void(const std::string&)>& log) {
  int changes = 0;
  yaml << YAML::Key << "changes" << YAML::Value << YAML::BeginSeq;
  for (const auto& name : names) {
    const std::vector<TrendPoint> series = seriesOf(rows, name, tracking);
    DetectableChange smallest;
    const std::vector<ParameterChange> found = detectChangesSequentially(series, detection, &smallest);
    (*detectable)[name] = smallest;
    for (const ParameterChange& change : found) {
      const std::string start = isoTime(change.start_stamp);
      std::string words = explainChange(name, units[name], change, start.substr(0, 10));
      if (tracking.at_reference)
        words += formatted(FMT_STRING(" (compared at {:.0f} degC)"), tracking.reference);
      yaml << YAML::Flow << YAML::BeginMap;
      yaml << YAML::Key << "parameter" << YAML::Value << name << YAML::Key << "shape" << YAML::Value
           << change.shape;
      yaml << YAML::Key << "start" << YAML::Value << YAML::DoubleQuoted << start;
      yaml << YAML::Key << "start_stamp" << YAML::Value
           << formatted(FMT_STRING("{:.3f}"), change.start_stamp);
      yaml << YAML::Key << "alarm" << YAML::Value << YAML::DoubleQuoted << isoTime(change.alarm_stamp);
      yaml << YAML::Key << "before" << YAML::Value << change.before << YAML::Key << "after" << YAML::Value
           << change.after << YAML::Key << "unit" << YAML::Value << YAML::DoubleQuoted << units[name];
      if (tracking.at_reference) yaml << YAML::Key << "at_temperature" << YAML::Value << tracking.reference;
      yaml << YAML::Key << "explanation" << YAML::Value << YAML::DoubleQuoted << words << YAML::EndMap;
      log("change: " + words);
      ++changes;
    }
  }
  yaml << YAML::EndSeq;
  return changes;
}

// The oil temperature the recordings held, and the smallest change of each parameter the test can see with
// the history it has (in words where no temperature was recorded: its swing is then in the scatter).
void emitDetectableChanges(const std::vector<Recording>& rows, const std::vector<std::string>& names,
                           std::map<std::string, std::string>& units, const Tracking& tracking,
                           const std::map<std::string, DetectableChange>& detectable, YAML::Emitter& yaml) {
  yaml << YAML::Key << "oil_temperature" << YAML::Value << YAML::BeginMap;
  yaml << YAML::Key << "recordings_with" << YAML::Value << tracking.with_temperature;
  yaml << YAML::Key << "tracked" << YAML::Value
       << (tracking.at_reference ? "at_reference_temperature" : "as_recorded");
  if (tracking.at_reference) {
    yaml << YAML::Key << "reference_temperature" << YAML::Value << tracking.reference;
    yaml
        << YAML::Key << "note" << YAML::Value
        << formatted(
               FMT_STRING(
                   "each parameter compared at {:.0f} degC (carried there by the oil's law), the rest of the "
                   "temperature's influence regressed out over the baseline"),
               tracking.reference) +
               (tracking.with_temperature < rows.size()
                    ? formatted(FMT_STRING("; {} recordings without an oil temperature left out"),
                                rows.size() - tracking.with_temperature)
                    : std::string());
  } else {
    yaml << YAML::Key << "note" << YAML::Value
         << "no recording holds an oil temperature (topic oil_temperature): the parameters are compared as "
            "recorded, and the oil's swing between recordings is part of the scatter the changes must exceed "
            "(smallest_change below); record the oil temperature to compare them at one temperature";
  }
  yaml << YAML::EndMap;
  yaml << YAML::Key << "detectable_changes" << YAML::Value << YAML::BeginSeq;
  for (const auto& name : names) {
    const auto it = detectable.find(name);
    if (it == detectable.end()) continue;
    const DetectableChange& d = it->second;
    yaml << YAML::Flow << YAML::BeginMap << YAML::Key << "parameter" << YAML::Value << name;
    if (std::isfinite(d.step)) {
      yaml << YAML::Key << "smallest_change" << YAML::Value << d.step;
      if (d.level != 0.0 && std::isfinite(d.level))
        yaml << YAML::Key << "relative" << YAML::Value << std::abs(d.step / d.level);
      yaml << YAML::Key << "scatter" << YAML::Value << d.scatter;
    }
    yaml << YAML::Key << "unit" << YAML::Value << YAML::DoubleQuoted << units[name];
    yaml << YAML::Key << "within_recordings" << YAML::Value << d.within << YAML::Key << "probability"
         << YAML::Value << d.probability << YAML::Key << "baseline_recordings" << YAML::Value << d.baseline;
    yaml << YAML::Key << "temperature_regressed" << YAML::Value << d.regressed;
    if (!std::isfinite(d.step))
      yaml << YAML::Key << "note" << YAML::Value << "too short a history since the last change";
    yaml << YAML::EndMap;
  }
  yaml << YAML::EndSeq;
}

// A verdict change: an effect `missing` in the last recordings (at least 2 in a row) after at least 3
// recordings where it was not. In a list of its own: `changes` keeps the contract's entry shape
// (parameter, start, start_stamp, before, after, unit, explanation) for whoever reads it. Returns how many.
int emitVerdictChanges(const std::vector<Recording>& rows, const std::vector<std::string>& effects,
                       YAML::Emitter& yaml, const std::function<void(const std::string&)>& log) {
  int changes = 0;
  yaml << YAML::Key << "verdict_changes" << YAML::Value << YAML::BeginSeq;
  for (const auto& effect : effects) {
    std::vector<std::pair<double, bool>> missing;
    for (const auto& r : rows) {
      if (r.verdicts.count(effect))
        missing.emplace_back(r.start, r.verdicts.at(effect) == verdictName(Verdict::kMissing));
    }
    std::size_t first = missing.size();
    while (first > 0 && missing[first - 1].second) --first;
    const std::size_t run_length = missing.size() - first;
    const bool before_clear = first >= 3 && std::none_of(missing.begin(), missing.begin() + first,
                                                         [](const auto& m) { return m.second; });
    if (run_length < 2 || !before_clear) continue;
    const std::string start = isoTime(missing[first].first);
    const std::string words =
        "the effect '" + effect + "' has been missing from the model in the last " +
        std::to_string(run_length) + " recordings, since " + start.substr(0, 10) +
        ", and was not before: add it to the model (analyze_bag --effects), and see which of "
        "its parameters changes";
    yaml << YAML::Flow << YAML::BeginMap << YAML::Key << "effect" << YAML::Value << effect << YAML::Key
         << "verdict" << YAML::Value << verdictName(Verdict::kMissing) << YAML::Key << "start" << YAML::Value
         << YAML::DoubleQuoted << start << YAML::Key << "start_stamp" << YAML::Value
         << formatted(FMT_STRING("{:.3f}"), missing[first].first) << YAML::Key << "explanation" << YAML::Value
         << YAML::DoubleQuoted << words << YAML::EndMap;
    log("change: " + words);
    ++changes;
  }
  yaml << YAML::EndSeq;
  return changes;
}

}  // namespace die_cushion_ident
