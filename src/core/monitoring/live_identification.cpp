#include "die_cushion_ident/core/monitoring/live_identification.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {

using PushResult = UniformResampler::PushResult;

// [s] the memory of the long-run mean the live estimate's scatter is taken around (EstimateScatter).
constexpr double kScatterHorizon = 50.0;

// The settings the survey chooses, as they are compared and applied: the effects, geometry and limits stay
// the live configuration's (a model changed during the survey is kept).
struct Resolution {
  double sample_period, identification_period, velocity_window;
  int moving_average_width, derivative_width;
  // Times as equal to within rounding (0.002 * 5 is not 0.010 in binary).
  bool operator==(const Resolution& o) const {
    const auto same = [](double a, double b) {
      return std::abs(a - b) <= 1e-9 * std::max(std::abs(a), std::abs(b));
    };
    return same(sample_period, o.sample_period) && same(identification_period, o.identification_period) &&
           same(velocity_window, o.velocity_window) && moving_average_width == o.moving_average_width &&
           derivative_width == o.derivative_width;
  }
};

Resolution resolutionOf(const IdentificationConfig& c) {
  return {c.resampler.sample_period, c.identification_period, c.velocity_window, c.moving_average_width,
          c.derivative_width};
}

void setResolution(IdentificationConfig& c, const Resolution& r) {
  c.resampler.sample_period = r.sample_period;
  c.identification_period = r.identification_period;
  c.velocity_window = r.velocity_window;
  c.moving_average_width = r.moving_average_width;
  c.derivative_width = r.derivative_width;
}

std::string describe(const Resolution& r) {
  return formatted(
      FMT_STRING(
          "sample_period {:.3g} ms, moving_average_width {}, derivative_width {}, identification_period "
          "{:.3g} ms, velocity_window {:.3g} ms"),
      1e3 * r.sample_period, r.moving_average_width, r.derivative_width, 1e3 * r.identification_period,
      1e3 * r.velocity_window);
}

}  // namespace

const char* liveEventCodeName(LiveEventCode code) {
  switch (code) {
    case LiveEventCode::kSurveyed:
      return "surveyed";
    case LiveEventCode::kSettingsChosen:
      return "settings_chosen";
    case LiveEventCode::kSettingsNotChosen:
      return "settings_not_chosen";
    case LiveEventCode::kSettingBiased:
      return "setting_biased";
    case LiveEventCode::kResolutionLimited:
      return "resolution_limited";
    case LiveEventCode::kClockOffsetCorrected:
      return "clock_offset_corrected";
    case LiveEventCode::kTimeBaseRestarted:
      return "time_base_restarted";
  }
  return "unknown";
}

LiveIdentification::LiveIdentification(const IdentificationConfig& config,
                                       LiveIdentificationSettings settings)
    : config_(config), settings_(std::move(settings)), delays_configured_(config.topicDelaysSet()) {
  // The monitor estimates the clock offsets on its first ranking window with strokes (a session shorter
  // than the survey is corrected too); the survey's estimate, at the finest period on all its seconds,
  // supersedes it.
  if (settings_.choose_settings) {
    startSurvey();
  } else {
    takeConfiguredValveModel(settings_.configured, &config_);
  }
  rebuild();
}

void LiveIdentification::startSurvey() {
  IdentificationConfig surveyed = config_;
  // A survey restarted after the monitor corrected the offsets must still estimate them on raw stamps.
  if (!delays_configured_) surveyed.topic_delays = {kUnsetDelay(), kUnsetDelay(), kUnsetDelay()};
  survey_ = std::make_unique<SettingsFromRecording>(surveyed, settings_.configured, settings_.survey_seconds);
}

LiveIdentification::~LiveIdentification() {
  if (study_.valid()) study_.wait();
}

void LiveIdentification::setCallbacks(GridCallback on_grid, StepCallback on_step) {
  on_grid_ = std::move(on_grid);
  on_step_ = std::move(on_step);
}

