// analyze_bag: the offline analysis of a recorded bag (interface contract):
//   rosrun die_cushion_ident analyze_bag BAG --out DIR [--config FILE.yaml] [--effects a,b]
//                                        [--custom-effect NAME=EXPR]... [--quiet]
// Exit codes: 0 done, 2 bad command line or configuration, 3 the bag cannot be used, 4 outputs not written,
// 5 partial result (the bag was cut off while recording; what could be recovered was analysed).
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/JointState.h>
#include <sys/stat.h>

#include <chrono>
#include <csetjmp>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <iostream>
#include <set>
#include <sstream>

#include "analysis_config.h"
#include "analysis_writer.h"
#include "command_line.h"
#include "die_cushion_ident/ValveSignal.h"
#include "die_cushion_ident/core/offline_analysis.h"
#include "message_conversions.h"

namespace die_cushion_ident {
namespace {

const char* kUsage =
    "usage: analyze_bag BAG --out DIR [--config FILE.yaml] [--effects a,b] [--custom-effect NAME=EXPR]... "
    "[--quiet]\n"
    "  Identifies the die cushion's hydraulics and valve from a recorded bag and writes DIR/summary.yaml,\n"
    "  DIR/analysis.bag and CSV files. Library effects: leakage, entrained_air, valve_overlap, "
    "tank_pressure.\n"
    "  The config file holds the geometry (piston_area, stroke_length, supply_pressure), any setting of\n"
    "  README's configuration table, effects, custom_effects and topics: {pressure, position, valve}.\n";

struct Options {
  std::string bag, out, config;
  std::vector<std::string> effects, custom_effects;
  bool effects_given = false;
  bool quiet = false;
};

[[noreturn]] void fail(int code, const std::string& message) {
  std::cerr << "analyze_bag: " << message << "\n";
  std::exit(code);
}

Options parseArguments(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) fail(2, a + " needs a value\n" + kUsage);
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else if (a == "--out") {
      o.out = value();
    } else if (a == "--config") {
      o.config = value();
    } else if (a == "--effects") {
      o.effects_given = true;
      o.effects = splitList(value());
    } else if (a == "--custom-effect") {
      o.custom_effects.push_back(value());
    } else if (a == "--quiet") {
      o.quiet = true;
    } else if (!a.empty() && a[0] == '-') {
      fail(2, "unknown option " + a + "\n" + kUsage);
    } else if (o.bag.empty()) {
      o.bag = a;
    } else {
      fail(2, "more than one bag given ('" + o.bag + "', '" + a + "')\n" + kUsage);
    }
  }
  if (o.bag.empty()) fail(2, std::string("no bag given\n") + kUsage);
  if (o.out.empty()) fail(2, std::string("--out DIR is required\n") + kUsage);
  return o;
}

// A file that begins like a ROS bag (version 2.0), however damaged its end.
bool looksLikeBag(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  char magic[13] = {0};
  file.read(magic, 12);
  return file && std::string(magic) == "#ROSBAG V2.0";
}

// The repair's temporary directory, removed on every way out (fail() exits without unwinding the stack, so
// this is a static whose destructor runs at exit).
struct TemporaryDirectory {
  std::string path;
  void remove() {
    if (!path.empty()) std::system(("rm -rf '" + path + "'").c_str());
    path.clear();
  }
  ~TemporaryDirectory() { remove(); }
};
TemporaryDirectory repair_directory;

