#include "die_cushion_ident/core/analysis/offline_analysis.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <limits>

#include "die_cushion_ident/core/adequacy/cycle_group_fits.h"
#include "die_cushion_ident/core/adequacy/effect_onset.h"
#include "die_cushion_ident/core/adequacy/equation_error_bias.h"
#include "die_cushion_ident/core/adequacy/formula_proposals.h"
#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/adequacy/implausible_parameters.h"
#include "die_cushion_ident/core/fits/parameter_uncertainty.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "die_cushion_ident/core/util/parallel_for.h"

namespace die_cushion_ident {

namespace {
// [K] an oil temperature range within a recording worth naming as the cause of a drift: the bulk modulus
// moves by about 2 % over it, the leakage by 20 %.
constexpr double kNotableWarming = 5.0;

// Samples kept before each kept cycle's impact where the grid is thinned: four times the filters' reach
// and at least half a second, so that every fit's filters and free run have settled at the impact; at most a
// tenth of the bound (a 10 us grid's half second would not leave room for cycles).
std::size_t leadInSamples(const IdentificationConfig& config) {
  const double half_second = std::ceil(0.5 / config.resampler.sample_period);
  const double wanted = std::max(4.0 * (config.moving_average_width + config.derivative_width), half_second);
  return static_cast<std::size_t>(std::min(wanted, std::floor(config.max_analysed_samples / 10.0)));
}

// The warning a thinned analysis carries, in words.
std::string thinnedInWords(const GridThinning& thinning, double sample_period) {
  return formatted(
             FMT_STRING(
                 "the recording is longer than max_analysed_samples ({:.0f} s of grid kept at {:.3g} ms): "
                 "the fit "
                 "to the whole recording, the free run, the uncertainty, the change search and the effect "
                 "ranking judged every "),
             thinning.samples_kept * sample_period, 1e3 * sample_period) +
         ordinal(thinning.stride) +
         formatted(
             FMT_STRING(
                 " press cycle, {} of {}, evenly spaced (the online estimate covers every sample); raise "
                 "max_analysed_samples to judge more of them"),
             thinning.cycles_kept, thinning.cycles_seen);
}
}  // namespace

void GridCoverage::add(const GridSample& g) {
  complete += g.complete ? 1 : 0;
  with_velocity += g.complete && std::isfinite(g.v) ? 1 : 0;
  if (std::isfinite(g.p)) highest = std::max(highest, static_cast<double>(g.p));
}

OfflineAnalysis::OfflineAnalysis(const IdentificationConfig& config)
    : config_(config),
      free_run_valve_(config.valve),
      pipeline_(config),
      grid_(static_cast<std::size_t>(config.max_analysed_samples), leadInSamples(config)) {
  config_.refine_held_out_fits = true;
  pressure_noise_.followGrid(config_.resampler.sample_period, config_.appliedTopicDelays()[0],
                             config_.resampler.grid_phase);
  pipeline_.setGridCallback([this](const GridSample& g, const HydraulicIdentifier&) {
    coverage_.add(g);
    grid_.push(g);
  });
  pipeline_.setStepCallback(
      [this](const HydraulicIdentifier& identifier) { estimates_.add(identifier.estimate()); });
}

// A valve reported much slower than the sweep's frequencies: the points depend on how long the amplifier
// held each command (the default assumes one message interval; an amplifier updating at 1 kHz but reported
// at 250 Hz held it a quarter of that), and the recording cannot tell which. A press's valve reported at
// 250 Hz gave 112 Hz and damping 0.61 under the default, 78.5 Hz and 0.69 with the true 1 ms hold: both
// fits go to the user, with the key that decides between them.
bool OfflineAnalysis::warnIfTheHoldDecidesTheValveFit(const RecordedSweep& sweep,
                                                      std::vector<AnalysisWarning>* warnings) const {
  if (!sweep.fit.success || sweep.points.empty() || !(sweep.message_interval > 0.0)) return false;
  double highest = 0.0;
  for (const auto& p : sweep.points) highest = std::max(highest, p.frequency);
  constexpr double kMessagesPerPeriod = 4.0;
  if (highest * sweep.message_interval * kMessagesPerPeriod <= 1.0) return false;
  RecordedSweepOptions continuous;
  continuous.command_hold = 0.0;
  const RecordedSweep alternative = analyzeRecordedSweep(valve_, continuous);
  const ServoValveParameters& held = sweep.fit.parameters;
  std::string text = formatted(
      FMT_STRING("the valve messages come every {:.3g} ms, fewer than {:.0f} per period of the highest "
                 "analysed sweep frequency ({:.0f} Hz): the valve fit "),
      1e3 * sweep.message_interval, kMessagesPerPeriod, highest);
  if (alternative.fit.success) {
    const ServoValveParameters& other = alternative.fit.parameters;
    text +=
        "depends on how long the amplifier held each command, which the recording cannot tell. " +
        formatted(
            FMT_STRING(
                "Held one message interval (the default): {:.1f} Hz, damping {:.2f}, dead time {:.2f} ms; "),
            held.natural_frequency, held.damping, 1e3 * held.dead_time) +
        formatted(FMT_STRING("a continuous command (valve_command_hold: 0): {:.1f} Hz, damping {:.2f}, dead "
                             "time {:.2f} ms. "),
                  other.natural_frequency, other.damping, 1e3 * other.dead_time) +
        "Set valve_command_hold to the amplifier's update period";
  } else {
    text += formatted(
        FMT_STRING(
            "({:.1f} Hz, damping {:.2f}) assumes the amplifier held each command one message interval, "
            "which the recording cannot tell; set valve_command_hold to the amplifier's update period"),
        held.natural_frequency, held.damping);
  }
  warnings->push_back({WarningCode::kValveModel, text});
  return true;
}

void OfflineAnalysis::pushOilTemperature(const StreamSample& sample) {
  ++messages_;
  ++oil_received_;
  // Every accepted message, for the grid's temperature once all are in (settleOilTemperature).
  if (pipeline_.pushOilTemperature(sample) == UniformResampler::PushResult::kAccepted) {
    oil_messages_.emplace_back(sample.stamp, sample.first);
  }
}

void OfflineAnalysis::push(InputStream stream, const StreamSample& sample) {
  ++messages_;
  pipeline_.push(stream, sample);
  if (stream == InputStream::kPressure) pressure_noise_.add(sample.stamp, sample.first);
  // The sweep analysis wants the raw valve signal, not the 2 ms grid (sweeps reach 160 Hz), but only where
  // the command can be a sweep: hours of press strokes are not kept.
  if (stream == InputStream::kValve && std::isfinite(sample.stamp) && std::isfinite(sample.first)) {
    valve_filter_.push({sample.stamp, sample.first, sample.second}, &valve_);
  }
}

void OfflineAnalysis::reserve(double seconds, double max_seconds) {
  if (!(seconds > 0.0) || !(seconds <= max_seconds)) return;
  grid_.reserve(static_cast<std::size_t>(1.01 * seconds / config_.resampler.sample_period) + 1000);
}

void OfflineAnalysis::endInput() {
  if (!flushed_) pipeline_.flush();
  flushed_ = true;
  config_.grid_pressure_noise = pressure_noise_.forGrid(config_.resampler.sample_period);
}

TopicDelayEstimate OfflineAnalysis::estimateTopicDelays() {
  endInput();
  return die_cushion_ident::estimateTopicDelays(grid_.grid(), config_);
}

OfflineResult OfflineAnalysis::finish(const std::function<void(const std::string&)>& progress) {
  OfflineResult r = identify(progress);
  explain(&r, progress);
  return r;
}

// The recorded sweep, before the fits: its valve model, not the configured one, then judges the port side
// near the kink in every fit (the node does the same after its own sweep). A valve model 30 % off in its
// natural frequency moved the dead volume by 1.3 % at the paper's widths and 3 % at the widest. Not where the
// recording cannot tell the amplifier's hold: that fit may be the wrong one.
void OfflineAnalysis::analyzeValveSweep(OfflineResult* result, const std::function<void(const std::string&)>& tell) {
  OfflineResult& r = *result;
  valve_filter_.flush(&valve_);
  if (valve_.empty()) return;
  tell("looking for valve sine sweeps");
  RecordedSweepOptions options;
  options.command_hold = config_.valve_command_hold;  // NaN: one valve message interval
  RecordedSweep sweep = analyzeRecordedSweep(valve_, options);
  const bool hold_undecided =
      !std::isfinite(config_.valve_command_hold) && warnIfTheHoldDecidesTheValveFit(sweep, &r.warnings);
  if (sweep.segments.empty()) return;
  if (sweep.fit.success && !hold_undecided) {
    config_.valve = sweep.fit.parameters;
    r.valve_model_source = "sweep";
  }
  r.valve = std::move(sweep);
}

namespace {

// A part of the analysis that could not run: why, in words and with what to do; the result is partial.
void cannotRun(OfflineResult& r, const std::string& why, WarningCode code = WarningCode::kNotRun) {
  r.warnings.push_back({code, why});
  r.partial = true;
}

// Messages rejected as implausible or as stamped far off the other topics, per topic.
void warnRejectedMessages(const IdentificationConfig& config, OfflineResult& r) {
  const auto& bounds = config.resamplerConfig().plausible;
  for (int s = 0; s < kInputStreamCount; ++s) {
    const StreamHealth& h = r.health[s];
    const char* name = inputStreamName(static_cast<InputStream>(s));
    if (h.implausible > 0) {
      const std::string text = formatted(
          FMT_STRING(
              "{} {} messages outside the physically plausible range [{:.4g}, {:.4g}]{} were rejected like "
              "non-finite ones (see the *_plausible_* configuration keys)"),
          h.implausible, name, bounds[s].min_first, bounds[s].max_first,
          s == 0   ? ""
          : s == 1 ? " (or |velocity| above max_plausible_velocity)"
                   : " (or |spool| > 1.5)");
      r.warnings.push_back({WarningCode::kMessagesRejected, text});
    }
    if (h.wild_stamps > 0) {
      const std::string text = formatted(
          FMT_STRING(
              "{} {} messages had stamps far off the other topics' (the last {:+.4g} s) and were rejected"),
          h.wild_stamps, name, h.last_wild_offset);
      r.warnings.push_back({WarningCode::kMessagesRejected, text});
    }
  }
}

// The oil temperature messages rejected, by reason.
void warnRejectedOilTemperature(const IdentificationConfig& config, OfflineResult& r) {
  if (!r.oil_temperature) return;
  const OilTemperatureRecord& oil = *r.oil_temperature;
  const StreamHealth& h = oil.health;
  std::string reasons;
  const auto add = [&](std::uint64_t count, const std::string& what) {
    if (count > 0) reasons += (reasons.empty() ? "" : ", ") + formatted(FMT_STRING("{} "), count) + what;
  };
  add(h.non_finite, "not finite (NaN)");
  add(h.implausible - oil.jumps,
      formatted(FMT_STRING("outside the plausible range [{:.4g}, {:.4g}] degC"),
                config.min_plausible_oil_temperature, config.max_plausible_oil_temperature));
  add(oil.jumps,
      formatted(
          FMT_STRING("jumping faster than {:.3g} K/s from the last accepted value (unconfirmed by the next "
                     "messages)"),
          config.max_plausible_oil_temperature_rate));
  add(h.wild_stamps,
      formatted(FMT_STRING("stamped more than {:.3g} s off the other topics (the last {:+.4g} s)"),
                config.oil_temperature_max_age, h.last_wild_offset));
  add(h.duplicates + h.out_of_order, "repeated or running back in time");
  if (reasons.empty()) return;
  r.warnings.push_back({WarningCode::kMessagesRejected,
                        "oil temperature messages rejected (the analysis goes on without them): " + reasons});
}

// Whether the hydraulics can be identified at all: all three topics, overlapping in time.
void decideHydraulics(const GridCoverage& coverage, OfflineResult& r) {
  r.hydraulics = r.health[0].accepted > 0 && r.health[1].accepted > 0 && r.health[2].accepted > 0;
  if (!r.hydraulics) {
    cannotRun(r, std::string("the ") +
                     (r.health[0].accepted == 0 ? "pressure" : r.health[1].accepted == 0 ? "position" : "valve") +
                     " topic gave no usable message: the hydraulics were not identified (check the topic names "
                     "in the config's topics: and the warnings above)");
  } else if (coverage.complete == 0) {
    cannotRun(r, "pressure, position and valve never overlap in time (no sample has all three): the hydraulics "
                 "were not identified; check the stamps (topics stamped by different clocks far apart?)");
    r.hydraulics = false;
  }
}

}  // namespace

void OfflineAnalysis::settleOilTemperature(OfflineResult* result) {
  OfflineResult& r = *result;
  const bool needed =
      std::find(config_.effects.begin(), config_.effects.end(), "oil_temperature") != config_.effects.end();
  if (oil_received_ == 0) {
    if (needed) {
      r.warnings.push_back(
          {WarningCode::kOilTemperature,
           "the model has the effect oil_temperature, but the recording holds no oil temperature "
           "(topic oil_temperature): the effect cannot act, and its coefficient stays at its "
           "start; record the oil's temperature, or leave the effect out"});
    }
    return;
  }
  const OilTemperatureInput& input = pipeline_.oilTemperature();
  OilTemperatureRecord oil;
  oil.health = input.health();
  oil.jumps = input.jumps();
  oil.mean = input.mean();
  oil.lowest = input.lowest();
  oil.highest = input.highest();
  oil.stamp_offset = input.meanStampOffset();
  oil.reference = config_.oil.reference_temperature;
  const double max_age = config_.oil_temperature_max_age;
  grid_.setOilTemperature([&](double t) { return OilTemperatureInput::heldAt(oil_messages_, t, max_age); });
  double sum = 0.0;
  std::uint64_t complete = 0, with = 0;
  for (const GridSample& g : grid_.grid()) {
    if (!g.complete) continue;
    ++complete;
    if (!std::isfinite(g.T)) continue;
    ++with;
    sum += g.T;
  }
  oil.grid_share = complete > 0 ? static_cast<double>(with) / static_cast<double>(complete) : 0.0;
  if (with > 0) {
    oil.origin = sum / static_cast<double>(with);
    config_.oil.temperature_origin = oil.origin;
  }
  if (oil.health.accepted == 0) {
    r.warnings.push_back(
        {WarningCode::kOilTemperature,
         formatted(FMT_STRING("the oil temperature topic gave no usable message ({} received, every one "
                              "rejected: see the warnings on rejected messages): the parameters are not "
                              "carried to the reference temperature"),
                   oil_received_)});
  } else if (oil.grid_share < 0.99 && complete > 0) {
    r.warnings.push_back(
        {WarningCode::kOilTemperature,
         formatted(
             FMT_STRING("the oil temperature topic was silent for {:.0f} % of the recording (longer than "
                        "oil_temperature_max_age, {:.3g} s, without a message): there the oil's temperature "
                        "is taken as "
                        "its mean over the rest ({:.1f} degC)"),
             100.0 * (1.0 - oil.grid_share), max_age, std::isfinite(oil.origin) ? oil.origin : oil.mean)});
  }
  r.oil_temperature = std::move(oil);
}

OfflineResult OfflineAnalysis::identify(const std::function<void(const std::string&)>& progress) {
  const auto tell = [&](const std::string& what) {
    if (progress) progress(what);
  };
  endInput();
  OfflineResult r;
  settleOilTemperature(&r);
  r.topic_delays = config_.appliedTopicDelays();
  r.topic_delays_source = config_.topicDelaysSet() ? "configured" : "none";
  r.derived_velocity_samples = pipeline_.derivedVelocitySamples();
  r.predicted_spool_messages = pipeline_.predictedSpoolMessages();
  r.messages = messages_;
  r.grid_samples = grid_.samplesSeen();
  r.thinning = {grid_.stride(), grid_.cyclesSeen(), grid_.cyclesKept(), grid_.grid().size()};
  for (int s = 0; s < kInputStreamCount; ++s)
    r.health[s] = pipeline_.resampler().health(static_cast<InputStream>(s));
  r.restarts = pipeline_.resampler().restarts();
  r.estimates = std::move(estimates_);
  const HydraulicModel model =
      HydraulicModel::fromNames(config_.geometry, config_.effects, config_.custom_effects, config_.oil);
  r.effects = model.effectNames();
  warnRejectedMessages(config_, r);
  warnRejectedOilTemperature(config_, r);
  decideHydraulics(coverage_, r);
  if (grid_.stride() > 1)
    r.warnings.push_back(
        {WarningCode::kCyclesThinned, thinnedInWords(r.thinning, config_.resampler.sample_period)});
  analyzeValveSweep(&r, tell);
  if (r.hydraulics) fitTheWholeRecording(model, coverage_.with_velocity > 0, coverage_.highest, &r, tell);
  if (r.no_press_stroke) {
    r.ranking.conclusion =
        "A recording without press strokes: judged for its step responses and valve sweeps only (see "
        "step_response and valve); the hydraulics need press strokes.";
  } else if (r.hydraulics && r.model.updates == 0) {
    // Nothing identified: no comparison of initial values with the measurement, no verdicts on them.
    r.ranking.conclusion = "No conclusion: nothing was identified (see the warnings).";
  } else if (r.hydraulics) {
    refineAndCompare(model, &r, tell);
  }
  if (r.oil_temperature && r.model.updates > 0 && std::isfinite(r.oil_temperature->origin)) {
    r.oil_temperature->at_reference = parametersAtTemperature(
        model, r.model, config_.oil, r.oil_temperature->origin, config_.oil.reference_temperature);
  }
  return r;
}

void OfflineAnalysis::fitTheWholeRecording(const HydraulicModel& model, bool velocity, double highest,
                                           OfflineResult* result, const std::function<void(const std::string&)>& tell) {
  OfflineResult& r = *result;
  if (!velocity) {
    cannotRun(r, "no velocity: the position topic carries none and none could be derived from the positions; "
                 "the model comparison and the effect ranking could not run");
  }
  tell("segmenting the strokes");
  r.strokes = segmentStrokes(grid_.grid());
  if (holdsNoPressStroke(grid_.grid(), r.strokes, config_.geometry.stroke_length)) {
    // Not a press recording: at rest the bulk modulus and the dead volume cannot be told apart, and a fit
    // would read as an implausible press model (K' = -1.4e10 on a step test). What it holds is judged below.
    cannotRun(
        r,
        "the recording holds no press stroke (the cushion at rest, no impact): a step-test or valve-sweep "
        "recording; the hydraulics are not identified from it (at rest the bulk modulus and the dead "
        "volume cannot be told apart), its step responses and valve sweeps are; record press strokes to "
        "identify the hydraulics",
        WarningCode::kNoPressStroke);
    r.no_press_stroke = true;
    return;
  }
  tell("fitting the model to the whole recording");
  r.model = fitOnCycles(grid_.grid(), r.strokes, config_, INT_MIN, INT_MAX);
  if (r.model.updates == 0 && highest < config_.min_pressure) {
    cannotRun(r,
              formatted(FMT_STRING("the pressure never exceeds min_pressure ({:.3g} Pa; highest {:.4g}): no "
                                   "parameters identified. Is it recorded in bar or psi? "
                                   "FluidPressure.fluid_pressure is in Pa"),
                        config_.min_pressure, highest));
    return;
  }
  if (r.model.updates == 0) {
    cannotRun(r, "the recording never excites the hydraulics (no press stroke with the pressure above "
                 "min_pressure): no parameters identified");
    return;
  }
  std::vector<std::string> uncertain;
  for (const auto& problem : implausibleParameters(model, r.model, 3.0, &uncertain)) {
    cannotRun(r,
              "implausible estimate: " + problem +
                  "; the model does not describe this recording (wrong joint, units or topic, or a large "
                  "clock offset between the topics); the comparison below is not a valid model check",
              WarningCode::kImplausibleParameter);
  }
  for (const auto& doubt : uncertain) {
    r.warnings.push_back({WarningCode::kUncertainParameter,
                          doubt +
                              ", but within 3 standard deviations of it: the recording does not pin "
                              "it down (more varied strokes would), or an effect the model lacks pulls it"});
  }
  tell("fitting each group of cycles alone (does a parameter change over the recording?)");
  const CycleGroupFits cycle_groups(grid_.grid(), r.strokes, config_, 10, jobs_);
  // The oil warmed while it was recorded, and the model does not follow it: the likeliest reading of a drift.
  std::string warming;
  if (r.oil_temperature && model.oilStateParameter() < 0 &&
      r.oil_temperature->highest - r.oil_temperature->lowest >= kNotableWarming) {
    warming = formatted(
        FMT_STRING(
            "; the oil's temperature went from {:.1f} to {:.1f} degC while it was recorded: try the effect "
            "oil_temperature"),
        r.oil_temperature->lowest, r.oil_temperature->highest);
  }
  for (const auto& spread : parametersThatVaryOverTheRecording(cycle_groups, r.model)) {
    const bool drift = spread.find(" drifts ") != std::string::npos;
    r.warnings.push_back({WarningCode::kChangingParameter, spread + (drift ? warming : "")});
  }
  tell("looking for an effect that starts within the recording");
  r.onset = findEffectOnset(grid_.grid(), r.strokes, config_, kVariationSignificance, jobs_, 60,
                            grid_.stride(), grid_.firstTime());
  if (r.onset) {
    r.warnings.push_back({WarningCode::kChangeWithinRecording,
                          r.onset->explanation + ". The whole recording's fit averages over the change: " +
                              "analyse the cycles from it on alone, or with " + r.onset->effect +
                              " in the model"});
  }
}

void OfflineAnalysis::refineAndCompare(const HydraulicModel& model, OfflineResult* result,
                                       const std::function<void(const std::string&)>& tell) {
  OfflineResult& r = *result;
  const HydraulicEstimate equation_error = r.model;
  // Refined by the free run's error where that brings it to the noise (refineByOutputError), unless the
  // fit is implausible (then the model does not describe the recording, and fitting its free run would
  // hide that).
  FreeRunInputSources sources;
  sources.spool_predicted = r.predicted_spool_messages > 0;
  OutputErrorOptions refine;
  if (!r.partial) {
    tell("refining the parameters by the free run's error");
    refine.jobs = jobs_;
    refine.pressure_noise = config_.grid_pressure_noise;
    refine.inputs = freeRunInputUncertainties(grid_.grid(), refine.max_samples, config_, free_run_valve_);
    r.output_error = refineByOutputError(grid_.grid(), model, r.model.values(), r.model.standardDeviations(),
                                         config_.min_pressure, refine);
    if (r.output_error->improved) {
      // The stds follow from both fits' parts in combineUncertainty below.
      for (std::size_t i = 0; i < r.model.parameters.size(); ++i)
        r.model.parameters[i].value = r.output_error->theta(static_cast<Eigen::Index>(i));
    }
  }
  tell("the parameters' uncertainty: the fit's, the press cycles' (jackknife) and the method's");
  HydraulicEstimate jackknife = equation_error;
  const bool resampled = applyCycleJackknife(grid_.grid(), r.strokes, config_, &jackknife, 10, jobs_);
  std::optional<EquationErrorBias> bias;  // the equation error's own bias at the refined model
  if (r.output_error && r.output_error->improved)
    bias =
        equationErrorBias(grid_.grid(), r.strokes, config_, model, r.output_error->theta, refine.max_samples);
  r.uncertainty = combineUncertainty(
      equation_error, r.output_error, resampled ? &jackknife : nullptr, &r.model,
      freeRunInputsKnown(grid_.grid(), refine.max_samples, config_, model, sources), bias ? &*bias : nullptr);
  tell("running the model free against the measurement");
  r.assessment = assessModel(grid_.grid(), r.strokes, model, r.model.values(), config_.min_pressure);
  if (r.assessment.samples == 0) {
    cannotRun(r, "the identified model could not be run against the measurement (no sample with pressure, "
                 "position, velocity and spool all known above min_pressure): no simulation error");
  }
}

void OfflineAnalysis::explain(OfflineResult* result, const std::function<void(const std::string&)>& progress) {
  const auto tell = [&](const std::string& what) {
    if (progress) progress(what);
  };
  OfflineResult& r = *result;
  if (r.hydraulics && r.model.updates > 0) {
    tell("trying the library's other effects on held-out cycles");
    EffectRankingOptions ranking_options;
    ranking_options.jobs = jobs_;
    ranking_options.resolution_error = resolution_error_;
    ranking_options.resolution_remedy = resolution_remedy_;
    r.ranking = rankEffects(grid_.grid(), r.strokes, config_, ranking_options);
    if (r.ranking.residual_unexplained || always_propose_) {
      tell("searching for a formula for the error the library leaves");
      addFormulaProposals(grid_.grid(), r.strokes, config_, &r.ranking, ranking_options);
    }
    r.ranking.recommended_held_out.predictions.reset();  // the base's free runs: 7 MB an hour, no longer read
    if (r.strokes.cycles == 0) {
      cannotRun(r,
                "no complete press stroke (impact, drawing, return to the top) in the recording: the effect "
                "ranking could not run; record at least three complete strokes");
    } else if (r.strokes.cycles < EffectRankingOptions().min_held_out_cycles) {
      cannotRun(r, "only " + std::to_string(r.strokes.cycles) +
                       " complete press stroke(s): the effect ranking "
                       "needs " +
                       std::to_string(EffectRankingOptions().min_held_out_cycles) +
                       " to judge on held-out strokes; every verdict is inconclusive (or not_needed where "
                       "the fit is outside "
                       "the physical range)");
    }
  }

  tell("looking for valve command steps at rest");
  r.step_responses = findStepResponses(grid_.grid());
  if (!r.step_responses.empty()) {
    const StepResponse& step = r.step_responses.front();
    if (config_.resampler.sample_period > step.recommendedMaxSamplingTime()) {
      r.warnings.push_back(
          {WarningCode::kSamplingTooCoarse,
           formatted(
               FMT_STRING("the sampling time (sample_period {:.4g} s) exceeds a tenth of the pressure's t63 "
                          "({:.4g} s from the step test at {:.3f} s): the identification cannot resolve the "
                          "pressure build-up; set sample_period to at most {:.4g} s"),
               config_.resampler.sample_period, step.t63, step.start, step.recommendedMaxSamplingTime())});
    }
  }
}

}  // namespace die_cushion_ident
