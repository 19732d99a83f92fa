// analyze_trend end to end (issue 14): daily recordings from simulate_bag of a press whose leakage starts
// rising on a known day, recorded alternately with the default sensors and with a position-only encoder at
// 500 Hz (a press whose recording set-up changed); the change is found within 3 recordings of its onset
// with the right parameter and day; a second run with one new bag analyses only that bag; a broken bag is
// reported and skipped; bad arguments get exit 2. The long acceptance matrix (air growing, 60 stable
// recordings, the speed-up of --jobs 2) is scripts/trend_acceptance.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>

#include "tool_runner.h"

namespace {

const std::string kTools = TOOL_DIR;
const std::string kWork = die_cushion_ident::testing::workDirectory("test_analyze_trend");
constexpr double kFirstDay = 1772582400.0;  // 2026-03-04T00:00:00Z
constexpr int kOnset = 8;                     // the leakage starts rising on 2026-03-12

using die_cushion_ident::testing::CommandResult;

CommandResult run(const std::string& command) {
  return die_cushion_ident::testing::runCommand(command, kWork + "/last_output.txt");
}

void recordDay(int day) {
  const double conductance = 5e-12 * (1.0 + (day >= kOnset ? 0.4 * (day - kOnset + 1) : 0.0));
  const std::string sensors = day % 2 ? " --no-velocity --rates 1000,500,1000" : "";
  char name[64], value[32];
  std::snprintf(name, sizeof(name), "/bags/day%02d.bag", day);
  std::snprintf(value, sizeof(value), "%.6g", conductance);
  const auto r = run(kTools + "/simulate_bag " + kWork + name + " --cycles 10 --plant-effects leakage --set " +
                     "leakage_conductance=" + value + " --seed " + std::to_string(day + 1) +
                     " --epoch " + std::to_string(static_cast<long>(kFirstDay + 86400.0 * day)) + sensors);
  ASSERT_EQ(r.status, 0) << r.output;
}

YAML::Node trendOf(const std::string& out) { return YAML::LoadFile(kWork + "/" + out + "/trend.yaml"); }

TEST(AnalyzeTrend, FindsTheRisingLeakageWithinThreeRecordingsAndReusesResults) {
  ASSERT_EQ(std::system(("rm -rf " + kWork + " && mkdir -p " + kWork + "/bags").c_str()), 0);
  // Recordings up to two days after the onset: the third recording of the rise is the newest.
  for (int day = 0; day <= kOnset + 2; ++day) recordDay(day);
  const std::string trend = kTools + "/analyze_trend " + kWork + "/bags --out " + kWork + "/out --effects leakage";
  auto first = run(trend + " --jobs 2");
  ASSERT_EQ(first.status, 0) << first.output;
  YAML::Node t = trendOf("out");
  EXPECT_EQ(t["recordings"].as<int>(), kOnset + 3);
  EXPECT_EQ(t["analysed_now"].as<int>(), kOnset + 3);
  ASSERT_EQ(t["changes"].size(), 1u) << first.output;
  EXPECT_TRUE(t["verdict_changes"].IsSequence());  // apart, so that every `changes` entry has the contract's keys
  const YAML::Node change = t["changes"][0];
  EXPECT_EQ(change["parameter"].as<std::string>(), "leakage_conductance");
  EXPECT_EQ(change["start"].as<std::string>(), "2026-03-12T00:00:00Z");
  EXPECT_DOUBLE_EQ(change["start_stamp"].as<double>(), kFirstDay + 86400.0 * kOnset);
  EXPECT_NEAR(change["before"].as<double>(), 5e-12, 0.3e-12);
  EXPECT_GT(change["after"].as<double>(), 1.5 * change["before"].as<double>());
  EXPECT_EQ(change["unit"].as<std::string>(), "m^3/(s*Pa)");
  EXPECT_NE(change["explanation"].as<std::string>().find("seal"), std::string::npos);

  // Nothing before the onset: the same directory without the rise reports no change.
  ASSERT_EQ(std::system(("mkdir -p " + kWork + "/steady && cp " + kWork + "/bags/day0[0-7].bag " + kWork +
                         "/steady/").c_str()), 0);
  auto steady = run(kTools + "/analyze_trend " + kWork + "/steady --out " + kWork +
                    "/steady_out --effects leakage --jobs 2");
  ASSERT_EQ(steady.status, 0) << steady.output;
  EXPECT_EQ(trendOf("steady_out")["changes"].size(), 0u) << steady.output;

  // The next day: only the new bag is analysed; a broken bag is reported and skipped.
  recordDay(kOnset + 3);
  ASSERT_EQ(std::system(("head -c 100000 " + kWork + "/bags/day03.bag > " + kWork + "/bags/broken.bag").c_str()), 0);
  auto second = run(trend);
  ASSERT_EQ(second.status, 0) << second.output;
  t = trendOf("out");
  EXPECT_EQ(t["analysed_now"].as<int>(), 2) << second.output;  // the new day and the broken bag
  EXPECT_EQ(t["recordings"].as<int>(), kOnset + 4);
  ASSERT_EQ(t["skipped"].size(), 1u);
  EXPECT_NE(t["skipped"][0]["bag"].as<std::string>().find("broken.bag"), std::string::npos);
  EXPECT_NE(t["skipped"][0]["reason"].as<std::string>().find("cut off"), std::string::npos)
      << t["skipped"][0]["reason"].as<std::string>();
  EXPECT_NE(second.output.find("2 to analyse"), std::string::npos) << second.output;
  // A third run finds everything unchanged (the broken bag's failure is remembered too).
  auto third = run(trend);
  EXPECT_EQ(trendOf("out")["analysed_now"].as<int>(), 0) << third.output;
  // One row per recording in the CSV, with the leakage and its std.
  const auto csv = run("(head -1 " + kWork + "/out/trend.csv && wc -l < " + kWork + "/out/trend.csv)");
  EXPECT_NE(csv.output.find("leakage_conductance,leakage_conductance_std"), std::string::npos) << csv.output;
  EXPECT_NE(csv.output.find("\n" + std::to_string(kOnset + 5) + "\n"), std::string::npos) << csv.output;
}

// Whole or absent on a full disk (issue 45; a file-size limit, `ulimit -f` with SIGXFSZ ignored, as
// test_analyze_bag does): exit 4 with "cannot write", no trend file under its final name unless whole (the
// previous run's, as it was), no temporary file left, and a bag whose analysis could not be written is not
// remembered as a failed bag: the next run with room analyses it.
std::map<std::string, std::string> filesBelow(const std::string& directory) {
  std::map<std::string, std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(directory)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    files[entry.path().lexically_relative(directory).string()] =
        std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return files;
}

TEST(AnalyzeTrend, AFullDiskExitsWithFourLeavesOnlyWholeFilesAndIsNotRemembered) {
  const std::string dir = kWork + "/full";
  ASSERT_EQ(std::system(("rm -rf " + dir + " && mkdir -p " + dir + "/bags").c_str()), 0);
  for (int day = 0; day < 2; ++day) {
    const auto r = run(kTools + "/simulate_bag " + dir + "/bags/day" + std::to_string(day) +
                       ".bag --cycles 3 --seed " + std::to_string(day + 1) + " --epoch " +
                       std::to_string(static_cast<long>(kFirstDay + 86400.0 * day)));
    ASSERT_EQ(r.status, 0) << r.output;
  }
  const std::string trend = kTools + "/analyze_trend " + dir + "/bags --out " + dir + "/out --jobs 2";
  const auto onAFullDisk = [&](int kilobytes, const std::string& extra) {
    // Its output through a pipe to the log, outside the limit.
    return run("bash -c 'set -o pipefail; (trap \"\" XFSZ; ulimit -f " + std::to_string(kilobytes) + "; " +
               trend + extra + ") 2>&1 | cat'");
  };
  // The disk full from the start: analyze_bag cannot write its results (each analysis.bag is about
  // 100 kB), nor analyze_trend its own.
  for (const int kilobytes : {0, 20}) {
    const auto r = onAFullDisk(kilobytes, "");
    EXPECT_EQ(r.status, 4) << kilobytes << " kB: " << r.output;
    EXPECT_NE(r.output.find("cannot write"), std::string::npos) << r.output;
    for (const auto& [name, bytes] : filesBelow(dir + "/out")) {
      EXPECT_EQ(name.find(".partial"), std::string::npos) << kilobytes << " kB: " << name;
      EXPECT_NE(name, "trend.csv") << kilobytes << " kB";
      EXPECT_NE(name, "trend.yaml") << kilobytes << " kB";
      EXPECT_EQ(name.find("fingerprint.txt"), std::string::npos) << kilobytes << " kB: remembered: " << name;
      EXPECT_EQ(name.find("failed.txt"), std::string::npos) << kilobytes << " kB: remembered: " << name;
    }
  }
  // With room: both bags analysed now (no failure remembered), the trend written.
  const auto r = run(trend);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(trendOf("full/out")["analysed_now"].as<int>(), 2) << r.output;
  const auto whole = filesBelow(dir + "/out");
  ASSERT_TRUE(whole.count("trend.csv") && whole.count("trend.yaml"));
  // Both bags reused, a new false-alarm rate: only the trend files are written, and they fail.
  const auto again = onAFullDisk(0, " --false-alarms-per-year 0.5");
  EXPECT_EQ(again.status, 4) << again.output;
  EXPECT_NE(again.output.find("cannot write"), std::string::npos) << again.output;
  const auto after = filesBelow(dir + "/out");
  EXPECT_TRUE(after == whole) << "the previous trend as it was, nothing temporary left";
  for (const auto& [name, bytes] : after) {
    EXPECT_TRUE(whole.count(name) && whole.at(name) == bytes) << name << " (" << bytes.size() << " bytes)";
  }
}

TEST(AnalyzeTrend, BadArgumentsGetExitTwoWithAReason) {
  std::system(("mkdir -p " + kWork).c_str());
  auto r = run(kTools + "/analyze_trend --out " + kWork + "/x");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("no bag or directory"), std::string::npos) << r.output;
  r = run(kTools + "/analyze_trend /nonexistent --out " + kWork + "/x");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("no such bag"), std::string::npos) << r.output;
  r = run(kTools + "/analyze_trend " + kWork + " --out " + kWork + "/x --jobs 0");
  EXPECT_EQ(r.status, 2);
  r = run(kTools + "/analyze_trend " + kWork + " --out " + kWork + "/x --false-alarms-per-year 0");
  EXPECT_EQ(r.status, 2);
  std::system(("mkdir -p " + kWork + "/empty").c_str());
  r = run(kTools + "/analyze_trend " + kWork + "/empty --out " + kWork + "/x");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("no *.bag"), std::string::npos) << r.output;
}

}  // namespace
