#include "die_cushion_ident/core/settings/settings_from_recording.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <functional>
#include <future>
#include <random>
#include <unordered_map>

#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/adequacy/implausible_parameters.h"
#include "die_cushion_ident/core/adequacy/model_assessment.h"
#include "die_cushion_ident/core/estimation/identification_pipeline.h"
#include "die_cushion_ident/core/fits/free_run_pressure.h"
#include "die_cushion_ident/core/fits/output_error_refinement.h"
#include "die_cushion_ident/core/model/effect_library.h"
#include "die_cushion_ident/core/signal/message_noise.h"
#include "die_cushion_ident/core/signal/message_phase.h"
#include "die_cushion_ident/core/signal/white_noise_estimator.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "die_cushion_ident/core/util/parallel_for.h"
#include "die_cushion_ident/core/valve/step_response.h"
#include "rate_study.h"
#include "resolution_study.h"
#include "study_level.h"

namespace die_cushion_ident {

using namespace settings_detail;

bool valveModelConfigured(const std::set<std::string>& keys) {
  return keys.count("valve_natural_frequency") || keys.count("valve_damping") || keys.count("valve_gain") ||
         keys.count("valve_dead_time");
}

void takeConfiguredValveModel(const std::set<std::string>& configured_keys, IdentificationConfig* config) {
  if (valveModelConfigured(configured_keys)) config->valve_model_drives_free_run = true;
}

std::string valveRateUnstudiedWarning(const IdentificationConfig& config, double valve_interval) {
  const double frequency = config.valve.natural_frequency;
  if (!config.valve_model_drives_free_run ||
      !commandsBetweenMessagesMatter(frequency, valve_interval, config.valve_command_hold))
    return "";
  return formatted(FMT_STRING(
      "the valve topic comes every {:.3g} ms, {:.1f} messages per period of the valve model's {:.0f} Hz: "
      "commands a faster amplifier applied between them are not in the recording, and the free run "
      "may be off by more than the noise for that alone; without the survey nothing measures how "
      "much. Leave out --fixed-settings (its survey does: settings.valve_rate_error), record the "
      "valve at {:.0f} Hz or more, or, where the amplifier updates only as often as the topic, set "
      "valve_command_hold: {:.3g}"),
      1e3 * valve_interval, 1.0 / (frequency * valve_interval), frequency, valveRecordingRate(frequency),
      valve_interval);
}

SettingsFromRecording::SettingsFromRecording(const IdentificationConfig& config, std::set<std::string> configured_keys,
                                             double survey_seconds, std::size_t max_messages)
    : config_(config), configured_(std::move(configured_keys)), survey_seconds_(survey_seconds),
      max_messages_(max_messages) {}

bool SettingsFromRecording::push(InputStream stream, const StreamSample& sample) {
  if (complete_) return false;
  messages_.emplace_back(stream, sample);
  if (std::isfinite(sample.stamp)) {
    if (std::isnan(first_stamp_)) first_stamp_ = sample.stamp;
    if (sample.stamp - first_stamp_ >= survey_seconds_) complete_ = true;
  }
  if (messages_.size() >= max_messages_) complete_ = true;
  return !complete_;
}

namespace {

// Message rates, pressure noise and the valve's operation (commands with a measured spool) of the survey.
std::vector<ValveSample> surveyMessages(const Messages& messages, RecordingSurvey* survey) {
  std::array<std::vector<double>, kInputStreamCount> intervals;
  std::array<double, kInputStreamCount> last = {NAN, NAN, NAN};
  WhiteNoiseEstimator pressure_noise(1);
  double recent[3] = {0.0, 0.0, 0.0};
  int recent_count = 0;
  std::vector<ValveSample> valve;
  std::size_t valve_messages = 0;
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (const auto& [stream, m] : messages) {
    const int s = static_cast<int>(stream);
    if (!std::isfinite(m.stamp) || !std::isfinite(m.first)) continue;
    low = std::min(low, m.stamp);
    high = std::max(high, m.stamp);
    if (m.stamp > last[s]) intervals[s].push_back(m.stamp - last[s]);
    if (!(m.stamp <= last[s])) last[s] = m.stamp;
    if (stream == InputStream::kPressure) {
      recent[0] = recent[1];
      recent[1] = recent[2];
      recent[2] = m.first;
      if (++recent_count >= 3) pressure_noise.add(recent[0], recent[1], recent[2]);
    } else if (stream == InputStream::kValve) {
      ++valve_messages;
      if (std::isfinite(m.second)) valve.push_back({m.stamp, m.first, m.second});
    }
  }
  survey->seconds = high > low ? high - low : 0.0;
  for (int s = 0; s < kInputStreamCount; ++s) survey->message_interval[s] = median(intervals[s]);
  survey->pressure_noise = std::isfinite(pressure_noise.sigma()) ? pressure_noise.sigma() : 0.0;
  survey->spool_measured = valve_messages > 0 && valve.size() * 2 > valve_messages;
  return valve;
}

std::string unmodelledSpoolWarning(const ServoValveParameters& valve) {
  return formatted(FMT_STRING("the spool is not measured and no valve model is configured: the spool is predicted by the "
                   "default valve ({:.0f} Hz, damping {:.2f}, dead time {:.2f} ms), and the free run is only as right "
                   "as it. Configure the valve (valve_natural_frequency, valve_damping, valve_gain, "
                   "valve_dead_time) from a sweep of this valve"),
                   valve.natural_frequency, valve.damping, 1e3 * valve.dead_time);
}

// [s] the fastest topic's message interval (infinity where none has one).
double finestInterval(const RecordingSurvey& survey) {
  double finest = std::numeric_limits<double>::infinity();
  for (double interval : survey.message_interval) {
    if (interval > 0.0) finest = std::min(finest, interval);
  }
  return finest;
}

// The study's periods: from the paper's 2 ms down, halving, never finer than the finest topic's messages
// (a grid between messages only interpolates them linearly, which undoes the free run's cubic inputs).
std::vector<double> studyPeriods(double finest_interval) {
  std::vector<double> periods;
  for (double period = kCoarsestPeriod; period >= kFinestPeriod * (1.0 - 1e-9); period *= 0.5) {
    if (std::isfinite(finest_interval) && period < 0.9 * finest_interval) break;
    periods.push_back(period);
  }
  if (periods.empty()) periods.push_back(kCoarsestPeriod);
  return periods;
}

// The valve model that drives the free run and judges the port side: the one fitted to the operation where
// the spool is measured, unless it does not follow the spool better than the configured one.
void adoptValveFit(ValveOperationFit fit, bool valve_configured, SettingsChoice& choice) {
  choice.valve = std::move(fit);
  if (!choice.valve->success || !(choice.valve->residual_rms < choice.valve->start_residual_rms)) return;
  choice.config.valve = choice.valve->parameters;
  choice.config.valve_covariance = choice.valve->covariance;
  choice.config.valve_model_drives_free_run = true;
  choice.valve_from_operation = true;
  if (valve_configured && choice.valve->start_residual_rms > 1.5 * choice.valve->noise_sigma) {
    choice.warnings.push_back(
        {WarningCode::kValveModel,
         "the configured valve model does not follow the measured spool (" +
             formatted(FMT_STRING("residual {:.2g} against a sensor noise of {:.2g}"), choice.valve->start_residual_rms,
                       choice.valve->noise_sigma) +
             "): the analysis uses the one fitted to the recording's operation instead (" +
             choice.valve->message + ")"});
  }
}

// Why the sample period is what it is, in words.
std::string periodReason(const StudyOutcome& outcome, const SettingsChoice& choice, double finest_interval,
                         double noise) {
  if (outcome.no_press_stroke) {
    const std::string period =
        outcome.step_t63 > 0.0 ? formatted(FMT_STRING("within a tenth of the step test's t63 ({:.3g} ms)"), 1e3 * outcome.step_t63)
        : outcome.implausible.empty()
            ? std::string("the paper's value")
            : formatted(FMT_STRING("the finest the recording supports (messages every {:.3g} ms)"), 1e3 * finest_interval);
    return period +
           ": the survey holds no press stroke (a step test or valve sweep with the cushion at rest), nothing to "
           "identify a model from and study the grid's error with";
  }
  if (!outcome.implausible.empty()) {
    return formatted(FMT_STRING("the finest the recording supports (messages every {:.3g} ms), unstudied: the configured "
                     "model's fit is implausible ("),
                     1e3 * finest_interval) +
           outcome.implausible + "), so its free run cannot measure the grid's error";
  }
  if (!outcome.studied) return "the paper's value: the survey holds nothing to identify";
  if (outcome.resolved) {
    return formatted(FMT_STRING(
        "the free run's own error there is {:.3g} bar, from how it changes as the period halves (the "
        "pressure noise is {:.3g} bar)"),
        1e-5 * outcome.grid_error, 1e-5 * noise);
  }
  if (choice.resolution_not_converging) {
    return formatted(FMT_STRING(
        "the finest the recording supports (messages every {:.3g} ms); the configured model's free run "
        "does not converge as the period halves (its own numerical error {:.2g} bar): no error of the "
        "grid is claimed, the model's error is the ranking's to explain"),
        1e3 * finest_interval, 1e-5 * choice.numerical_error);
  }
  return formatted(FMT_STRING(
      "the finest the recording supports (messages every {:.3g} ms); the free run's own error there is "
      "about {:.2g} bar (noise {:.3g} bar)"),
      1e3 * finest_interval, 1e-5 * outcome.grid_error, 1e-5 * noise);
}

void addSetting(SettingsChoice& choice, const std::string& key, double value, const std::string& reason) {
  ChosenSetting setting;
  setting.key = key;
  setting.value = value;
  setting.reason = reason;
  choice.settings.push_back(setting);
}

// The grid's points on the position's messages (their stamps as corrected by the clock offsets) where they
// carry the velocity, the cushion's impact is short against them and the period chosen is theirs or finer:
// the free run integrates the cushion's motion between grid points, and a cubic through messages that fall
// between them misreads a fast press's 4 ms impact by up to 1 % of its speed, in a pattern that moved its
// bulk modulus by up to 1.2 % as the same recording's stamps were moved by 0.3-0.7 ms (doc/resolution.md,
// "Where the messages fall between the grid's points"). On a coarser grid (a slow press at 2 ms) the motion
// is slow against the period and the grid stays at k T. The phase is taken modulo the study's period nearest
// the messages' interval (2 ms halved: on any of the study's grids every point, or every other, is then a
// message), and only where the messages keep it (coherence of at least 0.9: jitter below about 7 % of the
// period, a rate on it). Where the velocity is derived, the free run reads the position's own cubic, whose
// integral over each interval is its change: the grid's phase then only decides how much of the position's
// noise its samples hold (all of it on the messages; a large soft press's bulk modulus moved +0.3 %, its free
// run 1.25 -> 1.38 times the noise), and the grid stays too.
constexpr double kPhaseCoherence = 0.9;
// Only where the motion changes within a few messages (an impact shorter than about eight message
// intervals: the velocity steps by more than a fifth of its range from one message to the next; a cosine
// ramp over T steps by pi h / (2 T) of it): a fast press's 3-5 ms impact steps 31-52 % at 1 kHz, a small
// stiff press's 15 ms 10 %, the slow and large soft presses' 20-30 ms 5-8 %. Slower motions are read
// between messages as well as on them, and a grid moved off the valve's commands costs a slow press its
// 2 ms (its commands then switch inside the grid's intervals, which the free run resolves less well).
constexpr double kImpactStep = 0.2;
constexpr std::size_t kLargestSteps = 5;

std::optional<MessagePhase> motionPhase(const Messages& messages, const SettingsChoice& choice,
                                        double chosen_period) {
  constexpr int kX = static_cast<int>(InputStream::kPosition);
  const double interval = choice.survey.message_interval[kX];
  if (!(interval > 0.0) || chosen_period > 1.1 * interval) return std::nullopt;
  const double period = kCoarsestPeriod * std::exp2(std::round(std::log2(interval / kCoarsestPeriod)));
  if (std::abs(interval / period - 1.0) > 0.05) return std::nullopt;
  const double delay = choice.config.appliedTopicDelays()[kX];
  std::vector<double> stamps, speeds, steps;
  double last_stamp = NAN, last_speed = NAN;
  for (const auto& [stream, m] : messages) {
    if (stream != InputStream::kPosition || !std::isfinite(m.first)) continue;
    stamps.push_back(m.stamp - delay);
    if (!std::isfinite(m.second)) continue;
    speeds.push_back(std::abs(m.second));
    if (m.stamp - last_stamp <= 1.5 * interval && std::isfinite(last_speed))
      steps.push_back(std::abs(m.second - last_speed));
    last_stamp = m.stamp;
    last_speed = m.second;
  }
  if (speeds.size() * 2 < stamps.size() || steps.size() < kLargestSteps) return std::nullopt;
  // How far the motion changes from one message to the next: the 5th largest step (a few wild messages
  // aside) against the 99th percentile of the speed.
  std::nth_element(steps.begin(), steps.begin() + (kLargestSteps - 1), steps.end(), std::greater<double>());
  const std::size_t p99 = speeds.size() * 99 / 100;
  std::nth_element(speeds.begin(), speeds.begin() + static_cast<std::ptrdiff_t>(p99), speeds.end());
  if (!(steps[kLargestSteps - 1] > kImpactStep * speeds[p99])) return std::nullopt;
  const MessagePhase phase = messagePhase(stamps, period);
  if (!(phase.coherence >= kPhaseCoherence)) return std::nullopt;
  return phase;
}

// The configured values are kept, and the sample period judged against the study.
void keepConfigured(const IdentificationConfig& configured_config, const std::set<std::string>& configured,
                    double allowed_change, double noise, double chosen_period, SettingsChoice& choice) {
  IdentificationConfig& c = choice.config;
  for (ChosenSetting& setting : choice.settings) {
    if (!configured.count(setting.key)) continue;
    setting.configured = true;
    setting.reason = "configured";
    if (setting.key == "sample_period") {
      setting.value = configured_config.resampler.sample_period;
      c.resampler.sample_period = setting.value;
      for (const ResolutionCandidate& candidate : choice.study) {
        if (std::abs(candidate.sample_period - setting.value) > 1e-12) continue;
        const double change = candidate.change_to_finer;
        if (std::isfinite(change) && change > allowed_change) {
          choice.warnings.push_back(
              {WarningCode::kSettingBiased,
               formatted(FMT_STRING("sample_period {:.3g} ms (configured) leaves a resolution error on this "
                         "recording: the free run changes by {:.2g} bar when it halves (pressure "
                         "noise {:.2g} bar); the analysis would choose {:.3g} ms. An error of the "
                         "grid can look like a missing effect: remove the key to let the "
                         "analysis choose"),
                         1e3 * setting.value, 1e-5 * change, 1e-5 * noise, 1e3 * chosen_period)});
        }
      }
    } else if (setting.key == "moving_average_width") {
      setting.value = c.moving_average_width = configured_config.moving_average_width;
    } else if (setting.key == "derivative_width") {
      setting.value = c.derivative_width = configured_config.derivative_width;
    } else if (setting.key == "identification_period") {
      setting.value = c.identification_period = configured_config.identification_period;
    }
  }
}

// The velocity where the position topic carries none: differentiated over two sample periods of the chosen
// grid. Over the paper's 4 ms a fast press's 3-5 ms impact was smeared into 2.4 times the noise and a
// "missing" tank pressure; over 2 ms (at 1 ms) 1.5 times and nothing missing (measured while the free run
// read the derived velocity; it now reads the position's own slope, and the window shapes the stroke phases
// and the equation-error fit). The study keeps one window at every period.
void chooseVelocityWindow(const IdentificationConfig& configured_config, bool configured, SettingsChoice& choice) {
  IdentificationConfig& c = choice.config;
  ChosenSetting velocity;
  velocity.key = "velocity_window";
  velocity.configured = configured;
  c.velocity_window =
      analysisVelocityWindow(configured_config.velocity_window, configured, c.resampler.sample_period);
  velocity.reason =
      configured
          ? "configured"
          : "two sample periods: the derived velocity follows the impact as closely as the grid allows";
  velocity.value = c.velocity_window;
  choice.settings.push_back(velocity);
}

// A configured period changes what the others must be multiples of; windows longer than the shortest
// drawing phase are warned of.
void reconcile(double shortest_drawing, SettingsChoice& choice) {
  IdentificationConfig& c = choice.config;
  const double steps = c.identification_period / c.resampler.sample_period;
  if (std::abs(steps - std::lround(steps)) > 1e-6) {
    c.identification_period =
        c.resampler.sample_period * std::max(1L, std::lround(kIdentificationPeriod / c.resampler.sample_period));
  }
  if (shortest_drawing > 0.0 &&
      (c.moving_average_width + c.derivative_width - 1) * c.resampler.sample_period > shortest_drawing) {
    choice.warnings.push_back(
        {WarningCode::kFiltersTooLong,
         formatted(FMT_STRING("the filter windows ({} + {} samples of {:.3g} ms) are longer than the "
                   "shortest drawing phase ({:.3g} s): few rows lie wholly in it"),
                   c.moving_average_width, c.derivative_width, 1e3 * c.resampler.sample_period,
                   shortest_drawing)});
  }
}

// The topics' clock offsets on the survey's grid at `finest_period`, applied where they can be told from 0.
void searchClockOffsets(const Messages& messages, double finest_period, bool valve_configured, int jobs,
                        SettingsChoice& choice) {
  const auto searching = std::chrono::steady_clock::now();
  const IdentificationConfig finest = atPeriod(choice.config, finest_period, 0.0);
  choice.delays = estimateTopicDelays(gridAt(finest, messages), finest, jobs);
  if (choice.delays->valid && choice.delays->distinguishable()) {
    choice.config.topic_delays = choice.delays->delays;
    choice.delays_applied = true;
  } else if (choice.delays->valid) {
    choice.config.topic_delays = {0.0, 0.0, 0.0};
  }
  // Applied (or not) on the offsets the model's spool needs; stated as clock offsets with its timing.
  if (!choice.survey.spool_measured && !valve_configured)
    addValveModelTiming(choice.config.valve, &*choice.delays);
  choice.seconds_spent_on.clock_offsets = secondsSince(searching);
}

}  // namespace

TopicDelayEstimate SettingsFromRecording::clockOffsets() const {
  SettingsChoice choice;
  choice.config = config_;
  surveyMessages(messages_, &choice.survey);
  const double finest = studyPeriods(finestInterval(choice.survey)).back();
  searchClockOffsets(messages_, finest, valveModelConfigured(configured_), jobs_, choice);
  // The position's offset refined by the free run as the survey refines it, the model as configured.
  const HydraulicModel model = HydraulicModel::fromNames(choice.config.geometry, choice.config.effects,
                                                         choice.config.custom_effects, choice.config.oil);
  identifyAndRefineOffset(messages_, finest, model, jobs_, choice);
  return *choice.delays;
}

SettingsChoice SettingsFromRecording::choose() const {
  const auto started = std::chrono::steady_clock::now();
  SettingsChoice choice;
  choice.config = config_;
  std::vector<ValveSample> valve = surveyMessages(messages_, &choice.survey);
  const RecordingSurvey& survey = choice.survey;
  const bool valve_configured = valveModelConfigured(configured_);
  if (!survey.spool_measured && !valve_configured)
    choice.warnings.push_back({WarningCode::kValveModel, unmodelledSpoolWarning(config_.valve)});
  // The valve model from the operation, fitted on the other core while the clock offsets are searched
  // (they read the measured spool, not the model's).
  std::future<ValveOperationFit> valve_fit;
  double valve_seconds = 0.0;
  if (survey.spool_measured) {
    valve_fit = std::async(std::launch::async, [&valve, &valve_seconds, this] {
      const auto fitting = std::chrono::steady_clock::now();
      ValveOperationFit fit =
          fitValveToOperation(valve, config_.valve, config_.resampler.max_gap, kValveOperationSamples, jobs_);
      valve_seconds = secondsSince(fitting);
      return fit;
    });
  }
  const double finest_interval = finestInterval(survey);
  const double noise = survey.pressure_noise > 0.0 ? survey.pressure_noise : 0.2e5;
  const double allowed_change = kResolutionShare * noise;
  const std::vector<double> periods = studyPeriods(finest_interval);
  // The clock offsets, at the finest period (the study below then runs on corrected stamps).
  if (!config_.topicDelaysSet())
    searchClockOffsets(messages_, periods.back(), valve_configured, jobs_, choice);
  if (valve_fit.valid()) adoptValveFit(valve_fit.get(), valve_configured, choice);
  choice.seconds_spent_on.valve_model = valve_seconds;
  const SettingsChoice before_study = choice;
  ResolutionStudy study(messages_, periods, jobs_, choice);
  StudyOutcome outcome = study.run(allowed_change, noise, finest_interval, config_.resampler.sample_period);
  // Where the grid goes on the position's messages, the study runs again on that grid: its offset refinement
  // and its free runs then read the position where it was measured, as the analysis will.
  if (const std::optional<MessagePhase> phase = motionPhase(messages_, before_study, outcome.chosen_period)) {
    const auto first_study = choice.seconds_spent_on;
    choice = before_study;
    choice.seconds_spent_on = first_study;
    choice.config.resampler.grid_phase = phase->phase;
    ResolutionStudy on_the_messages(messages_, periods, jobs_, choice);
    outcome = on_the_messages.run(allowed_change, noise, finest_interval, config_.resampler.sample_period);
    // The study's free run may have refined the position's offset: the grid follows its corrected stamps.
    constexpr int kX = static_cast<int>(InputStream::kPosition);
    double& grid_phase = choice.config.resampler.grid_phase;
    grid_phase -= choice.config.appliedTopicDelays()[kX] - before_study.config.appliedTopicDelays()[kX];
    grid_phase -= std::floor(grid_phase / outcome.chosen_period) * outcome.chosen_period;
    addSetting(
        choice, "grid_phase", choice.config.resampler.grid_phase,
        formatted(FMT_STRING("the position's messages' phase within their period (coherence {:.3f}): the "
                             "cushion's motion is read where it was measured"),
                  phase->coherence));
  }
  const IdentificationConfig chosen = atPeriod(choice.config, outcome.chosen_period, outcome.shortest_drawing);
  addSetting(choice, "sample_period", outcome.chosen_period, periodReason(outcome, choice, finest_interval, noise));
  const std::string window_reason =
      chosen.moving_average_width == oddSamples(kMovingAverageWindow, outcome.chosen_period, 1)
          ? "the paper's window in time (62 ms moving average, 50 ms derivative)"
          : formatted(FMT_STRING("the paper's windows shortened to half the shortest drawing phase ({:.3g} s)"),
                      outcome.shortest_drawing);
  addSetting(choice, "moving_average_width", chosen.moving_average_width, window_reason);
  addSetting(choice, "derivative_width", chosen.derivative_width, window_reason);
  addSetting(choice, "identification_period", chosen.identification_period,
             "the paper's 10 ms, a whole number of samples");
  choice.config.resampler.sample_period = chosen.resampler.sample_period;
  choice.config.moving_average_width = chosen.moving_average_width;
  choice.config.derivative_width = chosen.derivative_width;
  choice.config.identification_period = chosen.identification_period;
  keepConfigured(config_, configured_, allowed_change, noise, outcome.chosen_period, choice);
  chooseVelocityWindow(config_, configured_.count("velocity_window") > 0, choice);
  reconcile(outcome.shortest_drawing, choice);
  choice.seconds_spent = secondsSince(started);
  choice.seconds_spent_on.resolution_study = choice.seconds_spent - choice.seconds_spent_on.clock_offsets;
  return choice;
}

}  // namespace die_cushion_ident
