// The settings chosen from the recording (SettingsFromRecording): the paper's 2 ms where it resolves the
// press, finer where the press is faster, never finer than the recording, and the recording's own limit told
// as what to record instead; a configured value kept and judged; the valve and the clock offsets taken from
// the survey.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "die_cushion_ident/core/settings/settings_from_recording.h"
#include "die_cushion_ident/core/simulation/press_class.h"

using namespace die_cushion_ident;

namespace {

// The first `seconds` of a class's press, surveyed.
SettingsChoice surveyed(SimulatorConfig plant, const std::set<std::string>& configured = {},
                        IdentificationConfig config = IdentificationConfig(), double position_late = 0.0) {
  DieCushionSimulator simulator(plant);
  std::vector<SimulatedMeasurement> messages;
  simulator.run(8 * simulator.program().cycleDuration(), &messages);
  config.geometry = plant.geometry;
  SettingsFromRecording survey(config, configured);
  for (auto m : messages) {
    if (m.stream == InputStream::kPosition) m.sample.stamp += position_late;
    if (!survey.push(m.stream, m.sample)) break;
  }
  return survey.choose();
}

const ChosenSetting& setting(const SettingsChoice& c, const std::string& key) {
  for (const auto& s : c.settings) {
    if (s.key == key) return s;
  }
  throw std::runtime_error("no setting " + key);
}

}  // namespace

// The paper's press keeps the paper's settings; the fast press gets the finest grid its 1 kHz topics allow.
TEST(SettingsFromRecording, ThePapersPressKeepsThePapersSettingsAndAFastOneGetsAFinerGrid) {
  const SettingsChoice slow = surveyed(pressClassPlant(PressClass::kSlowHydraulic));
  EXPECT_DOUBLE_EQ(setting(slow, "sample_period").value, 0.002) << setting(slow, "sample_period").reason;
  EXPECT_DOUBLE_EQ(setting(slow, "moving_average_width").value, 31);
  EXPECT_DOUBLE_EQ(setting(slow, "derivative_width").value, 25);
  EXPECT_DOUBLE_EQ(setting(slow, "identification_period").value, 0.010);
  EXPECT_LT(slow.resolution_error, SettingsFromRecording::kResolutionShare * slow.survey.pressure_noise);
  EXPECT_TRUE(slow.resolution_limit.empty()) << slow.resolution_limit;
  EXPECT_NEAR(slow.survey.message_interval[0], 0.001, 1e-5);
  EXPECT_GE(slow.survey.cycles, 6);

  const SettingsChoice fast = surveyed(pressClassPlant(PressClass::kFastMechanical));
  EXPECT_DOUBLE_EQ(setting(fast, "sample_period").value, 0.001) << setting(fast, "sample_period").reason;
  EXPECT_EQ(setting(fast, "moving_average_width").value, 63) << "the paper's 62 ms window in 1 ms samples";
  EXPECT_EQ(setting(fast, "derivative_width").value, 51);
  ASSERT_GE(fast.study.size(), 2u);
  EXPECT_GT(fast.study[0].change_to_finer, SettingsFromRecording::kResolutionShare * fast.survey.pressure_noise)
      << "2 ms does not resolve a 4 ms impact";
  EXPECT_LT(fast.numerical_error, 0.02 * fast.survey.pressure_noise) << "the free run's own numerical error";
}

// A fast press recorded at 250 Hz: the recording, not the analysis, limits the resolution, and the report
// says what rate to record at instead.
TEST(SettingsFromRecording, ARecordingTooSlowForThePressSaysWhatToRecordInstead) {
  SimulatorConfig plant = pressClassPlant(PressClass::kFastMechanical);
  plant.sensors.pressure_rate = plant.sensors.position_rate = plant.sensors.valve_rate = 250.0;
  const SettingsChoice c = surveyed(plant);
  EXPECT_DOUBLE_EQ(setting(c, "sample_period").value, 0.002);
  EXPECT_GT(c.resolution_error, SettingsFromRecording::kResolutionShare * c.survey.pressure_noise);
  EXPECT_NE(c.resolution_limit.find("resolution-limited"), std::string::npos) << c.resolution_limit;
  EXPECT_NE(c.resolution_remedy.find("Hz or more"), std::string::npos) << c.resolution_remedy;
}

