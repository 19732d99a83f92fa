#include "output/summary_yaml.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <regex>
#include <stdexcept>

#include "die_cushion_ident/core/util/formatted.h"
#include "output/output_files.h"

namespace die_cushion_ident {

namespace {

void emitRegions(YAML::Emitter& out, const char* key, const std::vector<RegionError>& regions, bool phase) {
  out << YAML::Key << key << YAML::Value << YAML::BeginSeq;
  for (const auto& r : regions) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << (phase ? "phase" : "range") << YAML::Value << r.label;
    out << YAML::Key << "samples" << YAML::Value << r.samples;
    out << YAML::Key << "simulation_error_rms" << YAML::Value << r.rms;
    out << YAML::Key << "mean_residual" << YAML::Value << r.mean_residual;
    if (std::isfinite(r.made_rms)) {
      out << YAML::Key << "made_error_rms" << YAML::Value << r.made_rms;
      out << YAML::Key << "made_mean_residual" << YAML::Value << r.made_mean_residual;
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
}

// `uncertainty`, where given (one per parameter), says what each std is made of.
void emitParameters(YAML::Emitter& out, const std::vector<IdentifiedParameter>& parameters,
                    const std::vector<ParameterUncertainty>& uncertainty = {}) {
  out << YAML::BeginSeq;
  for (std::size_t i = 0; i < parameters.size(); ++i) {
    const IdentifiedParameter& p = parameters[i];
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << p.name << YAML::Key
        << "value" << YAML::Value << p.value << YAML::Key << "std" << YAML::Value << p.std << YAML::Key
        << "unit" << YAML::Value << p.unit;
    if (i < uncertainty.size()) {
      const ParameterUncertainty& u = uncertainty[i];
      out << YAML::Key << "std_parts" << YAML::Value << YAML::BeginMap << YAML::Key << "regression"
          << YAML::Value << u.regression << YAML::Key << "cycles" << YAML::Value << u.cycles << YAML::Key
          << "free_run" << YAML::Value << u.free_run << YAML::Key << "misfit" << YAML::Value << u.misfit
          << YAML::Key << "method" << YAML::Value << u.method << YAML::Key << "valve_model" << YAML::Value
          << u.valve_model << YAML::Key << "clock_offsets" << YAML::Value << u.clock_offsets << YAML::EndMap;
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
}

std::string emitSummary(const AnalysisInput& input, const IdentificationConfig& config,
                        const OfflineResult& r, const std::vector<std::string>& outputs);

// yaml-cpp writes NaN and infinity as .nan / .inf; the contract allows neither. Each becomes null (~), and
// the count is returned so that a warning can say so.
int replaceNonFinite(std::string* text) {
  static const std::regex kNonFinite(R"((^|[\s:\[,{])-?\.(nan|inf|NaN|Inf)(?=$|[\s,\]}]))");
  int count = 0;
  std::string out;
  auto begin = std::sregex_iterator(text->begin(), text->end(), kNonFinite);
  std::size_t last = 0;
  for (auto it = begin; it != std::sregex_iterator(); ++it) {
    out.append(*text, last, it->position() - last);
    out += (*it)[1].str() + "~";
    last = it->position() + it->length();
    ++count;
  }
  out.append(*text, last, std::string::npos);
  *text = out;
  return count;
}

// The resolution study's candidate periods, each with its free run's error and change to the next finer.
void emitResolutionStudy(YAML::Emitter& out, const std::vector<ResolutionCandidate>& study) {
  out << YAML::Key << "study" << YAML::Value << YAML::BeginSeq;
  for (const ResolutionCandidate& c : study) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "sample_period" << YAML::Value << c.sample_period;
    if (std::isfinite(c.simulation_error_rms))
      out << YAML::Key << "simulation_error_rms" << YAML::Value << c.simulation_error_rms;
    if (std::isfinite(c.change_to_finer))
      out << YAML::Key << "change_to_finer" << YAML::Value << c.change_to_finer;
    if (std::isfinite(c.bulk_modulus)) out << YAML::Key << "bulk_modulus" << YAML::Value << c.bulk_modulus;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
}

// What the first read of the recording found, and the valve fitted to its operation.
void emitSurvey(YAML::Emitter& out, const SettingsChoice& choice) {
  static const char* kNames[kInputStreamCount] = {"pressure", "position", "valve"};
  const RecordingSurvey& survey = choice.survey;
  out << YAML::Key << "survey" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "seconds" << YAML::Value << survey.seconds;
  out << YAML::Key << "message_intervals" << YAML::Value << YAML::Flow << YAML::BeginMap;
  for (int s = 0; s < kInputStreamCount; ++s)
    out << YAML::Key << kNames[s] << YAML::Value << survey.message_interval[s];
  out << YAML::EndMap;
  out << YAML::Key << "pressure_noise" << YAML::Value << survey.pressure_noise;
  out << YAML::Key << "cycles" << YAML::Value << survey.cycles;
  out << YAML::Key << "shortest_drawing" << YAML::Value << survey.shortest_drawing;
  out << YAML::EndMap;
  if (!choice.valve) return;
  const ValveOperationFit& v = *choice.valve;
  out << YAML::Key << "valve_from_operation" << YAML::Value << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "used" << YAML::Value << choice.valve_from_operation;
  out << YAML::Key << "natural_frequency" << YAML::Value << v.parameters.natural_frequency;
  out << YAML::Key << "damping" << YAML::Value << v.parameters.damping;
  out << YAML::Key << "gain" << YAML::Value << v.parameters.gain;
  out << YAML::Key << "dead_time" << YAML::Value << v.parameters.dead_time;
  out << YAML::Key << "residual_rms" << YAML::Value << v.residual_rms;
  out << YAML::Key << "noise" << YAML::Value << v.noise_sigma;
  out << YAML::EndMap;
}

// The settings as configured, where none were chosen from the recording.
void emitFixedSettings(YAML::Emitter& out, const IdentificationConfig& config) {
  for (const auto& [key, value] :
       {std::pair<const char*, double>{"sample_period", config.resampler.sample_period},
        {"moving_average_width", config.moving_average_width},
        {"derivative_width", config.derivative_width},
        {"identification_period", config.identification_period}}) {
    out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "value"
        << YAML::Value << value << YAML::Key << "source" << YAML::Value << "fixed" << YAML::EndMap;
  }
}

// What the analysis chose from the recording and why (SettingsFromRecording), or the settings as configured.
void emitSettings(YAML::Emitter& out, const IdentificationConfig& config,
                  const std::optional<SettingsChoice>& choice) {
  out << YAML::Key << "settings" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "chosen_from_recording" << YAML::Value << choice.has_value();
  if (!choice) {
    emitFixedSettings(out, config);
    out << YAML::EndMap;
    return;
  }
  for (const ChosenSetting& setting : choice->settings) {
    out << YAML::Key << setting.key << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "value"
        << YAML::Value << setting.value << YAML::Key << "source" << YAML::Value
        << (setting.configured ? "configured" : "chosen") << YAML::Key << "reason" << YAML::Value
        << setting.reason << YAML::EndMap;
  }
  if (std::isfinite(choice->resolution_error)) {
    out << YAML::Key << "resolution_error" << YAML::Value << choice->resolution_error;
  }
  if (choice->position_delay_shift && choice->delays) {
    out << YAML::Key << "position_delay_refined_by_free_run" << YAML::Value << YAML::Flow << YAML::BeginMap
        << YAML::Key << "shift" << YAML::Value << *choice->position_delay_shift << YAML::Key << "std"
        << YAML::Value << choice->delays->resolution[static_cast<int>(InputStream::kPosition)];
    // The free run's own stds where it judged the common offset (computed only there).
    if (std::isfinite(choice->position_delay_std))
      out << YAML::Key << "fit_std" << YAML::Value << choice->position_delay_std;
    if (choice->pressure_delay_prior > 0.0) {
      out << YAML::Key << "valve_shift" << YAML::Value << 0.0 - choice->pressure_delay_shift;
      if (std::isfinite(choice->pressure_delay_std))
        out << YAML::Key << "common_fit_std" << YAML::Value << choice->pressure_delay_std;
      out << YAML::Key << "common_prior" << YAML::Value << choice->pressure_delay_prior;
    }
    out << YAML::EndMap;
  }
  if (std::isfinite(choice->position_rate_error)) {
    out << YAML::Key << "position_rate_error" << YAML::Value << choice->position_rate_error;
  }
  if (std::isfinite(choice->valve_rate_error)) {
    out << YAML::Key << "valve_rate_error" << YAML::Value << choice->valve_rate_error;
  }
  if (std::isfinite(choice->numerical_error)) {
    out << YAML::Key << "numerical_error" << YAML::Value << choice->numerical_error;
  }
  if (!choice->resolution_limit.empty())
    out << YAML::Key << "resolution_limit" << YAML::Value << choice->resolution_limit;
  out << YAML::Key << "free_run_spool" << YAML::Value
      << (choice->config.valve_model_drives_free_run
              ? "valve_model"
              : (choice->survey.spool_measured ? "measured" : "configured_valve_model"));
  emitResolutionStudy(out, choice->study);
  emitSurvey(out, *choice);
  out << YAML::Key << "seconds_spent" << YAML::Value << choice->seconds_spent;
  const SettingsChoice::Spent& spent = choice->seconds_spent_on;
  out << YAML::Key << "seconds_spent_on" << YAML::Value << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "clock_offsets" << YAML::Value << spent.clock_offsets;
  out << YAML::Key << "valve_model" << YAML::Value << spent.valve_model;
  out << YAML::Key << "resolution_study" << YAML::Value << spent.resolution_study << YAML::EndMap;
  out << YAML::EndMap;
}

// The recording read: its topics, their health, and the offsets between their stamps.
void emitInput(YAML::Emitter& out, const AnalysisInput& input, const OfflineResult& r) {
  static const char* kNames[kInputStreamCount] = {"pressure", "position", "valve"};
  out << YAML::Key << "input" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "bag" << YAML::Value << input.bag;
  out << YAML::Key << "start" << YAML::Value << formatted(FMT_STRING("{:.3f}"), input.start);
  out << YAML::Key << "duration" << YAML::Value << input.duration;
  out << YAML::Key << "messages" << YAML::Value << r.messages;
  out << YAML::Key << "records_unreadable" << YAML::Value << input.records_unreadable;
  out << YAML::Key << "topics" << YAML::Value << YAML::BeginMap;
  for (int s = 0; s < kInputStreamCount; ++s) {
    const StreamHealth& h = r.health[s];
    out << YAML::Key << kNames[s] << YAML::Value << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "topic" << YAML::Value << input.topics[s];
    out << YAML::Key << "messages" << YAML::Value << input.messages[s];
    out << YAML::Key << "rate" << YAML::Value << h.rate();
    out << YAML::Key << "rejected" << YAML::Value
        << (input.unusable[s] + h.non_finite + h.duplicates + h.out_of_order + h.implausible + h.wild_stamps);
    out << YAML::Key << "implausible" << YAML::Value << h.implausible;
    out << YAML::Key << "wild_stamps" << YAML::Value << h.wild_stamps;
    out << YAML::Key << "gaps" << YAML::Value << h.gaps;
    out << YAML::EndMap;
  }
  if (r.oil_temperature) {  // the optional topic, where the recording has it
    const StreamHealth& h = r.oil_temperature->health;
    out << YAML::Key << "oil_temperature" << YAML::Value << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "topic" << YAML::Value << input.oil_temperature_topic;
    out << YAML::Key << "messages" << YAML::Value << input.oil_temperature_messages;
    out << YAML::Key << "rate" << YAML::Value << h.rate();
    out << YAML::Key << "rejected" << YAML::Value
        << (input.oil_temperature_unusable + h.non_finite + h.duplicates + h.out_of_order + h.implausible +
            h.wild_stamps);
    out << YAML::Key << "implausible" << YAML::Value << h.implausible;
    out << YAML::Key << "wild_stamps" << YAML::Value << h.wild_stamps;
    out << YAML::Key << "gaps" << YAML::Value << h.gaps;
    if (std::isfinite(r.oil_temperature->stamp_offset))
      out << YAML::Key << "stamp_offset" << YAML::Value << r.oil_temperature->stamp_offset;
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  out << YAML::Key << "time_base_restarts" << YAML::Value << r.restarts;
  out << YAML::Key << "joint_name" << YAML::Value
      << (input.joint_name.empty() ? "(default)" : input.joint_name);
  // Where the velocity came from: the topic, or the positions (VelocityFromPosition).
  out << YAML::Key << "velocity" << YAML::Value
      << (r.derived_velocity_samples > 0 ? "derived from the position" : "measured");
  out << YAML::Key << "topic_delays" << YAML::Value << YAML::Flow << YAML::BeginMap;
  for (int s = 0; s < kInputStreamCount; ++s)
    out << YAML::Key << kNames[s] << YAML::Value << r.topic_delays[s];
  out << YAML::EndMap;
  out << YAML::Key << "topic_delays_source" << YAML::Value << r.topic_delays_source;
  if (r.delay_estimate && r.delay_estimate->valid) {
    out << YAML::Key << "topic_delays_estimated" << YAML::Value << YAML::Flow << YAML::BeginMap;
    for (int s = 0; s < kInputStreamCount; ++s)
      out << YAML::Key << kNames[s] << YAML::Value << r.delay_estimate->delays[s];
    out << YAML::EndMap;
    out << YAML::Key << "topic_delay_resolution" << YAML::Value << YAML::Flow << YAML::BeginMap;
    for (int s = 0; s < kInputStreamCount; ++s)
      out << YAML::Key << kNames[s] << YAML::Value << r.delay_estimate->resolution[s];
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
}

// The identified model, and its refinement by the free run.
void emitModel(YAML::Emitter& out, const IdentificationConfig& config, const OfflineResult& r) {
  out << YAML::Key << "model" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "effects" << YAML::Value << YAML::Flow << r.effects;
  out << YAML::Key << "regression_form" << YAML::Value << regressionFormName(config.regression_form);
  out << YAML::Key << "valve_model" << YAML::Value << r.valve_model_source;
  // Only what was computed: no initial values shown as estimates, no 0 for an error that was not measured.
  out << YAML::Key << "parameters" << YAML::Value;
  if (r.model.updates > 0) {
    emitParameters(out, r.model.parameters, r.uncertainty);
  } else {
    emitParameters(out, {});
  }
  if (r.output_error) {
    // The parameters are the equation-error fit's, refined by the free run's error where that fell.
    out << YAML::Key << "refined_by_free_run" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "used" << YAML::Value << r.output_error->improved;
    out << YAML::Key << "free_run_error_before" << YAML::Value << r.output_error->start_rms;
    out << YAML::Key << "free_run_error_after" << YAML::Value << r.output_error->rms;
    out << YAML::Key << "samples" << YAML::Value << r.output_error->samples;
    out << YAML::Key << "message" << YAML::Value << r.output_error->message;
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
}

// The recording's oil temperature, and the parameters carried to the reference temperature.
void emitOilTemperature(YAML::Emitter& out, const OilTemperatureRecord& oil) {
  if (oil.health.accepted == 0) return;
  out << YAML::Key << "oil_temperature" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "unit" << YAML::Value << "degC";
  out << YAML::Key << "mean" << YAML::Value << oil.mean;
  out << YAML::Key << "min" << YAML::Value << oil.lowest;
  out << YAML::Key << "max" << YAML::Value << oil.highest;
  out << YAML::Key << "range" << YAML::Value << oil.highest - oil.lowest;
  // The temperature model.parameters hold at: the analysed grid's mean.
  if (std::isfinite(oil.origin)) out << YAML::Key << "parameters_at" << YAML::Value << oil.origin;
  out << YAML::Key << "share_of_samples" << YAML::Value << oil.grid_share;
  out << YAML::EndMap;
  if (oil.at_reference.empty()) return;
  out << YAML::Key << "reference_temperature" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "temperature" << YAML::Value << oil.reference;
  out << YAML::Key << "unit" << YAML::Value << "degC";
  out << YAML::Key << "from" << YAML::Value << oil.origin;
  out << YAML::Key << "parameters" << YAML::Value << YAML::BeginSeq;
  for (const ParameterAtTemperature& p : oil.at_reference) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << p.name << YAML::Key
        << "value" << YAML::Value << p.value << YAML::Key << "std" << YAML::Value << p.std << YAML::Key
        << "unit" << YAML::Value << p.unit << YAML::Key << "std_parts" << YAML::Value << YAML::BeginMap
        << YAML::Key << "recording" << YAML::Value << p.recording << YAML::Key << "coefficients"
        << YAML::Value << p.coefficients << YAML::EndMap << YAML::Key << "law" << YAML::Value << p.law
        << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::EndMap;
}

// How well the model fits: overall, and by phase and operating region.
void emitFit(YAML::Emitter& out, const OfflineResult& r) {
  out << YAML::Key << "fit" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "samples" << YAML::Value << r.assessment.samples;
  out << YAML::Key << "cycles" << YAML::Value << r.strokes.cycles;
  if (r.thinning.stride > 1) {  // a long recording: the cycles above are every stride-th of cycles_seen
    out << YAML::Key << "thinned" << YAML::Value << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "stride" << YAML::Value << r.thinning.stride;
    out << YAML::Key << "cycles_seen" << YAML::Value << r.thinning.cycles_seen;
    out << YAML::Key << "cycles_kept" << YAML::Value << r.thinning.cycles_kept;
    out << YAML::Key << "samples_read" << YAML::Value << r.grid_samples;
    out << YAML::EndMap;
  }
  if (r.model.updates > 0)
    out << YAML::Key << "equation_error_rms" << YAML::Value << r.model.equation_error_rms;
  if (r.assessment.samples > 0)
    out << YAML::Key << "simulation_error_rms" << YAML::Value << r.assessment.simulation_error_rms;
  emitRegions(out, "by_phase", r.assessment.by_phase, true);
  emitRegions(out, "by_pressure", r.assessment.by_pressure, false);
  emitRegions(out, "by_velocity", r.assessment.by_velocity, false);
  emitRegions(out, "by_opening", r.assessment.by_opening, false);
  out << YAML::Key << "worst_regions" << YAML::Value << r.assessment.worst_regions;
  out << YAML::EndMap;
}

// The library effects tried on held-out cycles, and the staircase of verified additions.
void emitCandidates(YAML::Emitter& out, const EffectRankingResult& ranking) {
  out << YAML::Key << "candidates" << YAML::Value << YAML::BeginSeq;
  for (const auto& c : ranking.candidates) {
    out << YAML::BeginMap;
    out << YAML::Key << "effect" << YAML::Value << c.effect;
    out << YAML::Key << "error_reduction" << YAML::Value << c.error_reduction;
    out << YAML::Key << "verdict" << YAML::Value << verdictName(c.verdict);
    out << YAML::Key << "explanation" << YAML::Value << c.explanation;
    out << YAML::Key << "held_out_cycles" << YAML::Value << c.held_out_cycles;
    out << YAML::Key << "t_statistic" << YAML::Value << c.t_statistic;
    out << YAML::Key << "p_value" << YAML::Value << c.p_value;
    out << YAML::Key << "parameters" << YAML::Value;
    emitParameters(out, c.parameters);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  // The staircase of verified additions; the last entry is the recommended model.
  out << YAML::Key << "steps" << YAML::Value << YAML::BeginSeq;
  for (const auto& step : ranking.steps) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "add" << YAML::Value << step.add;
    out << YAML::Key << "held_out_error_rms" << YAML::Value << step.held_out_error_rms;
    if (!step.together_with.empty()) out << YAML::Key << "together_with" << YAML::Value << step.together_with;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
}

// Formulas proposed for what no library effect explains.
void emitProposals(YAML::Emitter& out, const EffectRankingResult& ranking) {
  out << YAML::Key << "proposals" << YAML::Value << YAML::BeginSeq;
  for (const auto& p : ranking.proposals) {
    out << YAML::BeginMap;
    out << YAML::Key << "expression" << YAML::Value << p.spec();
    out << YAML::Key << "error_reduction" << YAML::Value << p.error_reduction;
    out << YAML::Key << "verdict" << YAML::Value << verdictName(p.verdict);
    out << YAML::Key << "parameters" << YAML::Value;
    emitParameters(out, p.parameters);
    out << YAML::Key << "explanation" << YAML::Value << p.explanation;
    out << YAML::Key << "signal" << YAML::Value << std::string(1, p.signal);
    out << YAML::Key << "kind" << YAML::Value << (p.compliance ? "compliance" : "flow");
    if (std::isfinite(p.breakpoint)) out << YAML::Key << "breakpoint" << YAML::Value << p.breakpoint;
    out << YAML::Key << "held_out_error_rms" << YAML::Value << p.held_out_error_rms;
    out << YAML::Key << "held_out_cycles" << YAML::Value << p.held_out_cycles;
    out << YAML::Key << "t_statistic" << YAML::Value << p.t_statistic;
    out << YAML::Key << "p_value" << YAML::Value << p.p_value;
    if (!p.together_with.empty()) out << YAML::Key << "together_with" << YAML::Value << p.together_with;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
}

// The first step test of the recording (the contract's single entry); the others in step_responses.
void emitStepResponse(YAML::Emitter& out, const std::vector<StepResponse>& step_responses) {
  if (step_responses.empty()) return;
  const StepResponse& s = step_responses.front();
  out << YAML::Key << "step_response" << YAML::Value << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "t63" << YAML::Value << s.t63;
  out << YAML::Key << "final_pressure" << YAML::Value << s.final_pressure;
  out << YAML::Key << "step_voltage" << YAML::Value << s.step_voltage;
  out << YAML::Key << "recommended_max_sampling_time" << YAML::Value << s.recommendedMaxSamplingTime();
  out << YAML::Key << "initial_pressure" << YAML::Value << s.initial_pressure;
  out << YAML::Key << "start" << YAML::Value << YAML::Precision(16) << s.start;
  out << YAML::Key << "steps_found" << YAML::Value << step_responses.size();
  out << YAML::EndMap;
}

// Whether the model explains the measurement, and what is missing.
void emitAdequacy(YAML::Emitter& out, const OfflineResult& r) {
  out << YAML::Key << "adequacy" << YAML::Value << YAML::BeginMap;
  // Held-out errors exist only where the ranking could judge on held-out strokes.
  const bool judged = r.model.updates > 0 && r.strokes.cycles >= EffectRankingOptions().min_held_out_cycles;
  if (judged) {
    out << YAML::Key << "held_out_error_rms" << YAML::Value << r.ranking.base_error_rms;
    out << YAML::Key << "best_error_rms" << YAML::Value << r.ranking.best_error_rms;
  }
  if (r.ranking.noise_rms > 0.0) out << YAML::Key << "noise_rms" << YAML::Value << r.ranking.noise_rms;
  out << YAML::Key << "residual_unexplained" << YAML::Value << r.ranking.residual_unexplained;
  out << YAML::Key << "resolution_limited" << YAML::Value << r.ranking.resolution_limited;
  out << YAML::Key << "conclusion" << YAML::Value << r.ranking.conclusion;
  out << YAML::EndMap;
}

// The valve's frequency response from a sweep in the recording, and the model fitted to it.
void emitValveSweep(YAML::Emitter& out, const RecordedSweep& valve) {
  const ServoValveFit& fit = valve.fit;
  out << YAML::Key << "valve" << YAML::Value << YAML::BeginMap;
  if (fit.success) {
    out << YAML::Key << "natural_frequency" << YAML::Value << fit.parameters.natural_frequency;
    out << YAML::Key << "damping" << YAML::Value << fit.parameters.damping;
    out << YAML::Key << "gain" << YAML::Value << fit.parameters.gain;
    out << YAML::Key << "dead_time" << YAML::Value << fit.parameters.dead_time;
    out << YAML::Key << "natural_frequency_std" << YAML::Value << fit.natural_frequency_std;
    out << YAML::Key << "damping_std" << YAML::Value << fit.damping_std;
    out << YAML::Key << "gain_std" << YAML::Value << fit.gain_std;
    out << YAML::Key << "dead_time_std" << YAML::Value << fit.dead_time_std;
    out << YAML::Key << "magnitude_residual_rms" << YAML::Value << fit.magnitude_residual_rms;
    out << YAML::Key << "phase_residual_rms" << YAML::Value << fit.phase_residual_rms;
  }
  out << YAML::Key << "fit" << YAML::Value << fit.message;
  out << YAML::Key << "points" << YAML::Value << YAML::BeginSeq;
  for (const auto& p : valve.points) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "frequency" << YAML::Value << p.frequency;
    out << YAML::Key << "magnitude" << YAML::Value << p.magnitude;
    out << YAML::Key << "phase" << YAML::Value << p.phase;
    out << YAML::Key << "magnitude_std" << YAML::Value << p.magnitude_std;
    out << YAML::Key << "phase_std" << YAML::Value << p.phase_std;
    out << YAML::Key << "harmonic_distortion" << YAML::Value << p.harmonic_distortion;
    out << YAML::Key << "distorted" << YAML::Value << p.distorted;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::EndMap;
}

// An effect that starts within the recording, and the press cycle it starts in.
void emitOnset(YAML::Emitter& out, const EffectOnset& o) {
  out << YAML::Key << "change_within_recording" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "effect" << YAML::Value << o.effect;
  out << YAML::Key << "parameter" << YAML::Value << o.parameter;
  out << YAML::Key << "unit" << YAML::Value << o.unit;
  out << YAML::Key << "from_cycle" << YAML::Value << o.cycle;
  out << YAML::Key << "from_time" << YAML::Value << o.time;
  out << YAML::Key << "cycle_period" << YAML::Value << o.cycle_period;
  out << YAML::Key << "before" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "value"
      << YAML::Value << o.before << YAML::Key << "std" << YAML::Value << o.before_std << YAML::EndMap;
  out << YAML::Key << "after" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "value"
      << YAML::Value << o.after << YAML::Key << "std" << YAML::Value << o.after_std << YAML::EndMap;
  out << YAML::Key << "t_statistic" << YAML::Value << o.t_statistic;
  out << YAML::Key << "p_value" << YAML::Value << o.p_value;
  out << YAML::Key << "explanation" << YAML::Value << o.explanation;
  out << YAML::EndMap;
}

// The warnings in words (the contract's list) and, in the same order, their codes for tools to match by.
void emitWarnings(YAML::Emitter& out, const std::vector<AnalysisWarning>& warnings) {
  out << YAML::Key << "warnings" << YAML::Value << YAML::BeginSeq;
  for (const AnalysisWarning& w : warnings) out << w.text;
  out << YAML::EndSeq;
  out << YAML::Key << "warning_codes" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (const AnalysisWarning& w : warnings) out << warningCodeName(w.code);
  out << YAML::EndSeq;
}

std::string emitSummary(const AnalysisInput& input, const IdentificationConfig& config,
                        const OfflineResult& r, const std::vector<std::string>& outputs) {
  YAML::Emitter out;
  out.SetDoublePrecision(6);
  out << YAML::BeginMap;
  emitInput(out, input, r);
  emitSettings(out, config, r.settings);
  emitModel(out, config, r);
  if (r.oil_temperature) emitOilTemperature(out, *r.oil_temperature);
  emitFit(out, r);
  emitCandidates(out, r.ranking);
  emitProposals(out, r.ranking);
  emitStepResponse(out, r.step_responses);
  emitAdequacy(out, r);
  if (r.valve) emitValveSweep(out, *r.valve);
  if (r.onset) emitOnset(out, *r.onset);
  // The files this run wrote (each complete: written under a temporary name, renamed when whole).
  out << YAML::Key << "outputs" << YAML::Value << YAML::Flow << outputs;
  emitWarnings(out, r.warnings);
  out << YAML::EndMap;
  return out.c_str();
}

}  // namespace

void writeSummary(const std::string& path, const AnalysisInput& input, const IdentificationConfig& config,
                  const OfflineResult& result, const std::vector<std::string>& outputs) {
  std::string text = emitSummary(input, config, result, outputs);
  if (replaceNonFinite(&text) > 0) {
    OfflineResult flagged = result;
    flagged.warnings.push_back(
        {WarningCode::kNotFinite,
         "some figures could not be computed (not finite) and are written as null (~)"});
    text = emitSummary(input, config, flagged, outputs);
    replaceNonFinite(&text);
  }
  std::ofstream file(path);
  file << "# die_cushion_ident analyze_bag summary (SI units; see README.md)\n" << text << "\n";
  closeChecked(file, path);
}

}  // namespace die_cushion_ident
