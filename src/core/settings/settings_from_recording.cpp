#include "die_cushion_ident/core/settings/settings_from_recording.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
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
#include "die_cushion_ident/core/signal/white_noise_estimator.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "die_cushion_ident/core/util/parallel_for.h"
#include "die_cushion_ident/core/valve/step_response.h"

namespace die_cushion_ident {

namespace {

using Messages = std::vector<std::pair<InputStream, StreamSample>>;

// The paper's filter windows in time (31 and 25 samples at 2 ms) and identification period.
constexpr double kMovingAverageWindow = 0.062;  // [s]
constexpr double kDerivativeWindow = 0.050;     // [s]
constexpr double kIdentificationPeriod = 0.010;  // [s]
// The candidate periods: the paper's 2 ms halved down to 0.25 ms.
constexpr double kCoarsestPeriod = 0.002;
constexpr double kFinestPeriod = 0.00025;
// The free run converges where its own numerical error is below this share of its change as the period
// halves, and that change falls by at least this ratio from one halving to the next.
constexpr double kConvergingShare = 0.2;
constexpr double kConvergingRatio = 1.3;

int oddSamples(double seconds, double period, int lowest) {
  int n = static_cast<int>(std::lround(seconds / period));
  if (n % 2 == 0) ++n;
  return std::max(lowest, n);
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  auto middle = values.begin() + values.size() / 2;
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

// The configuration at `period` with the paper's windows in time, no longer than half the shortest drawing;
// the velocity derived (where the position has none) over the same window at every period (a central
// difference over 2 ms samples): a window that shrank with the period made the derived velocity noisier and
// the free run's change look like a resolution error.
IdentificationConfig atPeriod(IdentificationConfig c, double period, double shortest_drawing) {
  c.resampler.sample_period = period;
  c.velocity_window = std::max(c.velocity_window, 2.0 * period);
  c.moving_average_width = oddSamples(kMovingAverageWindow, period, 1);
  c.derivative_width = oddSamples(kDerivativeWindow, period, 3);
  if (shortest_drawing > 0.0) {
    const double span = (c.moving_average_width + c.derivative_width - 1) * period;
    const double allowed = 0.5 * shortest_drawing;
    if (span > allowed) {
      const double shrink = allowed / span;
      c.moving_average_width = oddSamples(shrink * kMovingAverageWindow, period, 1);
      c.derivative_width = oddSamples(shrink * kDerivativeWindow, period, 3);
    }
  }
  c.identification_period = period * std::max(1L, std::lround(kIdentificationPeriod / period));
  return c;
}

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::vector<GridSample> gridAt(const IdentificationConfig& config, const Messages& messages) {
  std::vector<GridSample> grid;
  IdentificationPipeline pipeline(config);
  pipeline.setIdentifying(false);
  pipeline.setGridCallback([&](const GridSample& g, const HydraulicIdentifier&) { grid.push_back(g); });
  for (const auto& [stream, sample] : messages) pipeline.push(stream, sample);
  pipeline.flush();
  return grid;
}

// One sample period of the study: the survey on its grid, and one model run free on it.
struct Level {
  double period = 0.0;
  std::vector<GridSample> grid;
  StrokeSegmentation strokes;
  std::vector<double> t, modelled;  // the free run, NaN where it is not running
  double error_rms = std::numeric_limits<double>::quiet_NaN();
  double numerical_error = std::numeric_limits<double>::quiet_NaN();  // [Pa] against a 20 times tighter run
};

Level levelAt(const IdentificationConfig& config, const Messages& messages) {
  Level level;
  level.period = config.resampler.sample_period;
  level.grid = gridAt(config, messages);
  level.strokes = segmentStrokes(level.grid);
  return level;
}

// The shortest drawing phase (impact included) of the complete cycles [s], 0 where there is none.
double shortestDrawing(const Level& level) {
  double shortest = 0.0;
  for (int c = 0; c < level.strokes.cycles; ++c) {
    const auto [begin, end] = level.strokes.range(c, c);
    std::size_t drawing = 0;
    for (std::size_t i = begin; i < end; ++i) {
      const StrokePhase phase = level.strokes.phase[i];
      drawing += phase == StrokePhase::kDrawing || phase == StrokePhase::kImpact ? 1 : 0;
    }
    const double seconds = drawing * level.period;
    if (seconds > 0.0 && (shortest == 0.0 || seconds < shortest)) shortest = seconds;
  }
  return shortest;
}

// The free run of `theta` on the level's grid.
void runFree(const HydraulicModel& model, const ParameterVector& theta, double min_pressure, Level* level) {
  const std::vector<GridSample>& grid = level->grid;
  FreeRunPressure free_run(model, min_pressure);
  double sum = 0.0;
  std::size_t n = 0;
  level->t.assign(grid.size(), 0.0);
  level->modelled.assign(grid.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const GridSample* next = i + 1 < grid.size() ? &grid[i + 1] : nullptr;
    const double p = free_run.step(grid[i], theta, next);
    level->t[i] = grid[i].t;
    if (!std::isfinite(p) || free_run.anchoredThisStep() || !std::isfinite(grid[i].p)) continue;
    level->modelled[i] = p;
    sum += (grid[i].p - p) * (grid[i].p - p);
    ++n;
  }
  if (n > 0) level->error_rms = std::sqrt(sum / n);
}

// The free run's own numerical error on a level already run: its rms difference from the same run with a
// twenty times tighter tolerance. Only the chosen level's is asked for (the tight run costs more than the
// run itself: it was a third of the study where every level ran it).
double numericalError(const HydraulicModel& model, const ParameterVector& theta, double min_pressure, Level* level) {
  if (!std::isnan(level->numerical_error) || level->modelled.empty()) return level->numerical_error;
  const std::vector<GridSample>& grid = level->grid;
  FreeRunPressure tight(model, min_pressure, FreeRunPressure::kDefaultTolerance / 20.0);
  double difference = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const double q = tight.step(grid[i], theta, i + 1 < grid.size() ? &grid[i + 1] : nullptr);
    const double p = level->modelled[i];
    if (!std::isfinite(p) || !std::isfinite(q)) continue;
    difference += (p - q) * (p - q);
    ++n;
  }
  level->numerical_error = n > 0 ? std::sqrt(difference / n) : std::numeric_limits<double>::quiet_NaN();
  return level->numerical_error;
}

// rms difference of two levels' free runs at the samples both have (the coarser grid's times lie on the finer).
double changeBetween(const Level& coarse, const Level& fine, double fine_period) {
  std::unordered_map<long long, double> at;
  at.reserve(fine.t.size());
  for (std::size_t i = 0; i < fine.t.size(); ++i) at[std::llround(fine.t[i] / fine_period)] = fine.modelled[i];
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < coarse.t.size(); ++i) {
    const auto it = at.find(std::llround(coarse.t[i] / fine_period));
    if (it == at.end()) continue;
    const double d = coarse.modelled[i] - it->second;
    if (!std::isfinite(d)) continue;
    sum += d * d;
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : std::numeric_limits<double>::quiet_NaN();
}

// Richardson's estimate of the error left at a step from how the result changed as the step halved to it
// (`change`) and on the halving before (`earlier_change`): change / (2^q - 1), the order q = log2 of their
// ratio, held between 1 and 4 (1 where the earlier change is unknown).
struct Richardson {
  double order = 1.0;
  double error = 0.0;
  // The step at which the error would fall to `allowed`, at the same order, from `step`.
  double stepFor(double allowed, double step) const { return step * std::pow(allowed / error, 1.0 / order); }
};

Richardson richardson(double change, double earlier_change) {
  Richardson r;
  if (std::isfinite(earlier_change) && change > 0.0) r.order = std::clamp(std::log2(earlier_change / change), 1.0, 4.0);
  r.error = change / (std::pow(2.0, r.order) - 1.0);
  return r;
}

// The message rate [Hz] to record at for a sample interval [s], rounded up to 100 Hz.
double recordingRate(double interval) { return 100.0 * std::ceil(0.01 / interval); }

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

// The grid study above halves the sample period, but a grid finer than a topic's messages only interpolates
// them: a fast press's 4 ms impact seen by a position topic at 500 Hz leaves the free run 6 times the noise
// off whatever the period (1.9 times at 1 kHz). The position's own rate is studied like the period: the free
// run of the same parameters with every second and every fourth position message dropped; its change, by
// Richardson's estimate, is the error the position's rate leaves. (The valve topic is not thinned: its
// command is held between messages by the amplifier, so thinning it makes an error the recording does not
// have.)
void studyPositionRate(const Messages& messages, const IdentificationConfig& at_chosen, const HydraulicModel& model,
                       const ParameterVector& theta, const Level& native, double allowed_change, double noise,
                       SettingsChoice& choice) {
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
  const std::string finding = formatted(FMT_STRING(
      "resolution-limited: the position topic comes every {:.3g} ms, and the free run's error from that rate alone "
      "is about {:.2g} bar (pressure noise {:.2g} bar); "),
      1e3 * interval, 1e-5 * choice.position_rate_error, 1e-5 * noise);
  addRateLimit(finding, remedy, choice.position_rate_error, choice);
}

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
  const std::string remedy = formatted(FMT_STRING(
      "record the valve topic at its amplifier's update rate ({:.0f} Hz or more: 4 messages per period of the "
      "valve's {:.0f} Hz), or, where the amplifier updates only as often as the topic, set "
      "valve_command_hold: {:.3g}"),
      valveRecordingRate(frequency), frequency, interval);
  const std::string finding = formatted(FMT_STRING(
      "resolution-limited: the valve topic comes every {:.3g} ms, {:.1f} messages per period of the valve's "
      "{:.0f} Hz; commands a faster amplifier applied between them are not in the recording, and the free "
      "run's error from them is about {:.2g} bar (pressure noise {:.2g} bar); "),
      1e3 * interval, 1.0 / (frequency * interval), frequency, 1e-5 * choice.valve_rate_error, 1e-5 * noise);
  addRateLimit(finding, remedy, choice.valve_rate_error, choice);
}

// The offset's refinement is kept up to this multiple of the noise: the survey's free run, over its first
// ten seconds and on the equation-error fit's start, came to 2.6 times the noise on a clean fast press whose
// offset was right. A model that lacks an effect leaves more (and the shift is bounded to three of the
// integral-form estimate's stds).
constexpr double kDelayKeptUpToNoise = 4.0;

// The free run's offset estimate is uncertain by at least this [s]: its sandwich std (1-5 us) is blind to
// the model's own timing (the valve's dead time, the derived velocity); over the press matrix's late-stamp
// recordings with the right model it came up to 0.19 ms off (8 cycles), most within 0.06 ms.
constexpr double kFreeRunOffsetFloor = 1e-4;
// Grid samples the offset is refined on (from the survey's start): 6 s at 1 ms. 12 000 instead of 20 000 (and
// no sandwich std) took the settings from 0.42-0.76 s to 0.34-0.45 s with no offset of 24 late-stamp
// recordings moved by more than 0.007 ms; 6000 took the refinement from 0.05-0.12 s to 0.026-0.07 s, and
// over 60 late-stamp recordings (4 classes x 3 plants x clean and 4 effects, position 10 ms and valve 5 ms
// late) no offset moved by more than 0.01 ms (all within 0.19 ms of the truth, as before). 4000 (tried
// 2026-11-26 for the settings' cost) moved those offsets by at most 0.013 ms, but a clean small stiff press
// with its position at 500 Hz, which the free run is most sensitive to, then ran 1.89 times the noise
// (1.54 with 6000): not taken.
constexpr std::size_t kDelaySamples = 6000;
// [Pa] the refinement's free-run tolerance; the analysis's own refinement keeps 1 Pa. 5 Pa took a third off
// the refinement's time and moved the refined offsets by 0.03 us at most (four classes' 8-cycle recordings).
constexpr double kDelayTolerance = 5.0;

// The position topic's clock offset refined by the free run. On a fast press the free run is so sensitive to
// it that the integral-form estimate's 0.08 ms (within its stated 0.07 ms) left 6 times the noise and a dead
// volume 54 % off; the output error, fitted jointly with the parameters, resolves it about ten times finer
// (a large soft chamber's 0.32 ms off came to 0.07 ms). Where kept it replaces the integral form's estimate,
// which bounds it (within three of its stds). Tried only where the offsets were estimated and the
// model's free run comes near the noise (refineByOutputError keeps nothing else: a model that lacks an
// effect would bend the offset to hide it). The refinement where the offset moved.
std::optional<OutputErrorFit> refinePositionDelay(const HydraulicModel& model, const HydraulicEstimate& fit,
                                                  const std::vector<GridSample>& grid, double period,
                                                  int jobs, SettingsChoice& choice) {
  if (!choice.delays || !choice.delays->valid || fit.updates == 0 || !fit.values().allFinite()) return std::nullopt;
  constexpr int kPosition = static_cast<int>(InputStream::kPosition);
  const double prior = choice.delays->resolution[kPosition];
  if (!(prior > 0.0)) return std::nullopt;
  OutputErrorOptions options;
  options.position_shift_scale = std::max(prior, 1e-4);
  options.kept_up_to_noise = kDelayKeptUpToNoise;
  // Its std is the floor: the sandwich's (a Jacobian of 2 (k + 1) free runs more) was 20-50 times smaller.
  options.with_stds = false;
  options.max_samples = kDelaySamples;
  options.tolerance = kDelayTolerance;
  options.jobs = jobs;
  // At a period between the pressure's messages the grid's own second differences see interpolations.
  const double pressure_interval = choice.survey.message_interval[static_cast<int>(InputStream::kPressure)];
  if (gridBetweenMessages(period, pressure_interval)) options.pressure_noise = choice.survey.pressure_noise;
  const OutputErrorFit refined =
      refineByOutputError(grid, model, fit.values(), fit.standardDeviations(), choice.config.min_pressure, options);
  if (!refined.improved) return std::nullopt;
  const double shift = refined.position_shift;
  choice.position_delay_shift = shift;
  choice.config.topic_delays[kPosition] += shift;
  choice.delays->delays[kPosition] += shift;
  choice.delays->resolution[kPosition] = kFreeRunOffsetFloor;
  choice.delays->message += formatted(FMT_STRING("; the position's offset refined by the free run by {:+.3f} ms (+-{:.2f} ms)"),
                                      1e3 * shift, 1e3 * kFreeRunOffsetFloor);
  if (choice.delays->distinguishable()) choice.delays_applied = true;
  return refined;
}

// The configured model identified on the whole grid at `period` (the survey's finest), and the position's
// clock offset refined by its free run there: the resolution study's start, and, alone, the offsets for an
// analysis whose settings are fixed (SettingsFromRecording::clockOffsets).
struct FinestFit {
  Level level;
  double shortest_drawing = 0.0;
  HydraulicEstimate fit;
  std::optional<OutputErrorFit> refined;
};

FinestFit identifyAndRefineOffset(const Messages& messages, double period, const HydraulicModel& model,
                                  int jobs, SettingsChoice& choice) {
  FinestFit finest;
  finest.level = levelAt(atPeriod(choice.config, period, 0.0), messages);
  finest.shortest_drawing = shortestDrawing(finest.level);
  finest.fit = fitOnCycles(finest.level.grid, finest.level.strokes,
                           atPeriod(choice.config, period, finest.shortest_drawing), INT_MIN, INT_MAX);
  const auto refining = std::chrono::steady_clock::now();
  finest.refined = refinePositionDelay(model, finest.fit, finest.level.grid, period, jobs, choice);
  choice.seconds_spent_on.clock_offsets += secondsSince(refining);
  return finest;
}

}  // namespace

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