// A reindexed copy of `bag` in a new temporary directory (returned in `directory`); "" if that failed.
std::string repairedCopy(const std::string& bag, std::string* directory) {
  const char* tmp = std::getenv("TMPDIR");
  std::string pattern_text = std::string(tmp && *tmp ? tmp : "/tmp") + "/analyze_bag_repair_XXXXXX";
  std::vector<char> pattern(pattern_text.begin(), pattern_text.end());
  pattern.push_back('\0');
  if (!mkdtemp(pattern.data())) return "";
  *directory = pattern.data();
  repair_directory.path = *directory;
  const auto quoted = [](const std::string& s) {
    std::string out = "'";
    for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return out + "'";
  };
  // 'rosbag reindex' trusts the bag header's index position and stops at a damaged index: a bag that lost
  // only its index (cut a few kB before its end) comes out empty. A copy of the chunks alone (everything
  // before the index position) whose header says "no index" (the state of a bag cut while recording)
  // makes reindex scan the chunks instead.
  const auto slash = bag.find_last_of('/');
  const std::string name = slash == std::string::npos ? bag : bag.substr(slash + 1);
  const std::string unindexed_directory = *directory + "/unindexed";
  if (mkdir(unindexed_directory.c_str(), 0700) != 0) return "";
  const std::string unindexed = unindexed_directory + "/" + name;
  {
    std::ifstream in(bag, std::ios::binary);
    std::ofstream out(unindexed, std::ios::binary);
    std::vector<char> block(1 << 20);
    bool first = true;
    std::uint64_t remaining = std::numeric_limits<std::uint64_t>::max();  // bytes of chunks to copy
    while (in && remaining > 0) {
      in.read(block.data(), static_cast<std::streamsize>(std::min<std::uint64_t>(block.size(), remaining)));
      const std::streamsize got = in.gcount();
      if (got <= 0) break;
      if (first) {
        const std::string head(block.data(), std::min<std::size_t>(static_cast<std::size_t>(got), 4096 + 13));
        const auto at = head.find("index_pos=");
        if (at != std::string::npos && at + 18 <= head.size()) {
          std::uint64_t index_position = 0;
          for (int b = 7; b >= 0; --b)
            index_position = (index_position << 8) | static_cast<unsigned char>(head[at + 10 + b]);
          if (index_position > 0) remaining = index_position;
        }
        // The header record's fields: index_pos (8 bytes), conn_count and chunk_count (4 bytes each).
        const std::size_t header_end = std::min<std::size_t>(static_cast<std::size_t>(got), 4096 + 13);
        for (const auto& [field, width] : {std::pair<std::string, int>{"index_pos=", 8}, {"conn_count=", 4},
                                           {"chunk_count=", 4}}) {
          const auto at = std::string(block.data(), header_end).find(field);
          if (at != std::string::npos && at + field.size() + width <= header_end)
            std::fill_n(block.begin() + static_cast<std::ptrdiff_t>(at + field.size()), width, 0);
        }
        first = false;
      }
      out.write(block.data(), got);
      remaining -= static_cast<std::uint64_t>(got);
    }
    if (!out) return "";
  }
  const std::string command = "rosbag reindex --quiet --output-dir " + quoted(*directory) + " " +
                              quoted(unindexed) + " >/dev/null 2>&1";
  const int status = std::system(command.c_str());
  std::remove(unindexed.c_str());
  if (status != 0) return "";
  return *directory + "/" + name;
}

bool makeDirectory(const std::string& path) {
  std::string partial;
  std::stringstream parts(path);
  std::string part;
  if (!path.empty() && path[0] == '/') partial = "/";
  while (std::getline(parts, part, '/')) {
    if (part.empty()) continue;
    partial += part + "/";
    if (mkdir(partial.c_str(), 0755) != 0 && errno != EEXIST) return false;
  }
  struct stat info;
  return stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode);
}

// What one pass over the bag's input topics found.
struct BagPass {
  std::uint64_t mismatched = 0;        // messages of another definition (md5sum)
  std::uint64_t joint_missing = 0;     // JointStates without the configured joint
  std::uint64_t without_position = 0;  // JointStates without a position for the cushion
  std::string joint_problem, joint_ambiguity;
  std::string read_error;  // the bag could not be read to the end
  std::uint64_t read = 0, total = 0;  // messages of the input topics read, and in the index
};

// rosbag reads a corrupted chunk without bounds checks and can crash (SIGSEGV, SIGBUS) inside its own
// code. While the input topics are read, such a fault ends the reading like a read error: the analysis
// covers what was read before the damage (exit 5), instead of the program dying.
sigjmp_buf read_fault;
volatile sig_atomic_t reading_bag = 0;
volatile std::uint64_t messages_read = 0, messages_total = 0;

void onReadFault(int signal_number) {
  if (reading_bag) siglongjmp(read_fault, signal_number);
  std::signal(signal_number, SIG_DFL);  // not ours: die as the signal means
  std::raise(signal_number);
}

