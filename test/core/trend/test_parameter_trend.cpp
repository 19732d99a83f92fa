// Change detection over many recordings (core; issues 14 and 27). Synthetic series with the stds the
// analysis reports and a day-to-day variation they miss: the sequential test (a self-starting CUSUM) finds a
// step and a starting drift within a few recordings, dated to their onset; on steady series its false
// alarms per recording meet the designed average run length (measured by simulation, not assumed), and
// adding a recording never changes an earlier alarm.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "die_cushion_ident/core/trend/parameter_trend.h"

namespace die_cushion_ident {
namespace {

constexpr double kDay = 86400.0;

// analyze_trend's default: 0.1 false alarms per press-year over 3 parameters, 750 recordings a year.
const SequentialDetectionOptions kDefault{750.0 * 3 / 0.1, 2.0, 4};

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

// analyze_trend's design where it compares the recordings at the reference temperature: their logarithms.
const SequentialDetectionOptions kRelative = [] {
  SequentialDetectionOptions o = kDefault;
  o.relative = true;
  return o;
}();

// The first alarm in a series, or -1.
std::pair<int, ParameterChange> firstDetection(const std::vector<TrendPoint>& series,
                                               const SequentialDetectionOptions& options = kDefault) {
  const auto changes = detectChangesSequentially(series, options);
  if (changes.empty()) return {-1, {}};
  return {static_cast<int>(changes.front().alarm_index), changes.front()};
}

TEST(ParameterTrend, ALeakageStepIsFoundWithinThreeRecordingsAtItsOnset) {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 20; ++trial) {
    const auto series = dailySeries(
        25, [](int i) { return i < 12 ? 1.1e-12 : 3.1e-12; }, 0.03, 0.02, rng);
    const auto [at, change] = firstDetection(series);
    ASSERT_GE(at, 12) << "trial " << trial << ": a change before the onset";
    EXPECT_LE(at, 14) << "trial " << trial;
    EXPECT_EQ(change.start_index, 12u);
    EXPECT_EQ(change.shape, "step");
    EXPECT_NEAR(change.before, 1.1e-12, 0.1e-12);
    const std::string words =
        explainChange("leakage_conductance", "m^3/(s*Pa)", change, isoTime(change.start_stamp));
    EXPECT_NE(words.find("-fold ("), std::string::npos) << words;
    EXPECT_NE(words.find("has risen"), std::string::npos) << words;
    EXPECT_NE(words.find("seal"), std::string::npos) << words;
  }
}

TEST(ParameterTrend, AStartingDriftIsFoundWithinFourRecordings) {
  std::mt19937 rng(2);
  for (int trial = 0; trial < 20; ++trial) {
    // Air drawn in from day 15: the air volume grows by a quarter of its level each day.
    const auto series = dailySeries(
        30, [](int i) { return 2e-4 * (1.0 + (i < 15 ? 0.0 : 0.25 * (i - 14))); }, 0.03, 0.02, rng);
    const auto [at, change] = firstDetection(series);
    ASSERT_GE(at, 15) << "trial " << trial;
    EXPECT_LE(at, 18) << "trial " << trial;
    EXPECT_NEAR(static_cast<double>(change.start_index), 15.0, 1.0) << "trial " << trial;
    EXPECT_GT(change.after, change.before);
  }
}

// The design: on steady series the alarms per recording are 1 / ARL. Measured on a design of 500
// recordings between false alarms (so that 400 000 recordings hold enough of them), with the stds varying
// from recording to recording and a day-to-day variation of none, as much as the stds, twice.
TEST(ParameterTrend, FalseAlarmsPerRecordingMeetTheDesignedRunLength) {
  std::mt19937 rng(3);
  SequentialDetectionOptions options;
  options.recordings_between_false_alarms = 500.0;
  int alarms = 0;
  long recordings = 0;
  for (int s = 0; s < 200; ++s) {
    const double day_to_day = (s % 3) * 0.02;
    const auto series = dailySeries(
        2000, [](int) { return 1.3e9; }, 0.01, day_to_day, rng);
    alarms += static_cast<int>(detectChangesSequentially(series, options).size());
    recordings += 2000;
  }
  const double per_recording = static_cast<double>(alarms) / recordings;
  std::printf(
      "false alarms: %d in %ld steady recordings, one per %.0f (designed: one per %.0f; threshold %.3f)\n",
      alarms, recordings, 1.0 / per_recording, options.recordings_between_false_alarms,
      cusumThreshold(options));
  // Measured one per 568 (the standardisation counts the baseline mean's own variance: a little
  // conservative); ~700 alarms give the rate within +-8 % (2 sigma).
  EXPECT_LE(per_recording, 1.1 / options.recordings_between_false_alarms);
  EXPECT_GE(per_recording, 0.6 / options.recordings_between_false_alarms);
}

// Adding a recording tests only it: every alarm on a prefix is an alarm, unchanged, on every longer series,
// and a lone outlier as the newest recording is no step.
TEST(ParameterTrend, AddingARecordingNeverReTestsThePast) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 10; ++trial) {
    const auto series = dailySeries(
        60, [](int i) { return i < 30 ? 1.0 : 1.4; }, 0.02, 0.01, rng);
    const auto all = detectChangesSequentially(series, kDefault);
    for (std::size_t m = 1; m <= series.size(); ++m) {
      const auto prefix = detectChangesSequentially({series.begin(), series.begin() + m}, kDefault);
      ASSERT_LE(prefix.size(), all.size());
      for (std::size_t c = 0; c < prefix.size(); ++c) {
        EXPECT_EQ(prefix[c].alarm_index, all[c].alarm_index);
        EXPECT_EQ(prefix[c].start_index, all[c].start_index);
      }
    }
    auto outlier = std::vector<TrendPoint>(series.begin(), series.begin() + 25);
    outlier.back().value *= 1.0 + 4.0 * 0.02;  // 4 of its stds, once
    EXPECT_TRUE(detectChangesSequentially(outlier, kDefault).empty());
  }
}