// What the resolution study decided.
struct StudyOutcome {
  double chosen_period = 0.0;
  double shortest_drawing = 0.0;
  bool studied = false;   // the configured model's fit was plausible, and its free run was studied
  bool resolved = false;  // a period's free run changed by less than the allowed share when it halved
  std::string implausible;  // the first implausible parameter, where the fit was
  bool no_press_stroke = false;  // the survey holds no press stroke (a step test or sweep at rest)
  double step_t63 = 0.0;         // [s] the first step test's t63 in such a survey (0: none found)
  double grid_error = 0.0;  // [Pa] the grid's own resolution error (the topics' rates not in it)
};

// The study itself: the model identified once, at the finest period, then run free at every period: how
// much the free run moves as the period halves is the grid's own error.
class ResolutionStudy {
 public:
  ResolutionStudy(const Messages& messages, std::vector<double> periods, int jobs, SettingsChoice& choice)
      : messages_(messages),
        periods_(std::move(periods)),
        jobs_(jobs),
        choice_(choice),
        model_(HydraulicModel::fromNames(choice.config.geometry, choice.config.effects,
                                         choice.config.custom_effects, choice.config.oil)),
        levels_(periods_.size()) {}

  StudyOutcome run(double allowed_change, double noise, double finest_interval, double configured_period);

