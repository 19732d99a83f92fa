// Whole or absent (issue 45): every tool writes each output under a temporary name in the same directory
// and renames it only when it is complete and every write succeeded. On a full disk (a file-size limit
// here, `ulimit -f` with SIGXFSZ ignored, as test_analyze_bag's AFullDiskExitsWithFourAndLeavesNoFile:
// every write beyond the limit fails with EFBIG) simulate_bag, study_settings and scripts/report exit with
// the contract's code 4, say "cannot write", leave no file under a final name that is partial, leave no
// temporary file behind, and leave the previous run's complete outputs as they were. analyze_trend's own
// cases are in test_analyze_trend.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "tool_runner.h"

namespace {

namespace fs = std::filesystem;

const std::string kTools = TOOL_DIR;
const std::string kReport = std::string(SCRIPTS_DIR) + "/report";
const std::string kWork = die_cushion_ident::testing::workDirectory("test_whole_outputs");

using die_cushion_ident::testing::CommandResult;

CommandResult run(const std::string& command) {
  return die_cushion_ident::testing::runCommand(command, kWork + "/last_output.txt");
}

// `command` with every file it writes limited to `kilobytes`; what it prints goes through a pipe to the log,
// which is written outside the limit (a log file inherited as stderr would be limited too).
CommandResult onAFullDisk(int kilobytes, const std::string& command) {
  return run("bash -c 'set -o pipefail; (trap \"\" XFSZ; ulimit -f " + std::to_string(kilobytes) + "; " +
             command + ") 2>&1 | cat'");
}

std::string fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Every regular file in `directory` (not below it) by name, with its bytes.
std::map<std::string, std::string> filesIn(const std::string& directory) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::directory_iterator(directory)) {
    if (entry.is_regular_file()) files[entry.path().filename().string()] = fileBytes(entry.path().string());
  }
  return files;
}

// The files' names and sizes, for a failure's message (not their bytes).
std::string described(const std::map<std::string, std::string>& files) {
  std::string text = "{";
  for (const auto& [name, bytes] : files)
    text += " " + name + " (" + std::to_string(bytes.size()) + " bytes)";
  return text + " }";
}

// The largest file of a complete run: a limit below it makes that write fail.
std::size_t largest(const std::map<std::string, std::string>& files) {
  std::size_t size = 0;
  for (const auto& [name, bytes] : files) size = std::max(size, bytes.size());
  return size;
}

class WholeOutputs : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { std::system(("rm -rf " + kWork + " && mkdir -p " + kWork).c_str()); }
};

// A failed simulate_bag left a bag cut at the limit that rosbag and analyze_bag read as a short recording.
TEST_F(WholeOutputs, SimulateBagOnAFullDiskLeavesNoBag) {
  const std::string dir = kWork + "/simulate";
  fs::create_directories(dir);
  const std::string command = kTools + "/simulate_bag " + dir +
                              "/press.bag --cycles 4 --seed 3 --write-config " + dir +
                              "/press.yaml --write-truth " + dir + "/truth.yaml";
  // The complete bag is about 1.3 MB; config and truth are a few hundred bytes: 0 fails every file,
  // 100 kB the bag after its first chunk, 1000 kB its last chunk or its index.
  for (const int kilobytes : {0, 100, 1000}) {
    const CommandResult r = onAFullDisk(kilobytes, command);
    EXPECT_EQ(r.status, 4) << kilobytes << " kB: " << r.output;
    EXPECT_NE(r.output.find("cannot write"), std::string::npos) << r.output;
    EXPECT_TRUE(filesIn(dir).empty())
        << kilobytes << " kB: no bag, config or truth, whole or partial: " << described(filesIn(dir));
  }
  // The same run with room writes all three.
  ASSERT_EQ(run(command).status, 0);
  const auto whole = filesIn(dir);
  EXPECT_EQ(whole.size(), 3u);
  ASSERT_GT(whole.at("press.bag").size(), 1000u * 1024u) << "the limits above cut into the bag";
  // A second run that fails keeps the first run's files as they were.
  const CommandResult again =
      onAFullDisk(100, kTools + "/simulate_bag " + dir + "/press.bag --cycles 5 --seed 4");
  EXPECT_EQ(again.status, 4) << again.output;
  EXPECT_TRUE(filesIn(dir) == whole) << "the previous bag untouched, no temporary file left: "
                                     << described(filesIn(dir)) << " after " << described(whole);
}

