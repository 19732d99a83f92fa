// analyze_bag: the offline analysis of a recorded bag (interface contract):
//   rosrun die_cushion_ident analyze_bag BAG --out DIR [--config FILE.yaml] [--effects a,b]
//                                        [--custom-effect NAME=EXPR]... [--quiet]
// Exit codes: 0 done, 2 bad command line or configuration, 3 the bag cannot be used, 4 outputs not written,
// 5 partial result (part of the bag unreadable, or part of the analysis could not run; the reasons are in
// summary.yaml's warnings).
#include <rosbag/bag.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/JointState.h>
#include <sensor_msgs/Temperature.h>
#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <set>
#include <sstream>

#include "analysis_config.h"
#include "argument_parser.h"
#include "bag/bag_inputs.h"
#include "bag/bag_stream_reader.h"
#include "command_line.h"
#include "die_cushion_ident/ValveSignal.h"
#include "die_cushion_ident/core/analysis/offline_analysis.h"
#include "die_cushion_ident/core/settings/settings_from_recording.h"
#include "die_cushion_ident/core/util/batch_pipe.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "message_conversions.h"
#include "output/analysis_writer.h"
#include "survey_then_analysis.h"

namespace die_cushion_ident {

[[noreturn]] void fail(int code, const std::string& message) {
  std::cerr << "analyze_bag: " << message << "\n";
  std::exit(code);
}

namespace {

const char* kUsage =
    "usage: analyze_bag BAG --out DIR [--config FILE.yaml] [--effects a,b] [--custom-effect NAME=EXPR]... "
    "[--propose] [--fixed-settings] [--jobs N] [--quiet]\n"
    "  Identifies the die cushion's hydraulics and valve from a recorded bag and writes DIR/summary.yaml,\n"
    "  DIR/analysis.bag and CSV files. Library effects: leakage, entrained_air, valve_overlap, "
    "tank_pressure,\n"
    "  oil_temperature (where the bag holds the oil temperature).\n"
    "  The config file holds the geometry (piston_area, stroke_length, supply_pressure), any setting of\n"
    "  doc/configuration.md, effects, custom_effects and topics: {pressure, position, valve,\n"
    "  oil_temperature}.\n"
    "  --propose searches formulas for the error the library leaves even when it is not structured (by\n"
    "  default the search runs only when it is).\n"
    "  The sample period, filter widths and identification period are chosen from the recording's first\n"
    "  seconds (the settings study run on it; summary.yaml settings: says what and why) unless configured;\n"
    "  --fixed-settings takes the configured (or the paper's default) values as they are; a configured\n"
    "  valve model then drives the free run (without one the measured spool does, and the summary warns).\n"
    "  --jobs N: threads for the effect ranking (default: one per core; "
    "analyze_trend runs bags side by side\n"
    "  with one each).\n";

struct Options {
  std::string bag, out, config;
  std::vector<std::string> effects, custom_effects;
  bool effects_given = false;
  int jobs = 0;  // threads for the effect ranking; 0: one per core
  bool quiet = false;
  bool propose = false;
  bool fixed_settings = false;  // no survey: the configured (or default) settings as they are
};

Options parseArguments(int argc, char** argv) {
  Options o;
  ArgumentParser arguments;
  arguments.option("--out", [&](const std::string& v) { o.out = v; })
      .option("--config", [&](const std::string& v) { o.config = v; })
      .option("--effects",
              [&](const std::string& v) {
                o.effects_given = true;
                o.effects = splitList(v);
              })
      .option("--custom-effect", [&](const std::string& v) { o.custom_effects.push_back(v); })
      .flag("--quiet", [&] { o.quiet = true; })
      .flag("--propose", [&] { o.propose = true; })
      .flag("--fixed-settings", [&] { o.fixed_settings = true; })
      .wholeNumber("--jobs", 1, 256, &o.jobs)
      .positional("bag", 1, [&](const std::string& v) { o.bag = v; });
  arguments.parseOrExit(argc, argv, "analyze_bag", kUsage);
  if (o.bag.empty()) fail(2, std::string("no bag given\n") + kUsage);
  if (o.out.empty()) fail(2, std::string("--out DIR is required\n") + kUsage);
  return o;
}

std::string milliseconds(double seconds) {
  return formatted(FMT_STRING("{:+.2f} ms"), seconds * 1e3);
}

// The configuration file and the command line's model, checked; warnings for the geometry left at defaults.
struct Configuration {
  IdentificationConfig config;
  InputTopics topics;
  std::vector<std::string> keys;  // given in the file
};

Configuration loadConfiguration(const Options& options, std::vector<AnalysisWarning>* warnings) {
  Configuration c;
  if (!options.config.empty()) {
    const auto problems = loadAnalysisConfig(options.config, &c.config, &c.topics, &c.keys);
    if (!problems.empty()) {
      std::string all;
      for (const auto& p : problems) all += "\n  " + p;
      fail(2, "invalid configuration in " + options.config + ":" + all);
    }
  }
  if (options.effects_given) c.config.effects = options.effects;
  for (const auto& custom : options.custom_effects) c.config.custom_effects.push_back(custom);
  for (const char* key : {"piston_area", "stroke_length", "supply_pressure"}) {
    if (std::find(c.keys.begin(), c.keys.end(), key) == c.keys.end()) {
      warnings->push_back({WarningCode::kGeometryDefault,
                           std::string("geometry key '") + key +
                               "' not configured: the default of doc/configuration.md is used"});
    }
  }
  const auto problems = c.config.validate();
  if (!problems.empty()) {
    std::string all;
    for (const auto& p : problems) all += "\n  " + p;
    fail(2, "invalid configuration:" + all);
  }
  return c;
}

// A bag without any input, or without the cushion's joint, cannot be analysed.
void failIfNothingToAnalyse(const BagPass& pass, const std::string (&names)[kInputStreamCount],
                            const AnalysisInput& input, const std::string& bag) {
  if (pass.present.empty()) {
    fail(3, "none of the input topics " + names[0] + ", " + names[1] + ", " + names[2] + " is in '" + bag +
                "'; it holds:" + (pass.listing.empty() ? std::string("\n  (nothing: the bag is empty)") : pass.listing) +
                (pass.read_error.empty() ? std::string() : "\n(reading stopped: " + pass.read_error + ")"));
  }
  if (input.messages[1] > 0 && pass.joint_missing == input.messages[1]) {
    fail(3, "no position message holds the cushion's joint: " + pass.joint_problem);
  }
}

// The messages the reading skipped, in words.
void skippedMessages(const BagPass& pass, const std::string (&names)[kInputStreamCount],
                     std::vector<AnalysisWarning>* warnings) {
  for (int s = 0; s < kInputStreamCount; ++s) {
    if (!pass.present.count(names[s]))
      warnings->push_back({WarningCode::kTopicMissing, "topic " + names[s] + " is not in the bag"});
  }
  if (pass.mismatched > 0) {
    warnings->push_back(
        {WarningCode::kMessagesRejected,
         std::to_string(pass.mismatched) +
             " messages had a different definition (md5sum) than this package's and were skipped"});
  }
  if (pass.damaged > 0) {
    warnings->push_back(
        {WarningCode::kMessagesDamaged,
         std::to_string(pass.damaged) + " messages were damaged (their bytes do not decode) and skipped"});
  }
  if (pass.joint_missing > 0) {
    warnings->push_back(
        {WarningCode::kJointMissing,
         std::to_string(pass.joint_missing) + " position messages skipped: " + pass.joint_problem});
  }
  if (pass.without_position > 0) {
    warnings->push_back({WarningCode::kMessagesRejected,
                         std::to_string(pass.without_position) +
                             " position messages without a position for the cushion's joint were skipped"});
  }
  if (!pass.joint_ambiguity.empty())
    warnings->push_back({WarningCode::kJointAmbiguous, pass.joint_ambiguity});
  if (!pass.oil_temperature_problem.empty())
    warnings->push_back({WarningCode::kOilTemperature, pass.oil_temperature_problem});
}

// "1 record" / "N records".
std::string records(std::uint64_t n) { return std::to_string(n) + (n == 1 ? " record" : " records"); }

// A recording killed while recording: what was read of it, in words; true where a record could not be read.
bool unclosedWarning(const BagPass& pass, std::vector<AnalysisWarning>* warnings) {
  std::string text = pass.read_error + ": ";
  if (pass.records_unreadable > 0) {
    text += std::to_string(pass.messages_read) +
            " messages were read, its open last chunk to its last whole record; " +
            records(pass.records_unreadable) + " could not be read";
  } else if (pass.data_lost) {
    text += std::to_string(pass.messages_read) + " messages were read, up to its open last chunk";
  } else {
    text += "every whole record of the file was read (" + std::to_string(pass.messages_read) +
            " messages), its open last chunk included";
  }
  text += "; what the recorder had not written when it stopped is not in the file";
  warnings->push_back({WarningCode::kBagDamaged, text});
  return pass.data_lost || pass.records_unreadable > 0;
}

// What the reading skipped, lost or could not read, in words; true where the result is partial.
bool readingWarnings(const BagPass& pass, const std::string (&names)[kInputStreamCount],
                     std::vector<AnalysisWarning>* warnings,
                     const std::function<void(const std::string&)>& log) {
  skippedMessages(pass, names, warnings);
  if (!pass.damage.empty()) {
    // Damage names where it is, so that the recording (or its copy) can be checked there.
    std::string where;
    for (std::size_t i = 0; i < pass.damage.size() && i < 5; ++i) {
      where += (i ? "; " : "") + pass.damage[i].what + " at byte " + std::to_string(pass.damage[i].position);
    }
    if (pass.damage.size() > 5) where += "; and " + std::to_string(pass.damage.size() - 5) + " more";
    const bool in_messages = std::any_of(pass.damage.begin(), pass.damage.end(),
                                         [](const BagStreamReader::Damage& d) { return d.in_messages; });
    std::string lost = "every message was read (the damage lies in the index or the headers)";
    if (in_messages || pass.records_unreadable > 0) {
      lost = (pass.messages_missing > 0 ? std::to_string(pass.messages_missing) + " messages the index lists"
                                        : std::string("the messages")) +
             " were lost in the damaged parts" +
             (pass.records_unreadable > 0 ? " (" + records(pass.records_unreadable) + " could not be read)"
                                          : "") +
             "; the reading went on at the next record that holds together";
    }
    if (pass.unclosed) lost += "; the recording was not closed (its last chunk still open)";
    warnings->push_back({WarningCode::kBagDamaged,
                         "the bag is damaged (" + where + "): " + lost + ", and what was read is analysed"});
    log(warnings->back().text);
    return true;
  }
  if (pass.read_error.empty()) return false;
  bool partial = false;
  if (pass.unclosed) {
    partial = unclosedWarning(pass, warnings);
  } else if (pass.cut_off && !pass.data_lost) {
    // Every message was read; only the index behind them is gone.
    warnings->push_back({WarningCode::kBagDamaged, "the bag lost its index (" + pass.read_error +
                                                       "): every message was read from its chunks"});
  } else {
    const std::string share =
        formatted(FMT_STRING("{:.1f}"), 100.0 * pass.bytes_read / std::max<std::uint64_t>(pass.file_size, 1));
    const std::string unread = pass.records_unreadable > 0
                                   ? " (" + records(pass.records_unreadable) + " cut there could not be read)"
                                   : "";
    warnings->push_back({WarningCode::kBagDamaged,
                         pass.cut_off ? "the bag was cut off while recording (" + pass.read_error +
                                            "): the analysis covers what was recorded before the cut" + unread
                                      : "the bag could not be read to the end (" + pass.read_error +
                                            "): the analysis covers the first " + share +
                                            " % of it, read before the damage"});
    partial = true;
  }
  log(warnings->back().text);
  return partial;
}

// The clock offsets without a survey: on the survey's messages at the finest period they support where it
// kept some (`surveyed`, its valve model's timing in it), else on the whole recording's grid; where they
// matter, they are set in `config` for a second reading.
TopicDelayEstimate estimateClockOffsets(OfflineAnalysis& analysis, std::optional<TopicDelayEstimate> surveyed,
                                        IdentificationConfig* config, bool valve_configured,
                                        const std::function<void(const std::string&)>& log) {
  log("estimating the clock offsets between the topics");
  const bool from_survey = surveyed && surveyed->valid;
  TopicDelayEstimate delays = from_survey ? *surveyed : analysis.estimateTopicDelays();
  if (delays.significant(config->resampler.sample_period) && (!from_survey || delays.distinguishable())) {
    config->topic_delays = delays.delays;
    // Their common offset against the pressure carries its uncertainty into the parameters (clock_offsets).
    config->common_delay_std = delays.common_std > 0.0
                                   ? delays.common_std
                                   : std::max({delays.resolution[1], delays.resolution[2], 1e-4});
    log("position stamps " + milliseconds(delays.delays[1]) + ", valve stamps " + milliseconds(delays.delays[2]) +
        " against pressure: reading again with the stamps corrected");
  }
  if (!from_survey && !valve_configured && !spoolMeasured(analysis.grid()))
    addValveModelTiming(config->valve, &delays);
  return delays;
}

// --fixed-settings without a configured valve model (takeConfiguredValveModel says why it matters).
void warnIfTheMeasuredSpoolDrivesTheFreeRun(const IdentificationConfig& config,
                                            const std::vector<GridSample>& grid,
                                            std::vector<AnalysisWarning>* warnings) {
  if (config.valve_model_drives_free_run || !spoolMeasured(grid)) return;
  warnings->push_back(
      {WarningCode::kValveModel,
       "--fixed-settings without a configured valve model: the measured spool drives the free run, and a "
       "shut valve integrates its noise (a clean fast press ran 3.9 bar off and was told its error was "
       "structured): configure the valve model (valve_natural_frequency, valve_damping, valve_gain, "
       "valve_dead_time) or leave out --fixed-settings, whose survey fits it to the recording's operation"});
}

// The settings chosen from the recording, with their warnings.
void reportSettings(const std::optional<SettingsChoice>& choice, OfflineResult* result) {
  if (!choice) return;
  result->settings = choice;
  for (const auto& w : choice->warnings) result->warnings.push_back(w);
  if (!choice->resolution_limit.empty()) {
    result->warnings.push_back({WarningCode::kResolutionLimited, choice->resolution_limit});
  }
  if (choice->valve_from_operation && result->valve_model_source == "configured") {
    result->valve_model_source = "operation";
  }
}

// The topics' clock offsets: where they come from, and a warning for each large one.
void reportClockOffsets(const std::optional<TopicDelayEstimate>& delays, bool applied, OfflineResult* result) {
  if (!delays) return;
  result->delay_estimate = delays;
  if (!delays->valid) {
    result->warnings.push_back(
        {WarningCode::kClockOffset, "the clock offsets between the topics could not be estimated (" +
                                        delays->message + "): the stamps are used as recorded"});
    return;
  }
  // Offsets the data cannot tell from 0 are reported but not corrected.
  result->topic_delays_source = applied ? "estimated" : "estimated, indistinguishable from 0: not corrected";
  for (int s = 1; s < kInputStreamCount; ++s) {
    if (!(std::abs(delays->delays[s]) > kLargeTopicDelay)) continue;
    const std::string topic = std::string("the ") + inputStreamName(static_cast<InputStream>(s));
    if (s == static_cast<int>(InputStream::kValve) && delays->valve_model_timing > 0.0) {
      result->warnings.push_back({WarningCode::kClockOffset, valveTimingWarning(delays->delays[s], applied)});
    } else if (applied) {
      result->warnings.push_back(
          {WarningCode::kClockOffset, topic + " topic's stamps are " + milliseconds(delays->delays[s]) +
                                          " off the pressure's (estimated from the data and corrected): its "
                                          "driver stamps on receipt or by another clock; set topic_delays to "
                                          "fix the value, or stamp at the measurement"});
    } else {
      result->warnings.push_back(
          {WarningCode::kClockOffset,
           topic + " topic's stamps look " + milliseconds(delays->delays[s]) +
               " off the pressure's, but the recording cannot tell that from none (+-" +
               milliseconds(delays->resolution[s]).substr(1) +
               "): not corrected; set topic_delays if you know the offset"});
    }
  }
}

// The end of the log: warnings, conclusion and speed; the exit code (5 for a partial result).
int finishLog(const OfflineResult& result, bool partial, double seconds, const Options& options,
              const std::function<void(const std::string&)>& log) {
  for (const auto& w : result.warnings) log("warning: " + w.text);
  log("simulation error " + std::to_string(result.assessment.simulation_error_rms * 1e-5) + " bar rms; " +
      result.ranking.conclusion);
  if (result.valve) log("valve: " + result.valve->fit.message);
  log(formatted(FMT_STRING("{:.1f} s for {} messages ({:.2f} M/s); results in {}"), seconds, result.messages,
                result.messages / std::max(seconds, 1e-9) / 1e6, options.out));
  if (!partial && !result.partial) return 0;
  std::cerr << "analyze_bag: partial result: " << (result.partial ? "part of the analysis could not run"
                                                                   : "the bag could not be read completely")
            << "; see the warnings in summary.yaml\n";
  return 5;
}

// What the reading found, for the summary.
struct ReadingFindings {
  std::vector<AnalysisWarning> warnings;
  std::optional<SettingsChoice> settings;
  std::optional<TopicDelayEstimate> delays;
  bool delays_applied = false;
  bool partial = false;  // the bag could not be read completely
};

// Identifies; writes the estimates out while the effects are ranked, then the rest; the exit code.
int analyseAndWrite(OfflineAnalysis& analysis, const Options& options, const IdentificationConfig& config,
                    const AnalysisInput& input, const ReadingFindings& found,
                    std::chrono::steady_clock::time_point started, const std::function<void(const std::string&)>& log) {
  const auto tell = [&](const std::string& step) {  // the log with the time since the start
    log(formatted(FMT_STRING("{:.1f} s: "),
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count()) +
        step);
  };
  OfflineResult result = analysis.identify(tell);
  // The estimates and the model comparison are final: written out while the effects are ranked.
  if (!makeDirectory(options.out)) fail(4, "cannot create output directory '" + options.out + "'");
  std::unique_ptr<AnalysisWriter> writer;
  try {
    writer = std::make_unique<AnalysisWriter>(options.out, config, result, analysis.grid());
  } catch (const std::exception& e) {
    fail(4, std::string("cannot write the results: ") + e.what());
  }
  analysis.explain(&result, tell);
  result.warnings.insert(result.warnings.begin(), found.warnings.begin(), found.warnings.end());
  reportSettings(found.settings, &result);
  reportClockOffsets(found.delays, found.delays_applied, &result);
  tell("writing the results");
  try {
    writer->finish(input, result);
  } catch (const std::exception& e) {
    writer.reset();  // removes what it wrote under temporary names (fail() exits without unwinding)
    fail(4, std::string("cannot write the results: ") + e.what());
  }
  return finishLog(result, found.partial,
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(), options, log);
}

int run(int argc, char** argv) {
  const Options options = parseArguments(argc, argv);
  const std::function<void(const std::string&)> log = [&](const std::string& line) {
    if (!options.quiet) std::cerr << ("analyze_bag: " + line + "\n");  // one write: two threads log
  };
  std::vector<AnalysisWarning> warnings;
  Configuration configuration = loadConfiguration(options, &warnings);
  IdentificationConfig& config = configuration.config;
  const InputTopics& topics = configuration.topics;

  // The three inputs, by name (types and presence are checked while reading).
  const std::string names[kInputStreamCount] = {topics.pressure, topics.position, topics.valve};
  AnalysisInput input;
  input.bag = options.bag;
  input.joint_name = topics.joint_name;
  for (int s = 0; s < kInputStreamCount; ++s) input.topics[s] = names[s];
  input.oil_temperature_topic = topics.oil_temperature;
  const auto started = std::chrono::steady_clock::now();

  const std::set<std::string> configured(configuration.keys.begin(), configuration.keys.end());
  if (options.fixed_settings) takeConfiguredValveModel(configured, &config);
  SurveyThenAnalysis surveyed(config, configured, !options.fixed_settings, options.jobs, log);
  BagPass pass =
      readInputs(options.bag, names, topics.oil_temperature, topics.joint_name, surveyed, input, log);
  OfflineAnalysis* analysis = &surveyed.analysis();
  config = surveyed.config();
  failIfNothingToAnalyse(pass, names, input, options.bag);
  // Topics stamped by different clocks: the survey estimated the offsets on the recording's first seconds
  // and the analysis ran on corrected stamps. Without a survey (or where it could not tell), they are
  // estimated on the whole recording, which is read again with the stamps corrected where they matter.
  std::optional<TopicDelayEstimate> delays;
  bool delays_applied = false;
  std::unique_ptr<SurveyThenAnalysis> reread;  // without a survey: the settings are chosen already
  if (surveyed.choice() && surveyed.choice()->delays && surveyed.choice()->delays->valid) {
    delays = surveyed.choice()->delays;
    delays_applied = surveyed.choice()->delays_applied;
  } else if (!config.topicDelaysSet()) {
    delays = estimateClockOffsets(*analysis, surveyed.clockOffsets(), &config,
                                  valveModelConfigured(configured), log);
    delays_applied = config.topicDelaysSet();  // set by estimateClockOffsets where they matter
    if (delays_applied) {
      reread = std::make_unique<SurveyThenAnalysis>(config, configured, false, options.jobs, log);
      pass = readInputs(options.bag, names, topics.oil_temperature, topics.joint_name, *reread, input, log);
      analysis = &reread->analysis();
    }
  }
  input.duration = std::isfinite(pass.last - pass.first) ? pass.last - pass.first : 0.0;
  input.start = std::isfinite(pass.first) ? pass.first : 0.0;
  const bool partial = readingWarnings(pass, names, &warnings, log);
  if (options.fixed_settings) {
    warnIfTheMeasuredSpoolDrivesTheFreeRun(config, analysis->grid(), &warnings);
    const auto valve_messages = input.messages[static_cast<int>(InputStream::kValve)];
    const std::string valve_rate =
        valveRateUnstudiedWarning(config, valve_messages > 1 ? input.duration / (valve_messages - 1) : 0.0);
    if (!valve_rate.empty()) warnings.push_back({WarningCode::kResolutionLimited, valve_rate});
  }

  analysis->proposeAlways(options.propose);
  if (surveyed.choice()) analysis->setResolution(surveyed.choice()->resolution_error, surveyed.choice()->resolution_remedy);
  return analyseAndWrite(*analysis, options, config, input, {warnings, surveyed.choice(), delays, delays_applied, partial},
                         started, log);
}

}  // namespace
}  // namespace die_cushion_ident

int main(int argc, char** argv) {
  // Every failure ends with a message and an exit code of the contract, never an abort.
  try {
    return die_cushion_ident::run(argc, argv);
  } catch (const std::bad_alloc&) {
    std::cerr << "analyze_bag: out of memory while analysing (the recording is too long for this machine's "
                 "memory; analyse it in parts, e.g. rosbag filter by time)\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "analyze_bag: cannot complete the analysis: " << e.what() << "\n";
    return 3;
  }
}