// Feeds the input topics of `bag` to `analysis` in time order; counts per topic in `input`.
BagPass readInputs(rosbag::Bag& bag, const std::vector<std::string>& present, const std::string names[],
                   const std::string& joint_name, OfflineAnalysis& analysis, AnalysisInput& input,
                   const std::function<void(const std::string&)>& log) {
  BagPass pass;
  JointSelector joints(joint_name);
  struct sigaction fault = {}, old_segv = {}, old_bus = {};
  fault.sa_handler = onReadFault;
  sigemptyset(&fault.sa_mask);
  sigaction(SIGSEGV, &fault, &old_segv);
  sigaction(SIGBUS, &fault, &old_bus);
  messages_read = messages_total = 0;
  if (const int signal_number = sigsetjmp(read_fault, 1); signal_number != 0) {
    reading_bag = 0;
    sigaction(SIGSEGV, &old_segv, nullptr);
    sigaction(SIGBUS, &old_bus, nullptr);
    pass.read = messages_read;
    pass.total = messages_total;
    pass.read_error = std::string("its data is damaged: rosbag failed with ") +
                      (signal_number == SIGBUS ? "a bus error" : "a segmentation fault") + " reading it";
    pass.joint_ambiguity = joints.ambiguity();
    return pass;
  }
  reading_bag = 1;
  try {
    rosbag::View view(bag, rosbag::TopicQuery(present));
    const std::uint64_t total = view.size();
    pass.total = total;
    messages_total = total;
    char span[32];
    std::snprintf(span, sizeof(span), "%.0f", input.duration);
    log("reading " + std::to_string(total) + " messages (" + span + " s) from " + input.bag);
    std::uint64_t done = 0;
    auto last_report = std::chrono::steady_clock::now();
    for (int s = 0; s < kInputStreamCount; ++s) input.messages[s] = 0;
    for (const rosbag::MessageInstance& m : view) {
      const std::string& topic = m.getTopic();
      if (topic == names[0]) {
        if (const auto msg = m.instantiate<sensor_msgs::FluidPressure>()) {
          analysis.push(InputStream::kPressure, {msg->header.stamp.toSec(), msg->fluid_pressure,
                                                 std::numeric_limits<double>::quiet_NaN()});
          ++input.messages[0];
        } else {
          ++pass.mismatched;
        }
      } else if (topic == names[1]) {
        if (const auto msg = m.instantiate<sensor_msgs::JointState>()) {
          ++input.messages[1];
          StreamSample sample;
          switch (joints.select(*msg, &sample)) {
            case JointSelector::Result::kSelected:
              analysis.push(InputStream::kPosition, sample);
              break;
            case JointSelector::Result::kJointMissing:
              ++pass.joint_missing;
              pass.joint_problem = joints.problem();
              break;
            case JointSelector::Result::kNoPosition:
              ++pass.without_position;
              break;
          }
        } else {
          ++pass.mismatched;
        }
      } else if (topic == names[2]) {
        if (const auto msg = m.instantiate<ValveSignal>()) {
          analysis.push(InputStream::kValve, {msg->header.stamp.toSec(), msg->voltage, msg->spool_position});
          ++input.messages[2];
        } else {
          ++pass.mismatched;
        }
      }
      pass.read = ++done;
      messages_read = done;
      // Progress every 2 s on long bags.
      if ((done & 0xFFF) == 0 && std::chrono::steady_clock::now() - last_report > std::chrono::seconds(2)) {
        last_report = std::chrono::steady_clock::now();
        log(std::to_string(100 * done / std::max<std::uint64_t>(total, 1)) + " % read (" + std::to_string(done) +
            " messages)");
      }
    }
  } catch (const std::exception& e) {
    pass.read_error = e.what();
  }
  reading_bag = 0;
  sigaction(SIGSEGV, &old_segv, nullptr);
  sigaction(SIGBUS, &old_bus, nullptr);
  pass.joint_ambiguity = joints.ambiguity();
  return pass;
}

std::string milliseconds(double seconds) {
  char text[32];
  std::snprintf(text, sizeof(text), "%+.2f ms", seconds * 1e3);
  return text;
}

// Opens `path`, or a reindexed copy when its index is missing, cut off or lost (the file then still
// begins like a bag). Returns whether the analysis covers only what the repair recovered.
bool openBag(const std::string& path, std::unique_ptr<rosbag::Bag>& opened, std::vector<std::string>* warnings) {
  opened = std::make_unique<rosbag::Bag>();
  rosbag::Bag& bag = *opened;
  struct stat file;
  if (stat(path.c_str(), &file) != 0) fail(3, "cannot open bag '" + path + "': no such file");
  if (S_ISDIR(file.st_mode)) fail(3, "cannot open bag '" + path + "': it is a directory");
  std::string why;
  try {
    bag.open(path, rosbag::bagmode::Read);
    // A bag that lost only its index (cut a few kB before its end) opens as empty: look at the file size.
    struct stat info;
    const bool holds_data = stat(path.c_str(), &info) == 0 && info.st_size > 64 * 1024;
    if (rosbag::View(bag).size() > 0 || !holds_data) return false;
    why = "it opens as empty although the file holds " + std::to_string(info.st_size / 1024) + " kB";
    bag.close();
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    if (!looksLikeBag(path)) {
      fail(3, "'" + path + "' is not a ROS bag (a version 2.0 bag begins with '#ROSBAG V2.0'; rosbag says: " +
                  e.what() + ")");
    }
    why = e.what();
  }
  // A bag whose index is missing or lies beyond its end was cut off while recording or copying: recover
  // what was written, in a temporary copy.
  std::cerr << "analyze_bag: error: '" << path << "' is not indexed (cut off while recording: " << why
            << "); recovering what it holds with 'rosbag reindex'\n";
  std::string directory;
  const std::string repaired = repairedCopy(path, &directory);
  try {
    if (repaired.empty()) throw std::runtime_error("rosbag reindex failed");
    try {
      bag.close();  // the failed open leaves the file attached
    } catch (const std::exception&) {
    }
    // A fresh object: a failed open may leave part of the broken index (connections, chunks) behind.
    auto fresh = std::make_unique<rosbag::Bag>();
    fresh->open(repaired, rosbag::bagmode::Read);
    opened = std::move(fresh);
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    fail(3, "cannot open bag '" + path + "': not indexed and not repairable (" + e.what() + ")");
  }
  warnings->push_back("the bag was cut off while recording: the analysis covers the part 'rosbag reindex' recovered");
  return true;
}