void LiveIdentification::rebuild() {
  auto next = std::make_unique<IdentificationPipeline>(config_);
  // The slow oil temperature is not lost with the old pipeline (its next message may be seconds away).
  if (pipeline_) next->adoptOilTemperature(pipeline_->oilTemperature());
  pipeline_ = std::move(next);
  pressure_noise_.followGrid(config_.resampler.sample_period, config_.appliedTopicDelays()[0],
                             config_.resampler.grid_phase);
  pipeline_->setGridCallback(
      [this](const GridSample& g, const HydraulicIdentifier& identifier) { onGridSample(g, identifier); });
  // The scatter over many press cycles: 50 s (19 cycles of the paper's press; with 20-40 s the coverage
  // was the same), counted once the estimator has forgotten its start (1 / (1 - lambda) updates).
  scatter_ = EstimateScatter(kScatterHorizon / config_.identification_period);
  const double converged = 1.0 / std::max(1.0 - config_.forgetting_factor, 1e-6);
  pipeline_->setStepCallback([this, converged](const HydraulicIdentifier& identifier) {
    if (static_cast<double>(identifier.updates()) >= converged) scatter_.add(identifier.physicalParameters());
    if (on_step_) on_step_(identifier);
  });
  if (monitor_) {
    monitor_->restart(config_, pipeline_->identifier().model());
  } else {
    monitor_ =
        std::make_unique<LiveModelMonitor>(config_, pipeline_->identifier().model(), settings_.monitor);
  }
  ++generation_;
}

HydraulicEstimate LiveIdentification::estimate() const {
  HydraulicEstimate e = pipeline_->identifier().estimate();
  const ParameterVector scatter = scatter_.stds();
  for (std::size_t i = 0; i < e.parameters.size() && static_cast<Eigen::Index>(i) < scatter.size(); ++i) {
    e.parameters[i].std = std::max(e.parameters[i].std, scatter(static_cast<Eigen::Index>(i)));
  }
  return e;
}

void LiveIdentification::onGridSample(const GridSample& g, const HydraulicIdentifier& identifier) {
  const std::optional<LiveRanking> ranking = monitor_->addSample(g, identifier);
  if (on_grid_) on_grid_(g, identifier, ranking);
}

PushResult LiveIdentification::push(InputStream stream, const StreamSample& sample) {
  const PushResult result = pipeline_->push(stream, sample);
  // The newest accepted stamp, reset where the stamps jumped back: the restart's age for the diagnostics.
  if (result == PushResult::kRestarted ||
      (result == PushResult::kAccepted && !(sample.stamp <= newest_stamp_))) {
    newest_stamp_ = sample.stamp;
  }
  if (result == PushResult::kRestarted) {
    last_restart_stamp_ = sample.stamp;
    ++time_base_restarts_;
    event(HealthLevel::kWarn, LiveEventCode::kTimeBaseRestarted,
          std::string(inputStreamName(stream)) + " stamp jumped (bag restarted?): identification restarted");
    monitor_->resync();
    // A survey that saw the stamps jump back would mix two time bases: it starts over.
    if (survey_) startSurvey();
  }
  if (survey_) surveyMessage(stream, sample);
  if (stream == InputStream::kPressure) {
    pressure_noise_.add(sample.stamp, sample.first);
    monitor_->setGridPressureNoise(pressure_noise_.forGrid(config_.resampler.sample_period));
  }
  // Changes that rebuild the pipeline, after the message (never from inside its callbacks).
  poll();
  return result;
}

void LiveIdentification::poll() {
  applyDelayCorrection();
  collectStudy();
}

void LiveIdentification::surveyMessage(InputStream stream, const StreamSample& sample) {
  if (survey_->push(stream, sample)) return;
  // The study costs a few tenths of a second: on its own thread, the identification goes on meanwhile.
  study_ = std::async(std::launch::async, [survey = std::move(survey_)] { return survey->choose(); });
  event(
      HealthLevel::kOk, LiveEventCode::kSurveyed,
      formatted(FMT_STRING("surveyed the first {:.0f} s of messages: choosing the sample period and filters "
                           "from them"),
                settings_.survey_seconds));
}