TEST(ParameterTrend, RefusesBadOrShortSeries) {
  std::mt19937 rng(4);
  auto series = dailySeries(
      20, [](int) { return 1.0; }, 0.01, 0.0, rng);
  EXPECT_TRUE(detectChangesSequentially({series.begin(), series.begin() + 4}).empty());
  series[7].value = std::nan("");
  EXPECT_TRUE(detectChangesSequentially(series).empty()) << "a non-finite recording is skipped";
  std::vector<TrendPoint> constant(10, TrendPoint{0.0, 1.0, 0.0});
  EXPECT_TRUE(detectChangesSequentially(constant).empty());
  EXPECT_EQ(isoTime(1772604000.0), "2026-03-04T06:00:00Z");
  // The threshold grows with the run length asked for.
  SequentialDetectionOptions rare, often;
  rare.recordings_between_false_alarms = 1e5;
  often.recordings_between_false_alarms = 100;
  EXPECT_GT(cusumThreshold(rare), cusumThreshold(often));
}

// ---- The oil's temperature as a covariate (issue 46) ----

// A daily series as analyze_trend tracks it with an oil temperature: each recording's value at the reference
// temperature (40 degC), left with what the oil's law missed, a relative `law_error` per kelvin (a configured
// coefficient off by that much), and its own relative noise `noise` (reported as its std); the oil random in
// 25-50 degC plus a seasonal 10 K over the series. `rise` from `onset` on (relative).
std::vector<TrendPoint> oilSeries(int count, double law_error, double noise, double rise, int onset,
                                  std::mt19937& rng, double season = 10.0) {
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> oil(25.0, 50.0);
  std::vector<TrendPoint> series;
  for (int i = 0; i < count; ++i) {
    const double T = oil(rng) + season * i / std::max(count - 1, 1);
    const double truth = 1.5e-12 * (i >= onset ? 1.0 + rise : 1.0) * std::exp(law_error * (T - 40.0));
    series.push_back({1.77e9 + i * kDay, truth * (1.0 + noise * normal(rng)), noise * truth, T});
  }
  return series;
}

// The same leakage as recorded, without an oil temperature: the viscosity's +4.5 %/K swing is in the values.
std::vector<TrendPoint> asRecorded(std::vector<TrendPoint> series) {
  for (TrendPoint& p : series) {
    p.value *= std::exp(0.045 * (p.covariate - 40.0));
    p.std *= std::exp(0.045 * (p.covariate - 40.0));
    p.covariate = std::nan("");
  }
  return series;
}

// The Done-when of issue 46 on the core: a 10 % rise at the reference temperature is reported within 3
// recordings of its onset, dated +-1, in at least 90 % of 20 series whose oil swings over 25-60 degC and
// whose configured law is off by up to 1 %/K (regressed out over the baseline); as recorded, without the
// temperature, the same rise mostly goes unseen.
TEST(ParameterTrend, ATenPercentRiseAtTheReferenceTemperatureIsFoundAcrossTheOilsSwing) {
  std::mt19937 rng(46);
  std::uniform_real_distribution<double> law_error(-0.01, 0.01), onset(12, 25);
  int found = 0, found_as_recorded = 0, before = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const int start = static_cast<int>(onset(rng));
    const auto series = oilSeries(30, law_error(rng), 0.005, 0.10, start, rng);
    const auto [at, change] = firstDetection(series, kRelative);
    before += at >= 0 && at < start;
    const bool in_time =
        at >= start && at <= start + 2 && std::abs(static_cast<int>(change.start_index) - start) <= 1;
    found += in_time;
    if (in_time) {
      EXPECT_NEAR(change.after / change.before, 1.10, 0.03) << "trial " << trial << ": the rise's size";
      EXPECT_TRUE(std::isfinite(change.slope)) << "the baseline regressed on the oil temperature";
    }
    const auto [at_recorded, unused] = firstDetection(asRecorded(series));
    found_as_recorded += at_recorded >= start && at_recorded <= start + 2;
  }
  std::printf("10 %% rise: found in time in %d of 20 at 40 degC, %d of 20 as recorded; %d alarms before it\n",
              found, found_as_recorded, before);
  EXPECT_GE(found, 18) << "at least 90 % of the series";
  EXPECT_EQ(before, 0);
  EXPECT_LE(found_as_recorded, 10) << "as recorded, the oil's swing hides a 10 % rise";
}