 private:
  Level& level(std::size_t k) { return level(k, model_); }
  Level& level(std::size_t k, const HydraulicModel& model) {
    if (levels_[k].grid.empty()) levels_[k] = levelAt(atPeriod(choice_.config, periods_[k], shortest_drawing_), messages_);
    if (levels_[k].t.empty()) runFree(model, theta_, choice_.config.min_pressure, &levels_[k]);
    return levels_[k];
  }
  // Levels k and k + 1 side by side (each its grid and free run), the second thread on its own copy of the
  // model (a user's formula holds one parser per instance). The same levels as one after the other.
  void prepareLevels(std::size_t k) {
    const HydraulicModel own(model_);
    parallelFor(2, jobs_, [&](std::size_t i) { level(k + i, i == 0 ? model_ : own); });
  }
  void identifyAtTheFinestPeriod(StudyOutcome& outcome);
  void chooseForTheStepTest(StudyOutcome& outcome);
  std::size_t halveUntilSettled(double allowed_change, bool* resolved);
  void judgeTheFinestPeriod(std::size_t chosen, double allowed_change, double noise, double finest_interval,
                            bool* resolved);

  const Messages& messages_;
  std::vector<double> periods_;
  int jobs_;
  SettingsChoice& choice_;
  HydraulicModel model_;
  std::vector<Level> levels_;
  HydraulicEstimate fit_;
  ParameterVector theta_;
  double shortest_drawing_ = 0.0;
};

