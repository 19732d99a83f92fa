#include "rate_study.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "die_cushion_ident/core/signal/white_noise_estimator.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "die_cushion_ident/core/valve/valve_operation_fit.h"

namespace die_cushion_ident::settings_detail {

namespace {

// The messages with all but every `factor`-th of one stream dropped.
Messages thinned(const Messages& messages, InputStream stream, int factor) {
  Messages kept;
  kept.reserve(messages.size());
  std::size_t count = 0;
  for (const auto& message : messages) {
    if (message.first == stream && count++ % factor != 0) continue;
    kept.push_back(message);
  }
  return kept;
}

// A topic's rate that limits the free run: its finding and remedy appended to the choice's, its error added
// in quadrature to what the grid cannot resolve (independent of it).
void addRateLimit(const std::string& finding, const std::string& remedy, double error,
                  SettingsChoice& choice) {
  choice.resolution_remedy =
      choice.resolution_remedy.empty() ? remedy : choice.resolution_remedy + "; " + remedy;
  choice.resolution_limit =
      choice.resolution_limit.empty() ? finding + remedy : choice.resolution_limit + "; " + finding + remedy;
  choice.resolution_error =
      std::hypot(std::isfinite(choice.resolution_error) ? choice.resolution_error : 0.0, error);
}

}  // namespace

// The grid study above halves the sample period, but a grid finer than a topic's messages only interpolates
// them: a fast press's 4 ms impact seen by a position topic at 500 Hz leaves the free run 6 times the noise
// off whatever the period (1.9 times at 1 kHz). The position's own rate is studied like the period: the free
// run of the same parameters with every second and every fourth position message dropped; its change, by
// Richardson's estimate, is the error the position's rate leaves. (The valve topic is not thinned: its
// command is held between messages by the amplifier, so thinning it makes an error the recording does not
// have.)
void studyPositionRate(const Messages& messages, const IdentificationConfig& at_chosen,
                       const HydraulicModel& model, const ParameterVector& theta, const Level& native,
                       double allowed_change, double noise, SettingsChoice& choice) {
  const double interval = choice.survey.message_interval[static_cast<int>(InputStream::kPosition)];
  const double period = at_chosen.resampler.sample_period;
  if (!(interval > 1.5 * period)) return;
  const auto freeRunWithEvery = [&](int factor) {
    Level thinned_level = levelAt(at_chosen, thinned(messages, InputStream::kPosition, factor));
    runFree(model, theta, at_chosen.min_pressure, &thinned_level);
    return thinned_level;
  };
  const Level half_rate = freeRunWithEvery(2);
  const double change = changeBetween(half_rate, native, period);
  const double earlier_change = changeBetween(freeRunWithEvery(4), half_rate, period);
  if (!std::isfinite(change)) return;
  const Richardson estimate = richardson(change, earlier_change);
  choice.position_rate_error = estimate.error;
  if (!(choice.position_rate_error > allowed_change)) return;
  const std::string remedy = formatted(FMT_STRING("record the position at {:.0f} Hz or more"),
                                       recordingRate(estimate.stepFor(allowed_change, interval)));
  const std::string finding = formatted(FMT_STRING("resolution-limited: the position topic comes every "
                                                   "{:.3g} ms, and the free run's error from that rate alone "
                                                   "is about {:.2g} bar (pressure noise {:.2g} bar); "),
                                        1e3 * interval, 1e-5 * choice.position_rate_error, 1e-5 * noise);
  addRateLimit(finding, remedy, choice.position_rate_error, choice);
}

// The velocity window where the position topic carries no velocity: it shapes the stroke phases and the
// equation-error fit's regressors; the free run reads the position's own slope instead (FreeRunPressure).
double analysisVelocityWindow(double configured_window, bool configured, double period) {
  return configured ? std::max(configured_window, 2.0 * period) : 2.0 * period;
}

namespace {

// The valve topic's messages with a command between each two (within max_gap) and no spool reading: the mean
// of its neighbours plus `roughness` times a normal draw (seeded: the same on every run). An amplifier
// updating twice per message, its command moving linearly where roughness is 0.
Messages withCommandsBetween(const Messages& messages, double max_gap, double roughness) {
  std::mt19937 draws(1);
  std::normal_distribution<double> normal;
  Messages dense;
  dense.reserve(messages.size() + messages.size() / 2);
  const StreamSample* last = nullptr;
  for (const auto& message : messages) {
    const StreamSample& valve = message.second;
    if (message.first == InputStream::kValve && std::isfinite(valve.stamp) && std::isfinite(valve.first)) {
      if (last && valve.stamp > last->stamp && valve.stamp - last->stamp <= max_gap) {
        StreamSample between;
        between.stamp = 0.5 * (last->stamp + valve.stamp);
        between.first = 0.5 * (last->first + valve.first) + roughness * normal(draws);
        between.second = std::numeric_limits<double>::quiet_NaN();
        dense.emplace_back(InputStream::kValve, between);
      }
      last = &valve;
    }
    dense.push_back(message);
  }
  return dense;
}

std::vector<ValveSample> valveSamples(const Messages& messages) {
  std::vector<ValveSample> valve;
  for (const auto& [stream, sample] : messages) {
    if (stream == InputStream::kValve) valve.push_back({sample.stamp, sample.first, sample.second});
  }
  return valve;
}

// How far a command between two of the valve's messages strays from their mean: a controller that answers
// its sensors' noise issues commands with a white part of std s (the recorded commands' second differences
// measure it), and a command's difference from the mean of its two neighbours then has std sqrt(1.5) s.
double commandRoughness(const Messages& messages) {
  WhiteNoiseEstimator white(1);
  const StreamSample* before = nullptr;
  const StreamSample* last = nullptr;
  for (const auto& [stream, sample] : messages) {
    if (stream != InputStream::kValve || !std::isfinite(sample.first)) continue;
    if (before) white.add(before->first, last->first, sample.first);
    before = last;
    last = &sample;
  }
  return std::isfinite(white.sigma()) ? std::sqrt(1.5) * white.sigma() : 0.0;
}

// Valve messages per period of its natural frequency below which the commands between them decide the
// spool (the sweep's warning counts the same per period of its highest frequency).
constexpr double kValveMessagesPerPeriod = 4.0;

}  // namespace

// Whether commands a faster amplifier applied between valve messages `interval` [s] apart can move a valve
// of natural frequency `frequency` [Hz]: fewer than kValveMessagesPerPeriod messages a period, and
// valve_command_hold (`hold`) not saying that the amplifier holds each command a whole message interval.
bool commandsBetweenMessagesMatter(double frequency, double interval, double hold) {
  return interval > 0.0 && frequency * interval * kValveMessagesPerPeriod > 1.0 && !(hold >= 0.9 * interval);
}

// [Hz] the valve topic's rate that holds kValveMessagesPerPeriod messages a period of `frequency` [Hz].
double valveRecordingRate(double frequency) {
  return recordingRate(1.0 / (kValveMessagesPerPeriod * frequency));
}

// The valve topic's rate. The valve model drives the free run from the recorded commands, each held to the
// next message, as if the amplifier updated at the message rate. Where the messages come fewer than 4 per
// period of the valve's natural frequency, commands a faster amplifier applied between them move the spool
// in ways the recording does not hold, and the valve's fit absorbs what it can into its parameters (a fast
// press's 182 Hz valve came out 207 Hz from 500 Hz messages of a 1 kHz controller); the spool's residual is
// at the sensor's noise either way, so the recording cannot tell. The study runs the free run of the same
// hydraulic parameters on a command between each two messages, as rough as the recorded ones
// (commandRoughness), the valve model fitted to the spool with those commands moving linearly; its rms
// difference from the chosen period's free run is the error the valve's rate leaves. Over 48 clean presses
// of the four classes with the valve at 500 and 250 Hz (a 1 kHz controller) it came to 0.59-1.81 times the
// free run's error beyond the noise (median 1.06) where it ran; the commands moving linearly alone gave
// 0.3-0.9 of it. Not where valve_command_hold says the amplifier holds each command a whole message
// interval (then nothing happens between messages).
void studyValveRate(const Messages& messages, const IdentificationConfig& at_chosen,
                    const HydraulicModel& model, const ParameterVector& theta, const Level& native,
                    double allowed_change, double noise, int jobs, SettingsChoice& choice) {
  // The valve as the spool showed it (where its fit failed, the measured spool drives the free run).
  if (!choice.valve) return;
  const ServoValveParameters& valve = choice.valve->parameters;
  const double interval = choice.survey.message_interval[static_cast<int>(InputStream::kValve)];
  const double frequency = valve.natural_frequency;
  if (!commandsBetweenMessagesMatter(frequency, interval, at_chosen.valve_command_hold)) return;
  const double max_gap = at_chosen.resampler.max_gap;
  const ValveOperationFit between =
      fitValveToOperation(valveSamples(withCommandsBetween(messages, max_gap, 0.0)), valve, max_gap,
                          2 * kValveOperationSamples, jobs);
  if (!between.success) return;
  IdentificationConfig driven = at_chosen;
  driven.valve = between.parameters;
  driven.valve_model_drives_free_run = true;
  Level level = levelAt(driven, withCommandsBetween(messages, max_gap, commandRoughness(messages)));
  runFree(model, theta, at_chosen.min_pressure, &level);
  choice.valve_rate_error = changeBetween(level, native, at_chosen.resampler.sample_period);
  if (!(choice.valve_rate_error > allowed_change)) return;
  const std::string remedy = formatted(
      FMT_STRING("record the valve topic at its amplifier's update rate ({:.0f} Hz or more: 4 messages per "
                 "period of the "
                 "valve's {:.0f} Hz), or, where the amplifier updates only as often as the topic, set "
                 "valve_command_hold: {:.3g}"),
      valveRecordingRate(frequency), frequency, interval);
  const std::string finding = formatted(
      FMT_STRING("resolution-limited: the valve topic comes every {:.3g} ms, {:.1f} messages per period of "
                 "the valve's "
                 "{:.0f} Hz; commands a faster amplifier applied between them are not in the recording, and "
                 "the free "
                 "run's error from them is about {:.2g} bar (pressure noise {:.2g} bar); "),
      1e3 * interval, 1.0 / (frequency * interval), frequency, 1e-5 * choice.valve_rate_error, 1e-5 * noise);
  addRateLimit(finding, remedy, choice.valve_rate_error, choice);
}

}  // namespace die_cushion_ident::settings_detail
