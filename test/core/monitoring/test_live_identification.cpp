// The live identification without a roscore: LiveIdentification chooses its settings from the first seconds
// of messages, as analyze_bag does, on more than one press class, and takes one estimate of the clock
// offsets.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "die_cushion_ident/core/monitoring/live_identification.h"
#include "die_cushion_ident/core/simulation/press_class.h"
#include "simulation_fixtures.h"

namespace die_cushion_ident {
namespace {

using testing::configFor;

/// A press fed message by message into a LiveIdentification, as the node does (each topic's stamps shifted
/// by its offset: a topic stamped by another clock).
struct LivePress {
  LivePress(const SimulatorConfig& plant, LiveIdentificationSettings settings,
            const std::vector<std::string>& configured = {})
      : simulator(plant) {
    IdentificationConfig config = configFor(plant);
    for (const auto& key : configured) settings.configured.insert(key);
    live = std::make_unique<LiveIdentification>(config, settings);
  }
  void run(double seconds, bool wait_for_the_study = true) {
    testing::feed(simulator, seconds, stamp_offsets, [&](InputStream stream, const StreamSample& sample) {
      live->push(stream, sample);
      for (auto& e : live->takeEvents()) events.push_back(e);
      // The study runs on its own thread: a test waits for it where the node would go on (deterministic).
      while (wait_for_the_study && live->surveying() && !surveyKeepsMessages()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        live->poll();
        for (auto& e : live->takeEvents()) events.push_back(e);
      }
    });
  }
  bool surveyKeepsMessages() const {
    return live->settingsHealth().message.find("surveying") != std::string::npos;
  }
  bool said(LiveEventCode code) const {
    for (const auto& e : events) {
      if (e.code == code) return true;
    }
    return false;
  }
  bool said(const std::string& words) const {
    for (const auto& e : events) {
      if (e.text.find(words) != std::string::npos) return true;
    }
    return false;
  }
  std::array<double, kInputStreamCount> stamp_offsets{};
  DieCushionSimulator simulator;
  std::unique_ptr<LiveIdentification> live;
  std::vector<LiveEvent> events;
};

LiveIdentificationSettings surveyed() {
  LiveIdentificationSettings s;
  s.monitor.ranking_window = 20.0;
  s.monitor.ranking_period = 1e9;  // no ranking: the comparison alone is under test
  s.choose_settings = true;
  s.survey_seconds = 24.0;
  return s;
}

LiveIdentificationSettings fixedSettings() {
  LiveIdentificationSettings s = surveyed();
  s.choose_settings = false;
  return s;
}

TEST(LiveIdentification, AFastPressChoosesAFinerGridLiveAndItsFreeRunComesNearTheNoise) {
  const SimulatorConfig plant = pressClassPlant(PressClass::kFastMechanical, 1);
  LivePress chosen(plant, surveyed());
  LivePress paper(plant, fixedSettings());
  chosen.run(60.0);
  paper.run(60.0);
  ASSERT_TRUE(chosen.live->settingsChoice()) << chosen.live->settingsHealth().message;
  EXPECT_TRUE(chosen.said(LiveEventCode::kSettingsChosen)) << chosen.live->settingsHealth().message;
  const double period = chosen.live->config().resampler.sample_period;
  EXPECT_LT(period, 0.002) << chosen.live->settingsHealth().message;
  EXPECT_EQ(paper.live->config().resampler.sample_period, 0.002);
  const double noise = plant.sensors.pressure_noise;
  const double chosen_error = chosen.live->monitor().simulationErrorRms();
  const double paper_error = paper.live->monitor().simulationErrorRms();
  std::printf("fast press live: chosen %.3g ms -> %.3f bar, paper 2 ms -> %.3f bar (noise %.3f bar)\n",
              1e3 * period, 1e-5 * chosen_error, 1e-5 * paper_error, 1e-5 * noise);
  // 0.39 bar against 4.8 bar on the paper's grid (0.2 bar noise).
  EXPECT_LT(chosen_error, 3.0 * noise);
  EXPECT_LT(chosen_error, 0.3 * paper_error);
  const HealthReport health = chosen.live->settingsHealth();
  EXPECT_FALSE(health.value("why sample_period").empty());
}

TEST(LiveIdentification, ASlowPressKeepsThePapersGridWhereItResolvesIt) {
  const SimulatorConfig plant = pressClassPlant(PressClass::kSlowHydraulic, 2);
  LivePress chosen(plant, surveyed());
  chosen.run(40.0);
  ASSERT_TRUE(chosen.live->settingsChoice());
  const HealthReport health = chosen.live->settingsHealth();
  std::printf("slow press live: %s\n", health.message.c_str());
  EXPECT_GE(chosen.live->config().resampler.sample_period, 0.001) << health.message;
  EXPECT_EQ(health.level, HealthLevel::kOk) << health.message;
  // Nothing changed: the identification was not restarted.
  EXPECT_TRUE(chosen.said("as running, nothing restarted"));
  for (const auto& e : chosen.events) std::printf("  event: %s\n", e.text.c_str());
  EXPECT_LT(chosen.live->monitor().simulationErrorRms(), 2.0 * plant.sensors.pressure_noise);
}

TEST(LiveIdentification, AStiffChambersLatePositionIsCorrectedEarlyByTheMonitorThenByTheSurvey) {
  const SimulatorConfig plant = pressClassPlant(PressClass::kSmallStiff, 1);
  LiveIdentificationSettings settings = surveyed();
  settings.monitor.ranking_period = 5.0;  // the monitor's first windows estimate the offsets early
  LivePress late(plant, settings);
  late.stamp_offsets = {0.0, 0.010, 0.0};
  late.run(45.0);
  ASSERT_TRUE(late.live->settingsChoice());
  const TimingState timing = late.live->timing();
  ASSERT_TRUE(timing.estimate);
  EXPECT_NEAR(timing.applied_delays[1], 0.010, 3e-4);
  EXPECT_NEAR(timing.applied_delays[2], 0.0, 3e-4);
  // Corrected early (a session shorter than the survey is corrected too), then by the survey's estimate.
  EXPECT_TRUE(late.said(LiveEventCode::kClockOffsetCorrected));
  EXPECT_TRUE(late.said("clock offsets position"));
  EXPECT_TRUE(late.live->monitor().topicDelayEstimate());
}

TEST(LiveIdentification, AConfiguredPeriodIsKeptAndJudged) {
  const SimulatorConfig plant = pressClassPlant(PressClass::kFastMechanical, 1);
  LivePress configured(plant, surveyed(), {"sample_period"});
  configured.run(30.0);
  ASSERT_TRUE(configured.live->settingsChoice());
  EXPECT_EQ(configured.live->config().resampler.sample_period, 0.002);
  EXPECT_TRUE(configured.said(LiveEventCode::kSettingBiased));
  EXPECT_TRUE(configured.said("sample_period 2 ms (configured) leaves a resolution error"))
      << "naming the key";
  EXPECT_EQ(configured.live->settingsHealth().level, HealthLevel::kWarn);
}

TEST(LiveIdentification, WithoutTheSurveyTheConfiguredSettingsRunAndTheMonitorEstimatesTheOffsets) {
  const SimulatorConfig plant = pressClassPlant(PressClass::kSlowHydraulic, 0);
  LiveIdentificationSettings settings = fixedSettings();
  settings.monitor.ranking_period = 10.0;  // the monitor estimates the offsets as its first ranking starts
  LivePress fixed(plant, settings);
  fixed.stamp_offsets = {0.0, 0.010, 0.0};
  fixed.run(35.0);
  EXPECT_FALSE(fixed.live->settingsChoice());
  EXPECT_FALSE(fixed.live->surveying());
  EXPECT_NE(fixed.live->settingsHealth().message.find("as configured"), std::string::npos);
  ASSERT_TRUE(fixed.live->monitor().topicDelayEstimate());
  EXPECT_NEAR(fixed.live->timing().applied_delays[1], 0.010, 1e-3);
}

// Without the survey nothing fits the valve model to the operation: a configured one drives the free run as
// it is (takeConfiguredValveModel), as under analyze_bag --fixed-settings; the default one does not.
TEST(LiveIdentification, WithoutTheSurveyAConfiguredValveModelDrivesTheFreeRun) {
  const SimulatorConfig plant = pressClassPlant(PressClass::kFastMechanical, 0);
  const LivePress configured(plant, fixedSettings(), {"valve_natural_frequency", "valve_dead_time"});
  EXPECT_TRUE(configured.live->config().valve_model_drives_free_run);
  const LivePress assumed(plant, fixedSettings());
  EXPECT_FALSE(assumed.live->config().valve_model_drives_free_run);
  const LivePress surveying(plant, surveyed(), {"valve_natural_frequency"});
  EXPECT_FALSE(surveying.live->config().valve_model_drives_free_run) << "the survey decides from the spool";
}

TEST(LiveIdentification, StampsJumpingBackDuringTheSurveyStartItOver) {
  const SimulatorConfig plant = pressClassPlant(PressClass::kSlowHydraulic, 0);
  LivePress looped(plant, surveyed());
  looped.run(15.0, false);
  // The bag starts again: 15 s back.
  looped.stamp_offsets = {-15.0, -15.0, -15.0};
  looped.run(15.0, false);
  EXPECT_EQ(looped.live->timing().time_base_restarts, 1u);
  // 30 s of messages, but only 15 s since the restart: still surveying.
  EXPECT_TRUE(looped.surveyKeepsMessages()) << looped.live->settingsHealth().message;
  looped.run(12.0);
  EXPECT_TRUE(looped.live->settingsChoice());
}

}  // namespace
}  // namespace die_cushion_ident