// Identifies the model at the finest period and refines the position's offset by the free run there. A
// configured model that lacks an effect the press has can fit to nonsense (a negative bulk modulus where the
// tank pressure is missing on a fast press); its free run then says nothing about the grid, and a resolution
// error read from it would hide the missing effect. Such a fit is not studied: the finest period the
// recording supports is taken, and no resolution error is claimed.
void ResolutionStudy::identifyAtTheFinestPeriod(StudyOutcome& outcome) {
  FinestFit finest_fit = identifyAndRefineOffset(messages_, periods_.back(), model_, jobs_, choice_);
  levels_.back() = std::move(finest_fit.level);
  shortest_drawing_ = finest_fit.shortest_drawing;
  choice_.survey.cycles = levels_.back().strokes.cycles;
  choice_.survey.shortest_drawing = shortest_drawing_;
  fit_ = std::move(finest_fit.fit);
  // Where the position's offset was refined by the free run: the finest level's grid read with it, and the
  // refined parameters (fitted with it) studied.
  const std::optional<OutputErrorFit>& refined = finest_fit.refined;
  if (refined) {
    Level& finest = levels_.back();
    finest.grid = positionShifted(finest.grid, finest.grid.size(), *choice_.position_delay_shift);
    finest.strokes = segmentStrokes(finest.grid);
  }
  std::vector<std::string> uncertain;
  const std::vector<std::string> implausible =
      fit_.updates > 0 ? implausibleParameters(model_, fit_, 3.0, &uncertain) : std::vector<std::string>();
  if (!implausible.empty()) outcome.implausible = implausible.front();
  outcome.studied = fit_.updates > 0 && fit_.values().allFinite() && implausible.empty();
  // A step test or sweep at rest cannot tell the bulk modulus from the dead volume: its fit says nothing of
  // the model (K' = -1.4e10 on a step test), and the survey is not studied. It is said as what it is, not as
  // an implausible press; its period is chosen as before (a live node surveying an idle press keeps the
  // finest, which a fast press needs once it strokes), unless a step test sets it (chooseForTheStepTest).
  const Level& finest = levels_.back();
  outcome.no_press_stroke =
      !outcome.studied && holdsNoPressStroke(finest.grid, finest.strokes, choice_.config.geometry.stroke_length);
  theta_ = !outcome.studied ? ParameterVector() : refined ? refined->theta : fit_.values();
}