// A valve reported at 250 Hz by a 1 kHz controller: the commands between its messages are not in the
// recording, and on a fast and on a small stiff press they decide the free run by more than the resolution's
// share of the noise: the survey measures it (valve_rate_error), says so and what to record. Not where the
// valve topic comes 4 times per period of the valve (1 kHz), nor where valve_command_hold says the amplifier
// holds each command a whole message interval.
TEST(SettingsFromRecording, AValveReportedSlowerThanItsAmplifierSaysWhatToRecord) {
  for (PressClass press : {PressClass::kFastMechanical, PressClass::kSmallStiff}) {
    SCOPED_TRACE(pressClassName(press));
    SimulatorConfig plant = pressClassPlant(press, 1);
    const SettingsChoice every = surveyed(plant);
    EXPECT_TRUE(std::isnan(every.valve_rate_error)) << "1 kHz: " << every.valve_rate_error;
    plant.sensors.valve_rate = 250.0;
    const SettingsChoice c = surveyed(plant);
    const double allowed = SettingsFromRecording::kResolutionShare * c.survey.pressure_noise;
    std::printf("%s, valve at 250 Hz: valve-rate error %.3f bar (allowed %.3f)\n", pressClassName(press),
                1e-5 * c.valve_rate_error, 1e-5 * allowed);
    EXPECT_GT(c.valve_rate_error, allowed);
    EXPECT_GE(c.resolution_error, c.valve_rate_error);
    EXPECT_NE(c.resolution_limit.find("the valve topic comes every 4 ms"), std::string::npos)
        << c.resolution_limit;
    EXPECT_NE(c.resolution_remedy.find("record the valve topic at"), std::string::npos)
        << c.resolution_remedy;
    EXPECT_NE(c.resolution_remedy.find("valve_command_hold: 0.004"), std::string::npos)
        << c.resolution_remedy;
    IdentificationConfig config;
    config.valve_command_hold = 0.004;
    const SettingsChoice held = surveyed(plant, {"valve_command_hold"}, config);
    EXPECT_TRUE(std::isnan(held.valve_rate_error))
        << "an amplifier that holds each command to the next message";
  }
}

// A configured sample period is kept, and judged: on the fast press 2 ms leaves a resolution error, named.
TEST(SettingsFromRecording, AConfiguredPeriodIsKeptAndJudged) {
  IdentificationConfig config;
  config.resampler.sample_period = 0.002;
  const SettingsChoice c = surveyed(pressClassPlant(PressClass::kFastMechanical), {"sample_period"}, config);
  EXPECT_DOUBLE_EQ(setting(c, "sample_period").value, 0.002);
  EXPECT_TRUE(setting(c, "sample_period").configured);
  EXPECT_DOUBLE_EQ(c.config.resampler.sample_period, 0.002);
  ASSERT_TRUE(hasWarning(c.warnings, WarningCode::kSettingBiased))
      << (c.warnings.empty() ? "" : c.warnings.front().text);
  EXPECT_NE(c.warnings.front().text.find("sample_period 2 ms (configured)"), std::string::npos)
      << "names the key";
}

// The valve model is fitted to the survey's operation (the free run then takes its spool), and the clock
// offsets are estimated at the finest period and applied.
TEST(SettingsFromRecording, TheValveAndTheClockOffsetsComeFromTheSurvey) {
  const SimulatorConfig plant = pressClassPlant(PressClass::kSmallStiff);
  const SettingsChoice c = surveyed(plant, {}, IdentificationConfig(), 0.010);
  ASSERT_TRUE(c.valve.has_value());
  EXPECT_TRUE(c.valve_from_operation) << c.valve->message;
  EXPECT_TRUE(c.config.valve_model_drives_free_run);
  EXPECT_NEAR(c.config.valve.natural_frequency / plant.valve.natural_frequency, 1.0, 0.05);
  ASSERT_TRUE(c.delays.has_value());
  EXPECT_TRUE(c.delays_applied);
  EXPECT_NEAR(c.config.topic_delays[1], 0.010, 0.3e-3);
  EXPECT_NEAR(c.config.topic_delays[2], 0.0, 0.3e-3);
}

// Without a measured spool there is nothing to fit the valve to: the configured model stays, and the free
// run takes the spool it predicts (as the identification does).
TEST(SettingsFromRecording, WithoutAMeasuredSpoolTheConfiguredValveStays) {
  SimulatorConfig plant = pressClassPlant(PressClass::kSlowHydraulic);
  plant.sensors.measure_spool = false;
  const SettingsChoice c = surveyed(plant);
  EXPECT_FALSE(c.survey.spool_measured);
  EXPECT_FALSE(c.valve.has_value());
  EXPECT_FALSE(c.valve_from_operation);
  EXPECT_DOUBLE_EQ(c.config.valve.natural_frequency, IdentificationConfig().valve.natural_frequency);
}

