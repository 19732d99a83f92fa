// Condition monitoring over many recordings (issue 14):
//   rosrun die_cushion_ident analyze_trend BAG_OR_DIR... --out DIR [--config FILE] [--effects a,b] [--jobs N]
//                                          [--false-alarms-per-year F] [--recordings-per-year R] [--quiet]
// Analyses every bag with analyze_bag (side by side, one thread each), keeps each bag's summary.yaml under
// DIR/bags/ and reuses it while the bag and the settings are unchanged, then writes DIR/trend.csv (a row per
// recording) and DIR/trend.yaml (the changes found: doc/condition_monitoring.md). Every file is written whole
// or not at all (OutputFiles); a full disk is exit 4 and is not remembered as a failed bag.
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "argument_parser.h"
#include "command_line.h"
#include "die_cushion_ident/core/adequacy/analysis_warning.h"
#include "die_cushion_ident/core/adequacy/verdict.h"
#include "die_cushion_ident/core/trend/parameter_trend.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "die_cushion_ident/core/util/parallel_for.h"
#include "output/csv_file.h"
#include "output/output_files.h"
#include "trend/trend_changes.h"
#include "trend/trend_recording.h"

namespace fs = std::filesystem;

namespace die_cushion_ident {
namespace {

const char* const kUsage =
    "usage: analyze_trend BAG_OR_DIR... --out DIR [--config FILE.yaml] [--effects a,b] [--jobs N]\n"
    "                     [--false-alarms-per-year F] [--recordings-per-year R] [--quiet]\n"
    "  Analyses every bag (directories: every *.bag below them) with analyze_bag, N side by side (default:\n"
    "  one per core), keeps each result in DIR/bags/ and reuses it while the bag and the settings are\n"
    "  unchanged, and writes DIR/trend.csv (one row per recording) and DIR/trend.yaml (the changes found\n"
    "  in the parameters and verdicts, with the recording they began in). A bag that cannot be analysed is\n"
    "  reported and skipped. A: probability of reporting any change on a press without one, per run\n"
    "  (default 0.01). Exit 0, 2 on bad arguments or no bag, 3 when no bag could be analysed, 4 when the\n"
    "  results (analyze_bag's or the trend's) cannot be written: then no file is left under its name unless\n"
    "  whole, a previous trend stays as it was, and the bags concerned are analysed again by the next run.\n";

struct Options {
  std::vector<std::string> inputs;
  std::string out, config;
  std::string effects;
  bool effects_given = false;
  int jobs = 0;
  double false_alarms_per_year = 0.1;  // over all parameters of a press
  double recordings_per_year = 750.0;  // one per shift, three shifts, 250 days
  bool quiet = false;
};

[[noreturn]] void fail(int code, const std::string& message) {
  std::cerr << "analyze_trend: " << message;
  std::exit(code);
}

Options parseArguments(int argc, char** argv) {
  Options o;
  ArgumentParser arguments;
  arguments.option("--out", [&](const std::string& v) { o.out = v; })
      .option("--config", [&](const std::string& v) { o.config = v; })
      .option("--effects",
              [&](const std::string& v) {
                o.effects = v;
                o.effects_given = true;
              })
      .wholeNumber("--jobs", 1, 256, &o.jobs)
      .number("--false-alarms-per-year", 1e-6, 100.0, &o.false_alarms_per_year)
      .number("--recordings-per-year", 1.0, 1e7, &o.recordings_per_year)
      .flag("--quiet", [&] { o.quiet = true; })
      .positional("bags or directories", std::numeric_limits<int>::max(),
                  [&](const std::string& v) { o.inputs.push_back(v); });
  arguments.parseOrExit(argc, argv, "analyze_trend", kUsage);
  if (o.inputs.empty()) fail(2, std::string("no bag or directory given\n") + kUsage);
  if (o.out.empty()) fail(2, std::string("--out DIR is required\n") + kUsage);
  if (o.jobs == 0) o.jobs = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return o;
}

std::string shellQuoted(const std::string& text) {
  std::string quoted = "'";
  for (char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Every bag named or below a named directory (not inside the output directory), sorted by path.
std::vector<std::string> collectBags(const Options& o) {
  std::vector<std::string> bags;
  const fs::path out = fs::weakly_canonical(o.out);
  for (const auto& input : o.inputs) {
    std::error_code error;
    if (fs::is_directory(input, error)) {
      for (auto it = fs::recursive_directory_iterator(input, fs::directory_options::skip_permission_denied, error);
           it != fs::recursive_directory_iterator(); it.increment(error)) {
        if (error) break;
        const fs::path path = fs::weakly_canonical(it->path());
        if (path.string().rfind(out.string() + "/", 0) == 0) continue;
        if (it->is_regular_file(error) && path.extension() == ".bag") bags.push_back(path.string());
      }
    } else if (fs::exists(input, error)) {
      bags.push_back(fs::weakly_canonical(input).string());
    } else {
      fail(2, "no such bag or directory: " + input + "\n");
    }
  }
  std::sort(bags.begin(), bags.end());
  bags.erase(std::unique(bags.begin(), bags.end()), bags.end());
  return bags;
}

// One bag's place under DIR/bags/ and what decides whether its result can be reused.
struct BagJob {
  std::string bag, directory, fingerprint;
  bool reused = false, failed = false;
  std::string reason;  // why it was skipped
  double seconds = 0.0;
};

std::string fingerprintOf(const std::string& bag, const Options& o, const std::string& config_text) {
  std::error_code error;
  const auto size = fs::file_size(bag, error);
  const auto written = fs::last_write_time(bag, error).time_since_epoch().count();
  std::ostringstream f;
  f << "bag: " << bag << "\nsize: " << size << "\nmodified: " << written << "\nconfig: "
    << std::hash<std::string>{}(config_text) << "\neffects: " << (o.effects_given ? o.effects : "(config)") << "\n";
  return f.str();
}

std::string directoryFor(const std::string& bag, const Options& o) {
  const std::string hash = formatted(FMT_STRING("{:016x}"), std::hash<std::string>{}(bag));
  return (fs::path(o.out) / "bags" / (fs::path(bag).stem().string() + "-" + hash.substr(0, 8))).string();
}

std::string analyzeBagPath() {
  if (const char* configured = std::getenv("DCI_ANALYZE_BAG")) return configured;
  char self[4096];
  const ssize_t length = readlink("/proc/self/exe", self, sizeof(self) - 1);
  if (length > 0) {
    self[length] = '\0';
    return (fs::path(self).parent_path() / "analyze_bag").string();
  }
  return "analyze_bag";
}

// `command`'s exit status (its wait status) and everything it printed.
int runCapturing(const std::string& command, std::string* output) {
  FILE* pipe = popen((command + " 2>&1").c_str(), "re");  // not inherited by the other jobs' children
  if (!pipe) return -1;
  char buffer[4096];
  for (std::size_t got; (got = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0;) output->append(buffer, got);
  return pclose(pipe);
}

// One bag through analyze_bag; what it printed kept in analyze_bag.log, then failed.txt (why it failed) and
// fingerprint.txt (last: the directory is complete and can be reused), each whole. Throws WriteError when
// analyze_bag could not write its results (exit 4) or a file here cannot be written: nothing is then
// remembered, and the next run analyses the bag again.
void analyse(BagJob& job, const Options& o, const std::string& analyze_bag, int threads) {
  const auto started = std::chrono::steady_clock::now();
  std::error_code error;
  fs::remove_all(job.directory, error);
  if (!fs::create_directories(job.directory, error) && !fs::is_directory(job.directory)) {
    throw WriteError("cannot create " + job.directory + ": " + error.message());
  }
  std::string command = shellQuoted(analyze_bag) + " " + shellQuoted(job.bag) + " --out " +
                        shellQuoted(job.directory) + " --quiet --jobs " + std::to_string(threads);
  if (!o.config.empty()) command += " --config " + shellQuoted(o.config);
  if (o.effects_given) command += " --effects " + shellQuoted(o.effects);
  std::string text;
  const int status = runCapturing(command, &text);
  job.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  while (!text.empty() && text.back() == '\n') text.pop_back();
  if (code == 4) {
    const auto last_line = text.rfind('\n');
    throw WriteError("the analysis of " + job.bag + " could not be written: " +
                     (last_line == std::string::npos ? text : text.substr(last_line + 1)));
  }
  writeWholeFile(job.directory + "/analyze_bag.log", text.empty() ? text : text + "\n");
  const bool ok = status == 0 && fs::exists(job.directory + "/summary.yaml");
  if (!ok) {
    job.failed = true;
    const auto last_line = text.rfind('\n');
    std::string why = last_line == std::string::npos ? text : text.substr(last_line + 1);
    try {  // a partial result (exit 5) says in its summary what could not run, after the setup warnings
      // The setup's warnings (geometry left at its defaults) are not why it failed: matched by their code.
      std::vector<std::string> said;
      const YAML::Node summary = YAML::LoadFile(job.directory + "/summary.yaml");
      const YAML::Node warnings = summary["warnings"], codes = summary["warning_codes"];
      for (std::size_t i = 0; i < warnings.size(); ++i) {
        const bool setup =
            i < codes.size() && codes[i].as<std::string>() == warningCodeName(WarningCode::kGeometryDefault);
        if (!setup) said.push_back(warnings[i].as<std::string>());
      }
      if (!said.empty()) why = said.front() + (said.size() > 1 ? " (and " + std::to_string(said.size() - 1) + " more warnings)" : "");
    } catch (const std::exception&) {
    }
    job.reason = "analyze_bag failed (exit " + std::to_string(code) + "): " + why;
    writeWholeFile(job.directory + "/failed.txt", job.reason + "\n");
  }
  writeWholeFile(job.directory + "/fingerprint.txt", job.fingerprint);
}

Recording readRecording(const BagJob& job) {
  const YAML::Node s = YAML::LoadFile(job.directory + "/summary.yaml");
  Recording r;
  r.bag = job.bag;
  r.start = s["input"]["start"].as<double>(0.0);
  r.duration = s["input"]["duration"].as<double>(0.0);
  for (const auto& p : s["model"]["parameters"]) {
    r.parameters.push_back({p["name"].as<std::string>(), p["unit"].as<std::string>(""), p["value"].as<double>(),
                            p["std"].as<double>()});
  }
  r.simulation_error_rms = s["fit"]["simulation_error_rms"].as<double>(std::nan(""));
  if (const YAML::Node oil = s["oil_temperature"]; oil && oil["parameters_at"]) {
    r.oil_temperature = oil["parameters_at"].as<double>(std::nan(""));
  }
  if (const YAML::Node reference = s["reference_temperature"]; reference && reference["parameters"]) {
    r.reference_temperature = reference["temperature"].as<double>(std::nan(""));
    for (const auto& p : reference["parameters"]) {
      const double recording = p["std_parts"] ? p["std_parts"]["recording"].as<double>(std::nan(""))
                                              : p["std"].as<double>(std::nan(""));
      r.at_reference[p["name"].as<std::string>()] = {p["name"].as<std::string>(),
                                                     p["unit"].as<std::string>(""),
                                                     p["value"].as<double>(std::nan("")), recording};
    }
  }
  for (const auto& c : s["candidates"]) r.verdicts[c["effect"].as<std::string>()] = c["verdict"].as<std::string>();
  r.conclusion = s["conclusion"].as<std::string>("");
  const YAML::Node valve = s["valve"];
  if (valve && valve["natural_frequency"]) {
    const std::pair<const char*, const char*> keys[] = {
        {"natural_frequency", "Hz"}, {"damping", "-"}, {"gain", "1/V"}, {"dead_time", "s"}};
    for (const auto& [key, unit] : keys) {
      r.parameters.push_back({std::string("valve_") + key, unit, valve[key].as<double>(),
                              valve[std::string(key) + "_std"].as<double>()});
    }
  }
  return r;
}

void writeCsv(OutputFiles& files, const std::string& path, const std::vector<Recording>& rows,
              const std::vector<std::string>& names, const std::vector<std::string>& effects,
              const std::string& config_name, bool temperatures) {
  constexpr int kDigits = 9;  // a parameter's tenth of a per mille is far inside its std
  CsvFile csv(files.add(path));
  csv.text("bag").text("start").text("start_stamp").text("duration").text("config");
  for (const auto& n : names) csv.text(n).text(n + "_std");
  csv.text("simulation_error_rms");
  for (const auto& e : effects) csv.text("verdict_" + e);
  // Where the recordings hold the oil temperature: it, and each parameter at the reference temperature.
  if (temperatures) {
    csv.text("oil_temperature");
    for (const auto& n : names) csv.text(n + "_at_reference").text(n + "_at_reference_std");
  }
  csv.endLine();
  const double missing = std::numeric_limits<double>::quiet_NaN();  // an empty field
  for (const auto& r : rows) {
    csv.quoted(r.bag).text(isoTime(r.start)).fixed(r.start, 3).number(r.duration, kDigits).text(config_name);
    for (const auto& n : names) {
      const auto p = std::find_if(r.parameters.begin(), r.parameters.end(), [&](const auto& q) { return q.name == n; });
      const bool found = p != r.parameters.end();
      csv.number(found ? p->value : missing, kDigits).number(found ? p->std : missing, kDigits);
    }
    csv.number(r.simulation_error_rms, kDigits);
    for (const auto& e : effects) csv.text(r.verdicts.count(e) ? r.verdicts.at(e) : "");
    if (temperatures) {
      csv.number(r.oil_temperature, kDigits);
      for (const auto& n : names) {
        const auto p = r.at_reference.find(n);
        const bool found = p != r.at_reference.end();
        csv.number(found ? p->second.value : missing, kDigits).number(found ? p->second.std : missing, kDigits);
      }
    }
    csv.endLine();
  }
  csv.close();
}

// Which bags need analysing: a result is reused while its fingerprint (bag size and time, settings) holds.
std::vector<BagJob> planJobs(const std::vector<std::string>& bags, const Options& o, const std::string& config_text,
                             std::vector<std::size_t>* pending) {
  std::vector<BagJob> jobs;
  for (const auto& bag : bags) {
    BagJob job;
    job.bag = bag;
    job.directory = directoryFor(bag, o);
    job.fingerprint = fingerprintOf(bag, o, config_text);
    if (readFile(job.directory + "/fingerprint.txt") == job.fingerprint) {
      job.reused = true;
      if (fs::exists(job.directory + "/failed.txt")) {
        job.failed = true;
        job.reason = readFile(job.directory + "/failed.txt");
        while (!job.reason.empty() && job.reason.back() == '\n') job.reason.pop_back();
      } else if (!fs::exists(job.directory + "/summary.yaml")) {
        job.reused = false;
      }
    }
    if (!job.reused) pending->push_back(jobs.size());
    jobs.push_back(std::move(job));
  }
  return jobs;
}

// The pending bags analysed side by side, one thread each; a lone remaining bag gets the cores for its
// ranking. Returns the seconds it took.
double analysePending(std::vector<BagJob>& jobs, const std::vector<std::size_t>& pending, const Options& o,
                      const std::function<void(const std::string&)>& log) {
  const auto started = std::chrono::steady_clock::now();
  const std::string analyze_bag = analyzeBagPath();
  const int threads_each = std::max(1, o.jobs / std::max<int>(1, static_cast<int>(pending.size())));
  std::atomic<int> done{0};
  std::mutex log_mutex;
  parallelFor(pending.size(), o.jobs, [&](std::size_t k) {
    BagJob& job = jobs[pending[k]];
    analyse(job, o, analyze_bag, threads_each);
    std::lock_guard<std::mutex> lock(log_mutex);
    log(std::to_string(++done) + " of " + std::to_string(pending.size()) + ": " +
        fs::path(job.bag).filename().string() + (job.failed ? " skipped: " + job.reason : formatted(FMT_STRING(" ({:.1f} s)"), job.seconds)));
  });
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
}

// The recordings whose summaries could be read, in time order; the others listed as skipped with why.
std::vector<Recording> readRecordings(std::vector<BagJob>& jobs, YAML::Emitter& yaml) {
  std::vector<Recording> rows;
  yaml << YAML::Key << "skipped" << YAML::Value << YAML::BeginSeq;
  for (auto& job : jobs) {
    if (!job.failed) {
      try {
        rows.push_back(readRecording(job));
        continue;
      } catch (const std::exception& e) {
        job.failed = true;
        job.reason = std::string("its summary.yaml could not be read: ") + e.what();
      }
    }
    yaml << YAML::Flow << YAML::BeginMap << YAML::Key << "bag" << YAML::Value << job.bag << YAML::Key << "reason"
         << YAML::Value << job.reason << YAML::EndMap;
  }
  yaml << YAML::EndSeq;
  std::stable_sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) { return a.start < b.start; });
  return rows;
}

int run(int argc, char** argv) {
  const Options o = parseArguments(argc, argv);
  const std::function<void(const std::string&)> log = [&](const std::string& text) {
    if (!o.quiet) std::cerr << "analyze_trend: " << text << "\n";
  };
  if (!makeDirectory(o.out + "/bags")) fail(4, "cannot create " + o.out + "/bags\n");
  const std::vector<std::string> bags = collectBags(o);
  if (bags.empty()) fail(2, "no *.bag found in the given paths\n");
  const std::string config_text = o.config.empty() ? "" : readFile(o.config);
  if (!o.config.empty() && config_text.empty()) fail(2, "cannot read the config " + o.config + "\n");
  const std::string config_name = o.config.empty() ? "default" : fs::path(o.config).stem().string();

  std::vector<std::size_t> pending;
  std::vector<BagJob> jobs = planJobs(bags, o, config_text, &pending);
  log(std::to_string(bags.size()) + " recordings: " + std::to_string(pending.size()) + " to analyse, " +
      std::to_string(bags.size() - pending.size()) + " unchanged since the last run; " + std::to_string(o.jobs) +
      " side by side");
  const double seconds = analysePending(jobs, pending, o, log);

  YAML::Emitter yaml;
  yaml << YAML::BeginMap;
  const std::vector<Recording> rows = readRecordings(jobs, yaml);
  std::vector<std::string> names, effects;
  std::map<std::string, std::string> units;
  for (const auto& r : rows) {
    for (const auto& p : r.parameters) {
      if (!units.count(p.name)) names.push_back(p.name);
      units[p.name] = p.unit;
    }
    for (const auto& [effect, verdict] : r.verdicts) {
      if (std::find(effects.begin(), effects.end(), effect) == effects.end()) effects.push_back(effect);
    }
  }
  OutputFiles files;  // trend.csv and trend.yaml, renamed when both are whole (a failure removes them)
  const Tracking tracking = trackingOf(rows);
  writeCsv(files, o.out + "/trend.csv", rows, names, effects, config_name, tracking.at_reference);

  // The sequential tests are designed for the false alarms per press-year allowed, shared by every
  // parameter tested.
  SequentialDetectionOptions detection;
  detection.recordings_between_false_alarms =
      o.recordings_per_year * static_cast<double>(std::max<std::size_t>(1, names.size())) / o.false_alarms_per_year;
  yaml << YAML::Key << "recordings" << YAML::Value << rows.size();
  yaml << YAML::Key << "analysed_now" << YAML::Value << pending.size();
  yaml << YAML::Key << "false_alarms_per_year" << YAML::Value << o.false_alarms_per_year;
  yaml << YAML::Key << "recordings_per_year" << YAML::Value << o.recordings_per_year;
  yaml << YAML::Key << "recordings_between_false_alarms" << YAML::Value << detection.recordings_between_false_alarms;
  yaml << YAML::Key << "cusum_threshold" << YAML::Value << cusumThreshold(detection);
  std::map<std::string, DetectableChange> detectable;
  // At the reference temperature the values are compared relative to each other: what the oil's law missed is
  // then a line in the temperature (doc/condition_monitoring.md).
  detection.relative = tracking.at_reference;
  int changes = emitParameterChanges(rows, names, units, detection, tracking, &detectable, yaml, log);
  changes += emitVerdictChanges(rows, effects, yaml, log);
  emitDetectableChanges(rows, names, units, tracking, detectable, yaml);
  yaml << YAML::EndMap;
  {
    std::ofstream trend(files.add(o.out + "/trend.yaml"));
    trend << "# die_cushion_ident analyze_trend (doc/condition_monitoring.md)\n" << yaml.c_str() << "\n";
    closeChecked(trend, o.out + "/trend.yaml");
  }
  files.commit();
  const std::size_t skipped = jobs.size() - rows.size();
  log(std::to_string(rows.size()) + " recordings in the trend, " + std::to_string(skipped) + " skipped, " +
      std::to_string(changes) + " changes; " + std::to_string(pending.size()) + " analysed in " +
      formatted(FMT_STRING("{:.1f} s"), seconds) + "; results in " + o.out);
  return rows.empty() ? 3 : 0;
}

}  // namespace
}  // namespace die_cushion_ident

int main(int argc, char** argv) {
  try {
    return die_cushion_ident::run(argc, argv);
  } catch (const die_cushion_ident::WriteError& e) {
    std::cerr << "analyze_trend: " << e.what() << "\n";
    return 4;
  } catch (const std::exception& e) {
    std::cerr << "analyze_trend: " << e.what() << "\n";
    return 3;
  }
}