// A survey at rest that holds a valve step test: the pressure's t63, timed on the finest grid, sets the
// period (at most a tenth of it, the paper's rule, as step_response's recommended_max_sampling_time): the
// coarsest studied period within it, else the finest. A fast press's 19 ms t63 on the paper's 2 ms was
// "sampling too coarse"; a slow press's 108 ms keeps 2 ms.
void ResolutionStudy::chooseForTheStepTest(StudyOutcome& outcome) {
  const std::vector<StepResponse> steps = findStepResponses(levels_.back().grid);
  if (steps.empty()) return;
  outcome.step_t63 = steps.front().t63;
  const double most = steps.front().recommendedMaxSamplingTime();
  outcome.chosen_period = periods_.back();
  for (double period : periods_) {
    if (period <= most) {
      outcome.chosen_period = period;
      break;
    }
  }
}

// From 2 ms down, halving, until the free run stops changing or the recording's rate is reached; the
// index of the period chosen.
std::size_t ResolutionStudy::halveUntilSettled(double allowed_change, bool* resolved) {
  for (std::size_t k = 0; k + 1 < periods_.size(); ++k) {
    prepareLevels(k);
    ResolutionCandidate& c = choice_.study.emplace_back();
    c.sample_period = periods_[k];
    c.simulation_error_rms = level(k).error_rms;
    c.change_to_finer = changeBetween(level(k), level(k + 1), periods_[k + 1]);
    if (std::isfinite(c.change_to_finer) && c.change_to_finer <= allowed_change) {
      *resolved = true;
      return k;
    }
  }
  ResolutionCandidate& c = choice_.study.emplace_back();
  c.sample_period = periods_.back();
  c.simulation_error_rms = level(periods_.size() - 1).error_rms;
  return periods_.size() - 1;
}