// study_settings writes its CSV, four charts and the recommendation at the end of the study.
TEST_F(WholeOutputs, StudySettingsOnAFullDiskLeavesNoResult) {
  const std::string dir = kWork + "/study";
  const std::string command = kTools + "/study_settings --out " + dir + " --seeds 2 --cycles 1 --jobs 2";
  ASSERT_EQ(run(command).status, 0);
  const auto whole = filesIn(dir);
  ASSERT_EQ(whole.size(), 6u) << "settings_study.csv, four charts, recommendation.txt";
  // A limit below its largest file fails that one after others may have been written; 0 fails the first.
  const int below = static_cast<int>(largest(whole) / 1024) - 1;
  ASSERT_GT(below, 0);
  for (const int kilobytes : {0, below}) {
    const std::string out = dir + "_full" + std::to_string(kilobytes);
    const CommandResult r =
        onAFullDisk(kilobytes, kTools + "/study_settings --out " + out + " --seeds 2 --cycles 1 --jobs 2");
    EXPECT_EQ(r.status, 4) << kilobytes << " kB: " << r.output;
    EXPECT_NE(r.output.find("cannot write"), std::string::npos) << r.output;
    EXPECT_TRUE(filesIn(out).empty())
        << kilobytes << " kB: nothing under a final name, nothing temporary: " << described(filesIn(out));
  }
  // Over a complete run: its files stay as they were.
  const CommandResult r = onAFullDisk(below, command);
  EXPECT_EQ(r.status, 4) << r.output;
  EXPECT_TRUE(filesIn(dir) == whole) << described(filesIn(dir)) << " after " << described(whole);
}

// scripts/report writes report.html and its PNG plots next to the analysis.
TEST_F(WholeOutputs, ReportOnAFullDiskLeavesNoReport) {
  const std::string dir = kWork + "/report";
  ASSERT_EQ(
      run(kTools + "/simulate_bag " + kWork + "/leak.bag --cycles 4 --plant-effects leakage --seed 5").status,
      0);
  const CommandResult analysed =
      run(kTools + "/analyze_bag " + kWork + "/leak.bag --out " + dir + " --quiet");
  ASSERT_TRUE(analysed.status == 0 || analysed.status == 5) << analysed.output;
  const auto analysis = filesIn(dir);
  const std::string copy = kWork + "/report_copy";
  ASSERT_EQ(run("cp -r " + dir + " " + copy).status, 0);
  ASSERT_EQ(run(kReport + " " + dir).status, 0) << fileBytes(kWork + "/last_output.txt");
  const auto whole = filesIn(dir);
  ASSERT_GE(whole.size(), analysis.size() + 3) << "report.html and at least two plots";
  std::map<std::string, std::string> report;
  for (const auto& [name, bytes] : whole) {
    if (!analysis.count(name)) report[name] = bytes;
  }
  const int below = static_cast<int>(largest(report) / 1024) - 1;
  ASSERT_GT(below, 20);
  for (const int kilobytes : {0, below}) {
    const std::string out = kWork + "/report_full" + std::to_string(kilobytes);
    ASSERT_EQ(run("rm -rf " + out + " && cp -r " + copy + " " + out).status, 0);
    const CommandResult r = onAFullDisk(kilobytes, kReport + " " + out);
    EXPECT_EQ(r.status, 4) << kilobytes << " kB: " << r.output;
    EXPECT_NE(r.output.find("cannot write"), std::string::npos) << r.output;
    EXPECT_TRUE(filesIn(out) == analysis) << kilobytes << " kB: no report file, whole or partial, beside the "
                                          << "analysis: " << described(filesIn(out));
  }
  // Over a complete report: it stays as it was.
  const CommandResult r = onAFullDisk(20, kReport + " " + dir);
  EXPECT_EQ(r.status, 4) << r.output;
  EXPECT_TRUE(filesIn(dir) == whole) << described(filesIn(dir)) << " after " << described(whole);
}

}  // namespace