// The regressed baseline keeps the design: on steady series whose values follow the oil temperature (a law
// 1 %/K or -0.6 %/K off, the oil random over the day and with the seasons), the false alarms per recording
// meet 1 / ARL (the baseline without the covariate is printed for comparison).
TEST(ParameterTrend, WithTheOilTemperatureRegressedOutFalseAlarmsMeetTheDesign) {
  std::mt19937 rng(47);
  SequentialDetectionOptions options;
  options.recordings_between_false_alarms = 500.0;
  options.relative = true;
  int alarms = 0, alarms_without = 0;
  long recordings = 0;
  for (int s = 0; s < 80; ++s) {
    auto series = oilSeries(2000, s % 2 ? 0.01 : -0.006, 0.005, 0.0, 1 << 30, rng);
    // The season's drift over the whole series would be 10 K: over 2000 recordings it repeats yearly.
    for (std::size_t i = 0; i < series.size(); ++i) {
      const double season = 5.0 * std::sin(2.0 * M_PI * static_cast<double>(i) / 750.0);
      const double T = series[i].covariate - 10.0 * i / 1999.0 + season;
      series[i].value *= std::exp((s % 2 ? 0.01 : -0.006) * (T - series[i].covariate));
      series[i].covariate = T;
    }
    alarms += static_cast<int>(detectChangesSequentially(series, options).size());
    auto without = series;
    for (TrendPoint& p : without) p.covariate = std::nan("");
    if (s < 10) alarms_without += static_cast<int>(detectChangesSequentially(without, options).size());
    recordings += 2000;
  }
  const double per_recording = static_cast<double>(alarms) / recordings;
  std::printf(
      "with the oil temperature regressed out: %d false alarms in %ld recordings, one per %.0f "
      "(designed %.0f); without it, %d in 20000\n",
      alarms, recordings, 1.0 / per_recording, options.recordings_between_false_alarms, alarms_without);
  EXPECT_LE(per_recording, 1.2 / options.recordings_between_false_alarms);
  EXPECT_GE(per_recording, 0.5 / options.recordings_between_false_alarms);
}

// The smallest detectable change the trend states is what its test achieves: a step of that size, injected
// into the series' next three recordings, is reported within them about as often as stated (90 %); with the
// oil temperature regressed out (the season warming the oil), and as recorded (its swing in the scatter).
TEST(ParameterTrend, TheStatedSmallestChangeIsFoundAsOftenAsStated) {
  std::mt19937 rng(48);
  for (bool with_temperature : {true, false}) {
    int trials = 0, found = 0;
    double relative = 0.0;
    for (int trial = 0; trial < 60; ++trial) {
      // As recorded, the season's warming (+4.5 %/K in the values) would add to any rise: a steady oil there.
      const auto full = oilSeries(23, 0.004, 0.005, 0.0, 1 << 30, rng, with_temperature ? 10.0 : 0.0);
      const auto series = with_temperature ? full : asRecorded(full);
      // As analyze_trend states it: the history's smallest detectable change, then the next three recordings
      // with a step of that size, through the same test.
      const SequentialDetectionOptions& options = with_temperature ? kRelative : kDefault;
      DetectableChange d;
      const std::vector<TrendPoint> history(series.begin(), series.begin() + 20);
      if (!detectChangesSequentially(history, options, &d).empty())
        continue;  // a false alarm: not the question
      ASSERT_TRUE(std::isfinite(d.step)) << "trial " << trial;
      relative += d.step / d.level;
      ++trials;
      std::vector<TrendPoint> shifted = series;
      for (int i = 20; i < 23; ++i) shifted[i].value += d.step;
      const auto changes = detectChangesSequentially(shifted, options);
      found += !changes.empty() && changes.front().alarm_index >= 20;
    }
    const double rate = static_cast<double>(found) / trials;
    std::printf(
        "%s: smallest detectable change %.1f %% of the level on average; found %d of %d (%.0f %%)\n",
        with_temperature ? "at 40 degC, regressed on the oil temperature" : "as recorded, no temperature",
        100.0 * relative / trials, found, trials, 100.0 * rate);
    // Measured: 82 % of 60 (85 % of 100) at 40 degC with the season warming the oil, 90 % as recorded.
    EXPECT_GE(rate, 0.75) << "stated 90 %: not much less";
    EXPECT_LE(rate, 0.98) << "stated 90 %: not much more (the statement would be loose)";
  }
}

}  // namespace
}  // namespace die_cushion_ident