// The finest period the recording supports still changed, or nothing finer than 2 ms was possible: its own
// error by Richardson's estimate from coarser periods, change / (2^q - 1), the order q from the last two
// halvings (4 and 8 ms run for them where the study had fewer), between 1 and 4.
void ResolutionStudy::judgeTheFinestPeriod(std::size_t chosen, double allowed_change, double noise,
                                           double finest_interval, bool* resolved) {
  std::vector<double> changes;  // coarsest first, ending with the change into the chosen period
  for (const ResolutionCandidate& c : choice_.study) {
    if (std::isfinite(c.change_to_finer)) changes.push_back(c.change_to_finer);
  }
  Level finer = level(0);
  // The coarser levels and the chosen level's numerical error side by side (the second on its own model).
  const HydraulicModel own(model_);
  Level& at_chosen = level(chosen);
  double numerical = std::numeric_limits<double>::quiet_NaN();
  parallelFor(2, jobs_, [&](std::size_t task) {
    if (task == 1) {
      numerical = numericalError(own, theta_, choice_.config.min_pressure, &at_chosen);
      return;
    }
    for (double coarse_period = 2.0 * kCoarsestPeriod; changes.size() < 2; coarse_period *= 2.0) {
      Level coarse = levelAt(atPeriod(choice_.config, coarse_period, shortest_drawing_), messages_);
      runFree(model_, theta_, choice_.config.min_pressure, &coarse);
      changes.insert(changes.begin(), changeBetween(coarse, finer, finer.period));
      finer = std::move(coarse);
    }
  });
  const double last_change = changes.back(), earlier_change = changes[changes.size() - 2];
  const Richardson estimate = richardson(last_change, earlier_change);
  choice_.resolution_error = estimate.error;
  // A free run that moves with its own tolerance as much as with the period, or whose change does not fall
  // as the period halves, does not converge: that is the configured model failing (a fast press without
  // its tank pressure ran 51 bar off, 10 bar from its own tolerance), not the grid. No resolution error is
  // claimed, or it would excuse the missing effect ("resolution-limited: record at 462600 Hz").
  const bool converging = !(numerical > kConvergingShare * last_change) &&
                          !(std::isfinite(earlier_change) && earlier_change < kConvergingRatio * last_change);
  const double chosen_period = periods_[chosen];
  if (!converging) {
    choice_.resolution_error = std::numeric_limits<double>::quiet_NaN();
    choice_.resolution_not_converging = true;
  } else if (choice_.resolution_error > allowed_change) {
    // The period at which the error would fall to the allowed share, at the same order.
    choice_.resolution_remedy = formatted(FMT_STRING("record pressure, position and valve at {:.0f} Hz or more"),
                                          recordingRate(estimate.stepFor(allowed_change, chosen_period)));
    choice_.resolution_limit =
        formatted(FMT_STRING("resolution-limited: at the finest sample period the recording supports ({:.3g} ms; its fastest "
                  "topic comes every {:.3g} ms) the free run's own error is about {:.2g} bar (pressure noise {:.2g} "
                  "bar); "),
                  1e3 * chosen_period, 1e3 * finest_interval, 1e-5 * choice_.resolution_error, 1e-5 * noise) +
        choice_.resolution_remedy;
  } else {
    *resolved = true;
  }
}