int run(int argc, char** argv) {
  const Options options = parseArguments(argc, argv);
  const auto log = [&](const std::string& line) {
    if (!options.quiet) std::cerr << "analyze_bag: " << line << "\n";
  };

  IdentificationConfig config;
  InputTopics topics;
  std::vector<std::string> keys;
  if (!options.config.empty()) {
    const auto problems = loadAnalysisConfig(options.config, &config, &topics, &keys);
    if (!problems.empty()) {
      std::string all;
      for (const auto& p : problems) all += "\n  " + p;
      fail(2, "invalid configuration in " + options.config + ":" + all);
    }
  }
  if (options.effects_given) config.effects = options.effects;
  for (const auto& c : options.custom_effects) config.custom_effects.push_back(c);
  std::vector<std::string> warnings;
  for (const char* key : {"piston_area", "stroke_length", "supply_pressure"}) {
    if (std::find(keys.begin(), keys.end(), key) == keys.end()) {
      warnings.push_back(std::string("geometry key '") + key +
                         "' not configured: the default of README's configuration table is used");
    }
  }
  {
    const auto problems = config.validate();
    if (!problems.empty()) {
      std::string all;
      for (const auto& p : problems) all += "\n  " + p;
      fail(2, "invalid configuration:" + all);
    }
  }

  std::unique_ptr<rosbag::Bag> opened;
  bool partial = openBag(options.bag, opened, &warnings);
  rosbag::Bag& bag = *opened;

  // The three inputs: present, and of the contract's types.
  const std::string names[kInputStreamCount] = {topics.pressure, topics.position, topics.valve};
  const std::string types[kInputStreamCount] = {"sensor_msgs/FluidPressure", "sensor_msgs/JointState",
                                                "die_cushion_ident/ValveSignal"};
  std::set<std::string> present;
  std::string listing;
  double begin = 0.0, end = 0.0;
  try {
    rosbag::View everything(bag);
    for (const auto* c : everything.getConnections()) {
      listing += "\n  " + c->topic + " (" + c->datatype + ")";
      for (int s = 0; s < kInputStreamCount; ++s) {
        if (c->topic != names[s]) continue;
        if (c->datatype != types[s]) {
          fail(3, "topic " + names[s] + " has type " + c->datatype + ", expected " + types[s] +
                      " (set the topics in the config file if the inputs are elsewhere)");
        }
        present.insert(names[s]);
      }
    }
    if (everything.size() > 0) {
      begin = everything.getBeginTime().toSec();
      end = everything.getEndTime().toSec();
    }
  } catch (const std::exception& e) {
    fail(3, "cannot read bag '" + options.bag + "': " + e.what());
  }
  if (present.empty()) {
    fail(3, "none of the input topics " + names[0] + ", " + names[1] + ", " + names[2] + " is in '" +
                options.bag + "'; it holds:" +
                (listing.empty() ? std::string("\n  (nothing: the bag is empty)") : listing));
  }
  for (int s = 0; s < kInputStreamCount; ++s) {
    if (!present.count(names[s])) warnings.push_back("topic " + names[s] + " is not in the bag");
  }

  AnalysisInput input;
  input.bag = options.bag;
  input.duration = end - begin;
  input.joint_name = topics.joint_name;
  for (int s = 0; s < kInputStreamCount; ++s) input.topics[s] = names[s];
  const std::vector<std::string> present_topics(present.begin(), present.end());
  const auto started = std::chrono::steady_clock::now();

  auto analysis = std::make_unique<OfflineAnalysis>(config);
  BagPass pass = readInputs(bag, present_topics, names, topics.joint_name, *analysis, input, log);
  if (present.count(names[1]) && input.messages[1] > 0 && pass.joint_missing == input.messages[1]) {
    fail(3, "no position message holds the cushion's joint: " + pass.joint_problem);
  }
  // Topics stamped by different clocks: estimate the offsets from the physics and read the bag again
  // with the stamps corrected (only when they matter, so a well-stamped bag is read once).
  std::optional<TopicDelayEstimate> delays;
  if (!config.topicDelaysSet() && pass.read_error.empty()) {
    log("estimating the clock offsets between the topics");
    delays = analysis->estimateTopicDelays();
    if (delays->significant(config.resampler.sample_period)) {
      config.topic_delays = delays->delays;
      log("position stamps " + milliseconds(delays->delays[1]) + ", valve stamps " +
          milliseconds(delays->delays[2]) + " against pressure: reading again with the stamps corrected");
      analysis = std::make_unique<OfflineAnalysis>(config);
      pass = readInputs(bag, present_topics, names, topics.joint_name, *analysis, input, log);
    }
  }
  if (pass.mismatched > 0) {
    warnings.push_back(std::to_string(pass.mismatched) +
                       " messages had a different definition (md5sum) than this package's and were skipped");
  }
  if (pass.joint_missing > 0) {
    warnings.push_back(std::to_string(pass.joint_missing) + " position messages skipped: " + pass.joint_problem);
  }
  if (pass.without_position > 0) {
    warnings.push_back(std::to_string(pass.without_position) +
                       " position messages without a position for the cushion's joint were skipped");
  }
  if (!pass.joint_ambiguity.empty()) warnings.push_back(pass.joint_ambiguity);
  if (!pass.read_error.empty()) {
    char share[64];
    std::snprintf(share, sizeof(share), "%.1f", 100.0 * pass.read / std::max<std::uint64_t>(pass.total, 1));
    warnings.push_back("the bag could not be read to the end (" + pass.read_error + "): the analysis covers " +
                       share + " % of its messages (" + std::to_string(pass.read) + " of " +
                       std::to_string(pass.total) + "), read before the damage");
    log(warnings.back());
    partial = true;
  }
  bag.close();
  repair_directory.remove();

  OfflineResult result = analysis->finish([&](const std::string& step) { log(step); });
  result.warnings.insert(result.warnings.begin(), warnings.begin(), warnings.end());
  if (delays) {
    result.delay_estimate = delays;
    if (delays->valid) {
      // Offsets below a quarter sample are reported but not corrected: they change nothing measurable.
      result.topic_delays_source = delays->significant(config.resampler.sample_period)
                                       ? "estimated"
                                       : "estimated, below a quarter sample period: not corrected";
      constexpr double kLargeOffset = 0.005;  // [s] beyond this a recording setup deserves a look
      for (int s = 1; s < kInputStreamCount; ++s) {
        if (std::abs(delays->delays[s]) > kLargeOffset) {
          result.warnings.push_back(std::string("the ") + inputStreamName(static_cast<InputStream>(s)) +
                                    " topic's stamps are " + milliseconds(delays->delays[s]) +
                                    " off the pressure's (estimated from the data and corrected): its "
                                    "driver stamps on receipt or by another clock; set topic_delays to "
                                    "fix the value, or stamp at the measurement");
        }
      }
    } else {
      result.warnings.push_back("the clock offsets between the topics could not be estimated (" +
                                delays->message + "): the stamps are used as recorded");
    }
  }
  if (!makeDirectory(options.out)) fail(4, "cannot create output directory '" + options.out + "'");
  try {
    writeAnalysis(options.out, input, config, result, analysis->grid());
  } catch (const std::exception& e) {
    fail(4, std::string("cannot write the results: ") + e.what());
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  for (const auto& w : result.warnings) log("warning: " + w);
  log("simulation error " + std::to_string(result.assessment.simulation_error_rms * 1e-5) + " bar rms; " +
      result.ranking.conclusion);
  if (result.valve) log("valve: " + result.valve->fit.message);
  char speed[128];
  std::snprintf(speed, sizeof(speed), "%.1f s for %llu messages (%.2f M/s); results in %s", seconds,
                static_cast<unsigned long long>(result.messages),
                result.messages / std::max(seconds, 1e-9) / 1e6, options.out.c_str());
  log(speed);
  if (partial || result.partial) {
    std::cerr << "analyze_bag: partial result: " << (result.partial ? "part of the analysis could not run"
                                                                     : "the bag could not be read completely")
              << "; see the warnings in summary.yaml\n";
    return 5;
  }
  return 0;
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
