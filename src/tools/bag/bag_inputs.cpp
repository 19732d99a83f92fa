#include "bag/bag_inputs.h"

#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/JointState.h>
#include <sensor_msgs/Temperature.h>

#include <chrono>
#include <memory>

#include "command_line.h"
#include "die_cushion_ident/ValveSignal.h"
#include "die_cushion_ident/core/util/batch_pipe.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "message_conversions.h"

namespace die_cushion_ident {

namespace {

const char* const kInputTypes[kInputStreamCount] = {"sensor_msgs/FluidPressure", "sensor_msgs/JointState",
                                                    "die_cushion_ident/ValveSignal"};
// The optional oil temperature topic's index among the connections' classes (after the three inputs).
constexpr int kOilTemperatureTopic = kInputStreamCount;
constexpr const char* kOilTemperatureType = "sensor_msgs/Temperature";

// The bag's connections as input streams: each classified once (its topic and definition compared), not
// each of its messages: its input stream (kOilTemperatureTopic for the optional oil temperature), -1 for
// another topic, -2 for a definition (md5sum) other than this package's.
class InputConnections {
 public:
  InputConnections(const std::string names[], const std::string& oil_temperature)
      : names_(names), oil_temperature_(oil_temperature) {}
  int streamOf(const BagStreamReader::Connection& c) const {
    for (int s = 0; s < kInputStreamCount; ++s) {
      if (c.topic == names_[s]) return s;
    }
    return c.topic == oil_temperature_ ? kOilTemperatureTopic : -1;
  }
  int classify(const BagStreamReader::Connection* c) {
    static const std::string kMd5[kInputStreamCount + 1] = {
        ros::message_traits::MD5Sum<sensor_msgs::FluidPressure>::value(),
        ros::message_traits::MD5Sum<sensor_msgs::JointState>::value(),
        ros::message_traits::MD5Sum<ValveSignal>::value(),
        ros::message_traits::MD5Sum<sensor_msgs::Temperature>::value()};
    for (const auto& [known, s] : classified_) {
      if (known == c) return s;
    }
    int s = streamOf(*c);
    if (s >= 0 && c->md5sum != kMd5[s]) s = -2;
    classified_.emplace_back(c, s);
    return s;
  }