StudyOutcome ResolutionStudy::run(double allowed_change, double noise, double finest_interval,
                                  double configured_period) {
  StudyOutcome outcome;
  identifyAtTheFinestPeriod(outcome);
  outcome.shortest_drawing = shortest_drawing_;
  if (!outcome.studied) {
    outcome.chosen_period = outcome.implausible.empty() ? configured_period : periods_.back();
    choice_.resolution_error = std::numeric_limits<double>::quiet_NaN();
    if (outcome.no_press_stroke) chooseForTheStepTest(outcome);
    return outcome;
  }
  const std::size_t chosen = halveUntilSettled(allowed_change, &outcome.resolved);
  for (ResolutionCandidate& c : choice_.study) c.bulk_modulus = fit_.parameters[HydraulicModel::kBulkModulus].value;
  outcome.chosen_period = periods_[chosen];
  if (outcome.resolved) {
    choice_.resolution_error = choice_.study[chosen].change_to_finer;
  } else {
    judgeTheFinestPeriod(chosen, allowed_change, noise, finest_interval, &outcome.resolved);
  }
  choice_.numerical_error = numericalError(model_, theta_, choice_.config.min_pressure, &level(chosen));
  outcome.grid_error = choice_.resolution_error;
  const IdentificationConfig at_chosen = atPeriod(choice_.config, outcome.chosen_period, shortest_drawing_);
  // Richardson's extrapolation of the position's rate needs a free run that converges; the valve's rate is a
  // difference of two free runs, measured, not extrapolated (a fast press with its valve at 250 Hz, whose
  // free run ran 46 times the noise, did not converge as the period halved and was told "structured").
  if (!choice_.resolution_not_converging)
    studyPositionRate(messages_, at_chosen, model_, theta_, level(chosen), allowed_change, noise, choice_);
  studyValveRate(messages_, at_chosen, model_, theta_, level(chosen), allowed_change, noise, jobs_, choice_);
  return outcome;
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
// "missing" tank pressure; over 2 ms (at 1 ms) 1.5 times and nothing missing. The study keeps one window at
// every period, so that the derived velocity's noise is not read as the grid's error.
void chooseVelocityWindow(const IdentificationConfig& configured_config, bool configured, SettingsChoice& choice) {
  IdentificationConfig& c = choice.config;
  ChosenSetting velocity;
  velocity.key = "velocity_window";
  velocity.configured = configured;
  if (velocity.configured) {
    c.velocity_window = std::max(configured_config.velocity_window, 2.0 * c.resampler.sample_period);
    velocity.reason = "configured";
  } else {
    c.velocity_window = 2.0 * c.resampler.sample_period;
    velocity.reason = "two sample periods: the derived velocity follows the impact as closely as the grid allows";
  }
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
  ResolutionStudy study(messages_, periods, jobs_, choice);
  const StudyOutcome outcome = study.run(allowed_change, noise, finest_interval, config_.resampler.sample_period);
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
