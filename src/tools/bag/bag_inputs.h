#pragma once

// analyze_bag's input topics read from a bag: what one pass over them found, and the pass itself.

#include <cmath>
#include <cstdint>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "bag/bag_stream_reader.h"
#include "output/analysis_writer.h"
#include "survey_then_analysis.h"

namespace die_cushion_ident {

// What one pass over the bag's input topics found.
struct BagPass {
  std::uint64_t mismatched = 0;        // messages of another definition (md5sum)
  std::uint64_t damaged = 0;           // messages whose bytes do not decode
  std::uint64_t joint_missing = 0;     // JointStates without the configured joint
  std::uint64_t without_position = 0;  // JointStates without a position for the cushion
  std::string joint_problem, joint_ambiguity;
  std::string read_error;                       // the bag could not be read to the end
  std::vector<BagStreamReader::Damage> damage;  // parts that failed their checks (the rest was read)
  std::uint64_t messages_missing = 0;           // listed by the index, not delivered by the chunks
  std::uint64_t records_unreadable = 0;         // message records in the file that could not be read
  std::uint64_t messages_read = 0;              // every topic's
  bool cut_off = false, data_lost = false;
  bool unclosed = false;  // killed while recording: the last chunk still open (rosbag record's .bag.active)
  std::uint64_t bytes_read = 0, file_size = 0;
  std::set<std::string> present;        // input topics seen
  std::string oil_temperature_problem;  // the oil temperature topic is there but cannot be read
  std::string listing;                  // every topic of the bag, for a message when none is an input
  double first = NAN, last = NAN;       // [s] record times of the first and last message
};

// Feeds the input topics of `path` to `analysis` in recorded order (BagStreamReader: memory independent of
// the recording's length, damage ends the reading with a reason); counts per topic in `input`. The analysis
// takes the messages on a thread of its own while this one reads and decodes the next (BatchPipe): one after
// the other, an hour's bag took the reading's 5 s plus the pipeline's.
BagPass readInputs(const std::string& path, const std::string names[], const std::string& oil_topic,
                   const std::string& joint_name, SurveyThenAnalysis& analysis, AnalysisInput& input,
                   const std::function<void(const std::string&)>& log);

/// analyze_bag's exit: "analyze_bag: `message`" on stderr, exit code `code` (analyze_bag.cpp).
[[noreturn]] void fail(int code, const std::string& message);

}  // namespace die_cushion_ident