// Without a measured spool the valve topic's offset also holds what the default valve model's timing lacks
// (a slow valve reads as early stamps, a fast one as late): its stated std includes that timing, so it covers
// the truth (the clocks agree here); with the valve configured, the model is the user's and nothing is added.
TEST(SettingsFromRecording, WithoutAMeasuredSpoolTheValveOffsetStatesTheValveModelsTiming) {
  for (const auto& [press, variation] : {std::pair<PressClass, int>{PressClass::kLargeSoft, 7},
                                         {PressClass::kFastMechanical, 2},
                                         {PressClass::kSmallStiff, 4}}) {
    SimulatorConfig plant = pressClassPlant(press, variation);
    plant.sensors.measure_spool = false;
    const SettingsChoice c = surveyed(plant);
    ASSERT_TRUE(c.delays && c.delays->valid) << pressClassName(press);
    const double offset = c.delays->delays[2], stated = c.delays->resolution[2];
    std::printf("%s v%d: valve offset %+.2f ms +- %.2f ms (of it the default model's timing %.2f ms)\n",
                pressClassName(press), variation, 1e3 * offset, 1e3 * stated,
                1e3 * c.delays->valve_model_timing);
    EXPECT_GT(c.delays->valve_model_timing, 1e-3) << pressClassName(press);
    EXPECT_LE(std::abs(offset), 2.0 * stated)
        << pressClassName(press) << ": the stated std covers the truth (0)";

    IdentificationConfig configured;
    configured.valve = plant.valve;
    const SettingsChoice right =
        surveyed(plant, {"valve_natural_frequency", "valve_damping", "valve_dead_time"}, configured);
    ASSERT_TRUE(right.delays && right.delays->valid);
    EXPECT_EQ(right.delays->valve_model_timing, 0.0);
    EXPECT_NEAR(right.delays->delays[2], 0.0, 0.3e-3)
        << pressClassName(press) << ": with its own valve model";
  }
}

// A recording with nothing to identify (the cushion at rest) keeps the paper's settings and says so.
TEST(SettingsFromRecording, NothingToStudyKeepsThePapersSettings) {
  SimulatorConfig plant;
  plant.cycle.rest_time = 100.0;
  DieCushionSimulator simulator(plant);
  std::vector<SimulatedMeasurement> messages;
  simulator.run(5.0, &messages);
  SettingsFromRecording survey(IdentificationConfig(), {});
  for (const auto& m : messages) survey.push(m.stream, m.sample);
  const SettingsChoice c = survey.choose();
  EXPECT_DOUBLE_EQ(setting(c, "sample_period").value, 0.002);
  EXPECT_NE(setting(c, "sample_period").reason.find("nothing to identify"), std::string::npos);
  EXPECT_TRUE(c.study.empty());
}

// The grid's points on the position's messages where they carry the velocity and the impact is short
// against them (a fast press): the simulator stamps the position 0.3 of a period after the pressure (plus its
// quantised jitter), with the clocks agreeing or the position 10 ms late (then corrected by the clock offset
// first). A small stiff press's 15 ms impact keeps the grid at k T (and its 2 ms); so does a derived
// velocity, and a rate off the study's periods has no phase to keep.
TEST(SettingsFromRecording, TheGridsPointsFallOnThePositionsMessagesWhereTheImpactIsShort) {
  for (const double late : {0.0, 0.010}) {
    const SimulatorConfig plant = pressClassPlant(PressClass::kFastMechanical);
    const SettingsChoice c = surveyed(plant, {}, IdentificationConfig(), late);
    const double period = 1.0 / plant.sensors.position_rate;
    // The stamps as the pipeline corrects them (less the estimated offset), modulo the position's period.
    const double phase = c.config.resampler.grid_phase;
    const double corrected = 0.3 * period + late - c.config.appliedTopicDelays()[1];
    EXPECT_NEAR(setting(c, "grid_phase").value, phase, 1e-12);
    EXPECT_NEAR(std::remainder(phase - corrected, period), 0.0, 0.1 * period)
        << "late " << late << ": " << setting(c, "grid_phase").reason;
    EXPECT_DOUBLE_EQ(c.config.resampler.sample_period, 0.001);
  }
  const SettingsChoice stiff = surveyed(pressClassPlant(PressClass::kSmallStiff));
  EXPECT_EQ(stiff.config.resampler.grid_phase, 0.0);
  EXPECT_THROW(setting(stiff, "grid_phase"), std::runtime_error);
  SimulatorConfig derived = pressClassPlant(PressClass::kFastMechanical);
  derived.sensors.publish_velocity = false;
  EXPECT_EQ(surveyed(derived).config.resampler.grid_phase, 0.0);
  SimulatorConfig off_rate = pressClassPlant(PressClass::kFastMechanical);
  off_rate.sensors.position_rate = 800.0;  // 1.25 ms: no study period is its interval
  EXPECT_EQ(surveyed(off_rate).config.resampler.grid_phase, 0.0);
}