void LiveIdentification::collectStudy() {
  if (!study_.valid() || study_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
  try {
    adopt(study_.get());
  } catch (const std::exception& e) {
    study_failure_ = e.what();
    event(HealthLevel::kWarn, LiveEventCode::kSettingsNotChosen,
          "the settings could not be chosen from the recording (" + study_failure_ +
              "): the configured settings stay");
  }
}

void LiveIdentification::adopt(const SettingsChoice& choice) {
  choice_ = choice;
  monitor_->setResolution(choice.resolution_error, choice.resolution_remedy);
  IdentificationConfig next = config_;
  setResolution(next, resolutionOf(choice.config));
  std::string extra;
  const bool delays_estimated = !delays_configured_ && choice.delays && choice.delays->valid;
  if (delays_estimated) {
    next.topic_delays = choice.config.topic_delays;
    const auto applied = next.appliedTopicDelays();
    extra += formatted(FMT_STRING("; clock offsets position {:+.2f} ms, valve {:+.2f} ms against pressure"),
                       1e3 * applied[1], 1e3 * applied[2]);
  }
  const bool valve_changed = choice.valve_from_operation && !valve_from_sweep_;
  if (valve_changed) {
    next.valve = choice.config.valve;
    next.valve_model_drives_free_run = choice.config.valve_model_drives_free_run;
    extra += formatted(
        FMT_STRING("; valve model from the operation ({:.0f} Hz, damping {:.2f}, dead time {:.2f} ms)"),
        next.valve.natural_frequency, next.valve.damping, 1e3 * next.valve.dead_time);
  }
  // A new grid, or offsets that move by more than a quarter of a sample period, restart the identification.
  // Smaller moves (within the stamps' jitter) and a new valve model alone are handed to the running pipeline
  // (as a sweep's valve is): the estimator goes on.
  const auto next_delays = next.appliedTopicDelays(), running_delays = config_.appliedTopicDelays();
  double largest_move = 0.0;
  for (int s = 0; s < kInputStreamCount; ++s) {
    largest_move = std::max(largest_move, std::abs(next_delays[s] - running_delays[s]));
  }
  const bool changed =
      !(resolutionOf(next) == resolutionOf(config_)) || largest_move > 0.25 * next.resampler.sample_period;
  config_ = next;
  if (changed) {
    rebuild();
  } else {
    pipeline_->setTopicDelays(config_.appliedTopicDelays());
    if (valve_changed) {
      pipeline_->setValveModel(config_.valve, config_.valve_model_drives_free_run);
      monitor_->setValveModel(config_.valve, config_.valve_model_drives_free_run);
    }
  }
  event(HealthLevel::kOk, LiveEventCode::kSettingsChosen,
        "settings chosen from the recording: " + describe(resolutionOf(config_)) + extra +
            (changed ? ": identification restarted with them" : ": as running, nothing restarted"));
  for (const AnalysisWarning& warning : choice.warnings) {
    event(HealthLevel::kWarn, LiveEventCode::kSettingBiased, warning.text);
  }
  if (!choice.resolution_limit.empty()) {
    event(HealthLevel::kWarn, LiveEventCode::kResolutionLimited, choice.resolution_limit);
  }
}

void LiveIdentification::applyDelayCorrection() {
  const auto delays = monitor_->takeDelayCorrection();
  if (!delays) return;
  config_.topic_delays = *delays;
  event(HealthLevel::kWarn, LiveEventCode::kClockOffsetCorrected,
        formatted(
            FMT_STRING("the topics' stamps are offset (position {:+.2f} ms, valve {:+.2f} ms against "
                       "pressure, estimated "
                       "from the data): corrected, identification restarted; set ~topic_delays to fix them"),
            config_.topic_delays[1] * 1e3, config_.topic_delays[2] * 1e3));
  rebuild();
}

std::vector<LiveEvent> LiveIdentification::takeEvents() {
  std::vector<LiveEvent> taken;
  taken.swap(events_);
  return taken;
}

std::vector<std::string> LiveIdentification::setEffects(const std::vector<std::string>& effects,
                                                        const std::vector<std::string>& custom_effects) {
  IdentificationConfig changed = config_;
  changed.effects = effects;
  changed.custom_effects = custom_effects;
  changed.initial_parameters.clear();
  std::vector<std::string> problems = changed.validate();
  if (!problems.empty()) return problems;
  config_ = changed;
  rebuild();
  return {};
}

void LiveIdentification::restart() { rebuild(); }

void LiveIdentification::setValveModel(const ServoValveParameters& valve) {
  config_.valve = valve;  // an unmeasured spool is predicted with the identified valve
  config_.valve.max_spool_velocity = std::numeric_limits<double>::infinity();
  pipeline_->setValveModel(config_.valve);
  valve_from_sweep_ = true;
}

TimingState LiveIdentification::timing() const {
  TimingState timing;
  timing.applied_delays = pipeline_->topicDelays();
  timing.derived_velocity_samples = pipeline_->derivedVelocitySamples();
  timing.velocity_delay = pipeline_->velocityDelay();
  timing.delays_configured = config_.topicDelaysSet();
  timing.estimate =
      choice_ && choice_->delays && choice_->delays->valid ? choice_->delays : monitor_->topicDelayEstimate();
  timing.time_base_restarts = time_base_restarts_;
  if (std::isfinite(last_restart_stamp_)) timing.since_restart = newest_stamp_ - last_restart_stamp_;
  return timing;
}

HealthReport LiveIdentification::settingsHealth() const {
  HealthReport r;
  const Resolution running = resolutionOf(config_);
  r.add("sample_period [ms]", formatted(FMT_STRING("{:.3g}"), 1e3 * running.sample_period));
  r.add("moving_average_width [samples]", formatted(FMT_STRING("{}"), running.moving_average_width));
  r.add("derivative_width [samples]", formatted(FMT_STRING("{}"), running.derivative_width));
  r.add("identification_period [ms]", formatted(FMT_STRING("{:.3g}"), 1e3 * running.identification_period));
  r.add("velocity_window [ms]", formatted(FMT_STRING("{:.3g}"), 1e3 * running.velocity_window));
  if (!settings_.choose_settings) {
    r.summary(HealthLevel::kOk, "settings as configured (~choose_settings is false)");
    return r;
  }
  if (survey_) {
    const auto& kept = survey_->messages();
    const double seconds = kept.size() > 1 ? kept.back().second.stamp - kept.front().second.stamp : 0.0;
    r.summary(
        HealthLevel::kOk,
        formatted(FMT_STRING("surveying the recording to choose the sample period and filters: {:.0f} of "
                             "{:.0f} s (the configured or default settings run meanwhile)"),
                  std::max(seconds, 0.0), settings_.survey_seconds));
    return r;
  }
  if (study_.valid()) {
    r.summary(HealthLevel::kOk, "choosing the sample period and filters from the survey");
    return r;
  }
  if (!choice_) {
    r.summary(HealthLevel::kWarn, "the settings could not be chosen from the recording (" + study_failure_ +
                                      "): the configured settings run");
    return r;
  }
  for (const ChosenSetting& s : choice_->settings) {
    r.add("why " + s.key, std::string(s.configured ? "configured" : "chosen") + ": " + s.reason);
  }
  if (std::isfinite(choice_->resolution_error)) {
    r.add("resolution error [bar]", formatted(FMT_STRING("{:.3g}"), 1e-5 * choice_->resolution_error));
  }
  r.add("pressure noise [bar]", formatted(FMT_STRING("{:.3g}"), 1e-5 * choice_->survey.pressure_noise));
  r.add("study time [s]", formatted(FMT_STRING("{:.2f}"), choice_->seconds_spent));
  if (!choice_->resolution_limit.empty()) {
    r.summary(HealthLevel::kWarn, choice_->resolution_limit);
  } else if (!choice_->warnings.empty()) {
    r.summary(HealthLevel::kWarn, choice_->warnings.front().text);
  } else {
    r.summary(HealthLevel::kOk, "chosen from the recording: " + describe(running));
  }
  return r;
}

}  // namespace die_cushion_ident