 private:
  const std::string* names_;
  std::string oil_temperature_;
  std::vector<std::pair<const BagStreamReader::Connection*, int>> classified_;
};

// One input message decoded into `sample` (the cushion's joint picked from a JointState); false, counted in
// `pass` and `input`, where it cannot be used.
bool decodeInput(const BagStreamReader::Message& m, int s, JointSelector& joints,
                 sensor_msgs::JointState& joint_state, StreamSample& sample, BagPass& pass,
                 AnalysisInput& input) {
  bool decoded = false;
  if (s == 0) {
    decoded = decodeFluidPressure(m.data, m.size, &sample.stamp, &sample.first);
  } else if (s == 2) {
    decoded = decodeValveSignal(m.data, m.size, &sample.stamp, &sample.first, &sample.second);
  } else {
    double stamp = 0.0;
    decoded = decodeJointState(m.data, m.size, &stamp, &joint_state.name, &joint_state.position,
                               &joint_state.velocity);
    joint_state.header.stamp = stamp >= 0.0 && stamp < 4e9 ? ros::Time(stamp) : ros::Time(0);
    if (decoded) {
      switch (joints.select(joint_state, &sample)) {
        case JointSelector::Result::kSelected:
          sample.stamp = stamp;
          break;
        case JointSelector::Result::kJointMissing:
          ++input.unusable[s];
          ++pass.joint_missing;
          pass.joint_problem = joints.problem();
          return false;
        case JointSelector::Result::kNoPosition:
          ++input.unusable[s];
          ++pass.without_position;
          return false;
      }
    }
  }
  if (!decoded) {
    ++input.unusable[s];
    ++pass.damaged;
  }
  return decoded;
}

// A topic of the wrong type: the reading stops (and the analysis's thread with it) before the tool exits.
struct WrongTopicType {
  std::string message;
};

std::unique_ptr<BagStreamReader> openBag(const std::string& path) {
  try {
    return std::make_unique<BagStreamReader>(path);
  } catch (const std::exception& e) {
    fail(3, std::string("cannot open bag: ") + e.what());
  }
}

// What the reader found besides the messages: damage, messages the index lists but no chunk holds, a cut.
void keepReadersFindings(const BagStreamReader& reader, BagPass& pass) {
  pass.damage = reader.damage();
  pass.messages_missing = reader.messagesMissing();
  pass.records_unreadable = reader.recordsUnreadable();
  pass.messages_read = reader.messages();
  pass.unclosed = reader.unclosed();
  pass.cut_off = reader.cutOff();
  pass.data_lost = reader.dataLost();
  pass.bytes_read = reader.bytesRead();
}

}  // namespace

// Feeds the input topics of `path` to `analysis` in recorded order (BagStreamReader: memory independent of
// the recording's length, damage ends the reading with a reason); counts per topic in `input`. The analysis
// takes the messages on a thread of its own while this one reads and decodes the next (BatchPipe): one after
// the other, an hour's bag took the reading's 5 s plus the pipeline's.
BagPass readInputs(const std::string& path, const std::string names[], const std::string& oil_topic,
                   const std::string& joint_name, SurveyThenAnalysis& analysis, AnalysisInput& input,
                   const std::function<void(const std::string&)>& log) {
  BagPass pass;
  JointSelector joints(joint_name);
  const std::unique_ptr<BagStreamReader> reader = openBag(path);
  pass.file_size = reader->fileSize();
  // A hint from the index, bounded by what the file can hold (a message is at least ~40 bytes on disk).
  analysis.expect(reader->indexedSpan());
  log("reading " + std::to_string(pass.file_size >> 20) + " MB from " + input.bag);
  for (int s = 0; s < kInputStreamCount; ++s) input.messages[s] = input.unusable[s] = 0;
  input.oil_temperature_messages = input.oil_temperature_unusable = 0;
  auto last_report = std::chrono::steady_clock::now();
  std::uint64_t done = 0;
  sensor_msgs::JointState joint_state;
  InputConnections connections(names, oil_topic);
  BatchPipe<std::pair<int, StreamSample>> to_analysis([&analysis](const std::pair<int, StreamSample>& m) {
    if (m.first == kOilTemperatureTopic) {
      analysis.pushOilTemperature(m.second);
    } else {
      analysis.push(static_cast<InputStream>(m.first), m.second);
    }
  });
  const auto on_connection = [&](const BagStreamReader::Connection& c) {
    pass.listing += "\n  " + c.topic + " (" + c.datatype + ")";
    const int s = connections.streamOf(c);
    if (s < 0) return;
    if (s == kOilTemperatureTopic) {  // optional: a wrong type loses the temperature, not the analysis
      if (c.datatype != kOilTemperatureType) {
        pass.oil_temperature_problem = "topic " + oil_topic + " has type " + c.datatype + ", expected " +
                                       kOilTemperatureType + ": the oil temperature was not read";
      }
      return;
    }
    if (c.datatype != kInputTypes[s]) {
      throw WrongTopicType{"topic " + names[s] + " has type " + c.datatype + ", expected " + kInputTypes[s] +
                           " (set the topics in the config file if the inputs are elsewhere)"};
    }
    pass.present.insert(names[s]);
  };
  const auto on_message = [&](const BagStreamReader::Message& m) {
    if (std::isnan(pass.first)) pass.first = m.time;
    pass.last = m.time;
    const int s = connections.classify(m.connection);
    if (s == -1) return;
    if (s == -2) {
      ++pass.mismatched;
      return;
    }
    if (s == kOilTemperatureTopic) {
      if (!pass.oil_temperature_problem.empty()) return;
      ++input.oil_temperature_messages;
      StreamSample sample{0.0, 0.0, NAN};
      if (!decodeTemperature(m.data, m.size, &sample.stamp, &sample.first)) {
        ++input.oil_temperature_unusable;
        ++pass.damaged;
        return;
      }
      to_analysis.push({kOilTemperatureTopic, sample});
      return;
    }
    ++input.messages[s];
    StreamSample sample{0.0, 0.0, NAN};
    if (!decodeInput(m, s, joints, joint_state, sample, pass, input)) return;
    to_analysis.push({s, sample});
    // Progress every 2 s on long bags.
    if ((++done & 0xFFF) == 0 && std::chrono::steady_clock::now() - last_report > std::chrono::seconds(2)) {
      last_report = std::chrono::steady_clock::now();
      log(std::to_string(100 * reader->bytesRead() / std::max<std::uint64_t>(pass.file_size, 1)) +
          " % read (" + std::to_string(done) + " messages)");
    }
  };
  try {
    if (!reader->read(on_message, on_connection)) pass.read_error = reader->error();
  } catch (const WrongTopicType& wrong) {
    to_analysis.finish();
    fail(3, wrong.message);
  }
  to_analysis.finish();  // the analysis's exception, if any, from here on this thread
  keepReadersFindings(*reader, pass);
  input.records_unreadable = pass.records_unreadable;
  pass.joint_ambiguity = joints.ambiguity();
  return pass;
}

}  // namespace die_cushion_ident
