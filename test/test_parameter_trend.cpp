// Issue 14: change detection over many recordings (core). Synthetic series with the stds the analysis
// reports: a step and a starting drift are found within 3 recordings of their onset, at the right
// recording; stable series of 60 recordings give a false alarm at most at the configured rate.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "die_cushion_ident/core/analysis/parameter_trend.h"

namespace die_cushion_ident {
namespace {

constexpr double kDay = 86400.0;

// As analyze_trend runs it every day on the recordings so far: 1 % per run shared by 5 parameters. A
// series is tested again on every day, so the rate over a whole sequence of runs is higher; the detection
// is also asserted never to fire before the onset on these prefixes.
const ChangeDetectionOptions kDailyRun{0.002, 3};

// `count` daily estimates of `level(i)`, each with a relative std of `relative_std` (reported) and scattered
// by it plus a day-to-day variation of `day_to_day` (relative) that the stds do not cover.
std::vector<TrendPoint> dailySeries(int count, double (*level)(int), double relative_std, double day_to_day,
                                    std::mt19937& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<TrendPoint> series;
  for (int i = 0; i < count; ++i) {
    const double truth = level(i);
    const double std = relative_std * truth * (0.5 + 0.1 * (i % 10));  // recordings differ in length
    series.push_back({1.77e9 + i * kDay, truth * (1.0 + day_to_day * normal(rng)) + std * normal(rng), std});
  }
  return series;
}

// The first prefix (recordings 0 .. m) on which a change is found, and the change.
std::pair<int, ParameterChange> firstDetection(const std::vector<TrendPoint>& series,
                                               const ChangeDetectionOptions& options = {}) {
  for (std::size_t m = 1; m <= series.size(); ++m) {
    const auto change = detectParameterChange({series.begin(), series.begin() + m}, options);
    if (change) return {static_cast<int>(m) - 1, *change};
  }
  return {-1, {}};
}

TEST(ParameterTrend, ALeakageStepIsFoundWithinThreeRecordingsAtItsOnset) {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 20; ++trial) {
    const auto series = dailySeries(25, [](int i) { return i < 12 ? 1.1e-12 : 3.1e-12; }, 0.03, 0.02, rng);
    const auto [at, change] = firstDetection(series, kDailyRun);
    ASSERT_GE(at, 12) << "trial " << trial << ": a change before the onset";
    EXPECT_LE(at, 14) << "trial " << trial;
    EXPECT_EQ(change.start_index, 12u);
    EXPECT_EQ(change.shape, "step");
    EXPECT_NEAR(change.before, 1.1e-12, 0.1e-12);
    const std::string words = explainChange("leakage_conductance", "m^3/(s*Pa)", change, isoTime(change.start_stamp));
    EXPECT_NE(words.find("-fold ("), std::string::npos) << words;
    EXPECT_NE(words.find("has risen"), std::string::npos) << words;
    EXPECT_NE(words.find("seal"), std::string::npos) << words;
  }
}

TEST(ParameterTrend, AStartingDriftIsFoundWithinThreeRecordings) {
  std::mt19937 rng(2);
  int late = 0;
  for (int trial = 0; trial < 20; ++trial) {
    // Air drawn in from day 15: the air volume grows by a quarter of its level each day.
    const auto series =
        dailySeries(30, [](int i) { return 2e-4 * (1.0 + (i < 15 ? 0.0 : 0.25 * (i - 14))); }, 0.03, 0.02, rng);
    const auto [at, change] = firstDetection(series, kDailyRun);
    ASSERT_GE(at, 15) << "trial " << trial;
    late += at > 17;
    EXPECT_NEAR(static_cast<double>(change.start_index), 15.0, 1.0) << "trial " << trial;
    EXPECT_GT(change.after, change.before);
  }
  EXPECT_EQ(late, 0);
}

TEST(ParameterTrend, StableSeriesGiveFalseAlarmsAtMostAtTheConfiguredRate) {
  std::mt19937 rng(3);
  ChangeDetectionOptions options;
  options.false_alarm_rate = 0.05;
  const int series_count = 400;
  int alarms = 0;
  for (int s = 0; s < series_count; ++s) {
    const double day_to_day = (s % 3) * 0.02;  // none, as much as the stds, twice
    const auto series = dailySeries(60, [](int) { return 1.3e9; }, 0.01, day_to_day, rng);
    alarms += detectParameterChange(series, options).has_value();
  }
  const double rate = static_cast<double>(alarms) / series_count;
  std::printf("false alarms on %d stable series of 60 recordings: %d (%.1f %%) at a configured 5 %%\n",
              series_count, alarms, 100 * rate);
  EXPECT_LE(rate, 0.05 + 2 * std::sqrt(0.05 * 0.95 / series_count));
}

TEST(ParameterTrend, RefusesBadOrShortSeries) {
  std::mt19937 rng(4);
  auto series = dailySeries(20, [](int) { return 1.0; }, 0.01, 0.0, rng);
  EXPECT_FALSE(detectParameterChange({series.begin(), series.begin() + 5}).has_value());
  series[7].value = std::nan("");
  EXPECT_FALSE(detectParameterChange(series).has_value());
  series[7].value = 1.0;
  series[8].std = -1.0;
  EXPECT_FALSE(detectParameterChange(series).has_value());
  std::vector<TrendPoint> constant(10, TrendPoint{0.0, 1.0, 0.0});
  EXPECT_FALSE(detectParameterChange(constant).has_value());
  EXPECT_EQ(isoTime(1772604000.0), "2026-03-04T06:00:00Z");
}

}  // namespace
}  // namespace die_cushion_ident
