#include "die_cushion_ident/core/monitoring/live_diagnostics.h"

#include <cmath>
#include <limits>

#include "die_cushion_ident/core/adequacy/implausible_parameters.h"
#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

double allInputsSilentFor(const UniformResampler& resampler, double now) {
  double youngest = std::numeric_limits<double>::infinity();
  for (int s = 0; s < kInputStreamCount; ++s) {
    const StreamHealth& h = resampler.health(static_cast<InputStream>(s));
    if (h.received > 0) youngest = std::min(youngest, now - h.last_stamp);
  }
  return youngest;
}

HealthReport inputHealth(const InputState& in) {
  HealthReport r;
  const StreamHealth& h = in.health;
  const double age = in.now - h.last_stamp;
  r.add("topic", in.topic);
  r.add("rate [Hz]", formatted(FMT_STRING("{:.1f}"), h.rate()));
  r.add("received", h.received);
  r.add("rejected", in.rejected);
  r.add("last rejection", in.last_rejection.empty() ? "none" : in.last_rejection);
  r.add("late", h.late);
  r.add("gaps", h.gaps);
  r.add("stamp jitter [ms]", formatted(FMT_STRING("{:.3f}"), h.interval_std * 1e3));
  r.add("longest interval [ms]", formatted(FMT_STRING("{:.1f}"), h.max_interval * 1e3));
  r.add("age of last stamp [s]", formatted(FMT_STRING("{:.3f}"), age));
  r.add("implausible values", h.implausible);
  r.add("wild stamps", h.wild_stamps);
  if (in.new_wild_stamps) {
    r.summary(HealthLevel::kError,
              "stamps " + formatted(FMT_STRING("{:+.3g} s"), h.last_wild_offset) +
                  " off the other topics (its clock jumped): " + std::to_string(h.wild_stamps) +
                  " messages rejected so far; the identification goes on without them");
  } else if (h.received == 0 && in.rejected == 0) {
    r.summary(HealthLevel::kError, "no messages received");
  } else if (h.accepted == 0) {
    r.summary(HealthLevel::kError, "every message rejected: " + in.last_rejection);
  } else if (h.stale) {
    // Silent while the other topics run (judged on stamps, so a processing delay is not staleness).
    r.summary(HealthLevel::kError,
              "stale: silent for " + formatted(FMT_STRING("{:.2f} s"), age) + " while the other inputs run");
  } else if (in.all_inputs_silent_for > kInputSilenceLimit) {
    r.summary(HealthLevel::kError, "no input for " +
                                       formatted(FMT_STRING("{:.2f} s"), in.all_inputs_silent_for) +
                                       " (all three topics silent)");
  } else if (in.stream == InputStream::kValve && !(in.spool_age < 1.0)) {
    r.summary(HealthLevel::kWarn, "spool position not measured (NaN): predicted with the valve model");
  } else if (in.rejected > 0) {
    r.summary(HealthLevel::kWarn,
              std::to_string(in.rejected) + " messages rejected, last: " + in.last_rejection);
  } else {
    r.summary(HealthLevel::kOk, "receiving at " + formatted(FMT_STRING("{:.0f} Hz"), h.rate()));
  }
  return r;
}

HealthReport oilTemperatureHealth(const OilTemperatureState& state) {
  HealthReport r;
  const OilTemperatureInput& in = state.input;
  const StreamHealth& h = in.health();
  const std::uint64_t rejected = h.received - h.accepted;
  const double age = state.now - h.last_stamp;
  const double latest = in.any() ? in.peek(h.last_stamp) : std::numeric_limits<double>::quiet_NaN();
  r.add("topic", state.topic);
  r.add("received", h.received);
  r.add("rejected", rejected);
  r.add("last rejection", state.last_rejection.empty() ? "none" : state.last_rejection);
  r.add("rate [Hz]", formatted(FMT_STRING("{:.2f}"), h.rate()));
  r.add("latest [degC]", in.any() ? formatted(FMT_STRING("{:.2f}"), latest) : std::string("none"));
  r.add("range [degC]", in.any() ? formatted(FMT_STRING("{:.1f}"), in.lowest()) + " ... " +
                                       formatted(FMT_STRING("{:.1f}"), in.highest())
                                 : std::string("none"));
  r.add("implausible values", h.implausible);
  r.add("wild stamps", h.wild_stamps);
  r.add("age of last stamp [s]", in.any() ? formatted(FMT_STRING("{:.1f}"), age) : std::string("none"));
  const bool silent = in.any() && age > in.config().max_age;
  if (h.received == 0) {
    r.summary(state.model_uses_it ? HealthLevel::kWarn : HealthLevel::kOk,
              state.model_uses_it
                  ? "no oil temperature received: the effect oil_temperature cannot act"
                  : "not received (optional): the parameters hold at the oil's unknown temperature");
  } else if (h.accepted == 0) {
    r.summary(HealthLevel::kWarn, "every oil temperature message rejected: " + state.last_rejection);
  } else if (silent) {
    r.summary(HealthLevel::kWarn, "silent for " + formatted(FMT_STRING("{:.1f} s"), age) + " (held " +
                                      formatted(FMT_STRING("{:.3g} s"), in.config().max_age) +
                                      "): the oil's temperature is unknown since");
  } else if (rejected > 0) {
    r.summary(HealthLevel::kWarn,
              std::to_string(rejected) + " messages rejected, last: " + state.last_rejection);
  } else {
    r.summary(HealthLevel::kOk, "oil at " + formatted(FMT_STRING("{:.1f} degC"), latest));
  }
  return r;
}

HealthReport estimatorHealth(const HydraulicModel& model, const HydraulicEstimate& e) {
  HealthReport r;
  r.add("effects", e.effects.empty() ? std::string("none (base model)") : joined(e.effects, ", "));
  r.add("updates", e.updates);
  r.add("steps without excitation", e.skipped_unexcited);
  r.add("steps outside the model's validity", e.skipped_invalid);
  double worst_relative_std = 0.0;
  std::string problem;
  for (const auto& p : e.parameters) {
    r.add(p.name + " [" + p.unit + "]",
          formatted(FMT_STRING("{:.4g}"), p.value) + " +/- " + formatted(FMT_STRING("{:.2g}"), p.std));
    if (problem.empty() && (!std::isfinite(p.value) || !std::isfinite(p.std)))
      problem = p.name + " is not finite";
    if (p.value != 0.0) worst_relative_std = std::max(worst_relative_std, std::abs(p.std / p.value));
  }
  r.add("largest relative std", formatted(FMT_STRING("{:.3f}"), worst_relative_std));
  std::vector<std::string> uncertain;
  if (problem.empty() && e.updates >= kUpdatesBeforeJudgement) {
    const auto implausible = implausibleParameters(model, e, kImplausibleSigmas, &uncertain);
    if (!implausible.empty()) problem = implausible.front();
  }
  if (!problem.empty()) {
    r.summary(HealthLevel::kError, "implausible estimate: " + problem);
  } else if (e.updates < kUpdatesBeforeJudgement) {
    r.summary(HealthLevel::kWarn,
              "waiting for excitation (" + std::to_string(e.updates) + " updates; the press must stroke)");
  } else if (!uncertain.empty()) {
    r.summary(HealthLevel::kWarn, "not pinned down yet: " + uncertain.front());
  } else if (worst_relative_std > kConvergedRelativeStd) {
    r.summary(HealthLevel::kWarn, "converging: a parameter still has " +
                                      formatted(FMT_STRING("{:.0f} %"), 100 * worst_relative_std) +
                                      " relative std");
  } else {
    r.summary(HealthLevel::kOk, "converged");
  }
  return r;
}

HealthReport valveHealth(const ValveSweep& sweep, const ServoValveParameters& v,
                         const ServoValveFit& last_sweep, const ServoValveFit& f) {
  HealthReport r;
  r.add("sweep", sweepStateName(sweep.state()));
  r.add("model used for spool prediction", formatted(FMT_STRING("{:.1f} Hz"), v.natural_frequency) + ", D " +
                                               formatted(FMT_STRING("{:.2f}"), v.damping) + ", K " +
                                               formatted(FMT_STRING("{:.4g} 1/V"), v.gain) + ", Td " +
                                               formatted(FMT_STRING("{:.2f} ms"), v.dead_time * 1e3));
  if (sweep.running()) {
    r.add("frequency [Hz]", formatted(FMT_STRING("{:.1f}"), sweep.currentFrequency()));
    r.add("progress",
          std::to_string(sweep.currentIndex()) + " of " + std::to_string(sweep.request().frequencies.size()));
    r.summary(HealthLevel::kOk, "sweep running");
    return r;
  }
  if (sweep.state() == ValveSweep::State::kAborted) {
    r.summary(HealthLevel::kWarn, "last sweep aborted: " + sweep.abortReason());
    return r;
  }
  if (sweep.state() == ValveSweep::State::kFinished && !last_sweep.success) {
    r.summary(HealthLevel::kWarn, "last sweep not usable: " + last_sweep.message);
    return r;
  }
  if (!f.success) {
    r.summary(HealthLevel::kOk, "not identified yet (configured model in use)");
    return r;
  }
  r.add("identified natural frequency [Hz]", formatted(FMT_STRING("{:.2f}"), f.parameters.natural_frequency));
  r.add("identified damping", formatted(FMT_STRING("{:.3f}"), f.parameters.damping));
  r.add("identified gain [1/V]", formatted(FMT_STRING("{:.4g}"), f.parameters.gain));
  r.add("identified dead time [ms]", formatted(FMT_STRING("{:.3f}"), f.parameters.dead_time * 1e3));
  r.add("points distorted", static_cast<std::uint64_t>(f.points_rejected));
  if (f.reduced_chi_square > 10.0) {
    r.summary(HealthLevel::kWarn,
              "identified, but the 2nd-order model misses the measured response (chi2/dof " +
                  formatted(FMT_STRING("{:.1f}"), f.reduced_chi_square) + ")");
  } else {
    r.summary(HealthLevel::kOk, "identified by the last sweep and in use");
  }
  return r;
}

HealthReport valveExperimentsHealth(const ValveSupervisor& supervisor, Instant now) {
  HealthReport r;
  const ValveExperiments& experiments = supervisor.experiments();
  const std::string holder = experiments.holder();
  r.add("running", holder.empty() ? "none" : holder);
  r.add("feed-forward", !supervisor.feedForwardEngaged() ? "not engaged"
                        : holder.empty()                 ? "engaged"
                                                         : "paused while " + holder + " holds the valve");
  const PlantCondition plant = supervisor.condition(now);
  const auto age = [](double seconds) {
    return std::isfinite(seconds) ? formatted(FMT_STRING("{:.1f}"), seconds * 1e3)
                                  : std::string("never received");
  };
  r.add("pressure arrived [ms ago]", age(plant.pressure_age));
  r.add("position arrived [ms ago]", age(plant.position_age));
  r.add("valve arrived [ms ago]", age(plant.valve_age));
  r.add("spool arrived [ms ago]", age(plant.spool_age));
  r.add("supervision timeout [ms]",
        formatted(FMT_STRING("{:.1f}"), supervisor.limits().signal_timeout * 1e3));
  r.add("clocks", plant.clock_problem.empty() ? "the stamps agree with the clock" : plant.clock_problem);
  r.add("last refusal", experiments.lastRefusal().empty() ? "none" : experiments.lastRefusal());
  r.add("last ended", experiments.lastEnd().empty() ? "none" : experiments.lastEnd());
  if (const auto& fault = supervisor.lastFault()) {
    r.add("last fault", fault->output + " stopped: " + fault->reason);
    r.add("last fault: safe value after [ms]",
          std::isnan(fault->safe_after) ? std::string("not yet")
                                        : formatted(FMT_STRING("{:.1f}"), fault->safe_after * 1e3));
  }
  const double since_refusal = now.steady - experiments.lastRefusalTime();
  if (!holder.empty()) {
    r.summary(HealthLevel::kOk, holder + " holds the valve");
  } else if (since_refusal >= 0.0 && since_refusal < kRecentRefusal) {
    // A cell controller that asked for an experiment learns here why it did not run.
    r.summary(HealthLevel::kWarn, experiments.lastRefusal());
  } else {
    r.summary(HealthLevel::kOk, "no valve experiment runs");
  }
  return r;
}

HealthReport feedForwardOutputHealth(const ValveSupervisor& supervisor) {
  HealthReport r;
  r.add("output", supervisor.feedForwardState());
  r.add("last voltage [V]", formatted(FMT_STRING("{:.3f}"), supervisor.feedForwardOutput()));
  r.add("switched", supervisor.feedForwardEnabled() ? "on" : "off (~enable_feed_forward)");
  return r;
}

HealthReport adequacyHealth(const LiveModelMonitor& m, double equation_error_rms, double warn_error,
                            double error_error) {
  HealthReport r;
  const double rms = m.simulationErrorRms();
  r.add("simulation error rms [bar]", formatted(FMT_STRING("{:.2f}"), rms * 1e-5));
  r.add("equation error rms [bar/s]", formatted(FMT_STRING("{:.1f}"), equation_error_rms * 1e-5));
  int worst = 0;
  for (int i = 0; i < kStrokePhaseCount; ++i) {
    const auto phase = static_cast<StrokePhase>(i);
    r.add(std::string("simulation error rms in ") + strokePhaseName(phase) + " [bar]",
          formatted(FMT_STRING("{:.2f}"), m.phaseErrorRms(phase) * 1e-5));
    if (m.phaseErrorRms(phase) > m.phaseErrorRms(static_cast<StrokePhase>(worst))) worst = i;
  }
  std::string where = std::string("worst in ") + strokePhaseName(static_cast<StrokePhase>(worst));
  if (std::isfinite(m.lastRankingSeconds())) {
    r.add("effect ranking duration", formatted(FMT_STRING("{:.3f} s (own thread)"), m.lastRankingSeconds()));
  }
  if (std::isfinite(m.changePoint().lastCheckSeconds())) {
    r.add("plant change check duration",
          formatted(FMT_STRING("{:.3f} s per press cycle (own thread)"), m.changePoint().lastCheckSeconds()));
  }
  if (const auto& change = m.changePoint().onset()) r.add("last plant change", change->onset.explanation);
  if (const LiveOnset* change = m.changeWithinWindow()) {
    where += "; the plant changed: " + change->onset.effect +
             formatted(FMT_STRING(" from press cycle {} on"), change->onset.cycle);
  }
  if (const auto& ranking = m.ranking()) {
    r.add("effect ranking", ranking->conclusion);
    for (const auto& c : ranking->candidates) {
      r.add("candidate " + c.effect,
            verdictName(c.verdict) + std::string(", ") +
                formatted(FMT_STRING("{:.0f} % less error"), 100 * c.error_reduction));
    }
    if (!ranking->candidates.empty() && ranking->candidates.front().verdict == Verdict::kMissing) {
      where += "; suspected missing effect: " + ranking->candidates.front().effect;
    } else if (!ranking->proposals.empty() && ranking->proposals.front().verdict == Verdict::kMissing) {
      where += "; proposed formula: " + ranking->proposals.front().spec();
    } else if (ranking->residual_unexplained) {
      where += "; not explained by the effect library: consider a custom effect";
    }
  }
  if (m.comparedSamples() < LiveModelMonitor::kSamplesBeforeVerdict) {
    std::string why;
    if (!m.estimatorStarted()) {
      why = "the estimator has " + std::to_string(m.identifierUpdates()) + " of " +
            std::to_string(LiveModelMonitor::kUpdatesBeforeComparison) + " updates (the press must stroke)";
    } else if (m.comparisonBlocker()[0] != '\0') {
      why = std::string("the model cannot run: ") + m.comparisonBlocker();
    } else {
      why = std::to_string(m.comparedSamples()) + " of " +
            std::to_string(LiveModelMonitor::kSamplesBeforeVerdict) + " samples compared";
    }
    r.add("why no comparison yet", why);
    r.summary(HealthLevel::kOk, "not enough data yet: " + why);
  } else if (rms > error_error || rms > warn_error) {
    r.summary(rms > error_error ? HealthLevel::kError : HealthLevel::kWarn,
              "the model misses the pressure by " + formatted(FMT_STRING("{:.1f} bar"), rms * 1e-5) +
                  " rms, " + where);
  } else {
    r.summary(HealthLevel::kOk, "the model follows the pressure within " +
                                    formatted(FMT_STRING("{:.1f} bar"), rms * 1e-5) + " rms");
  }
  return r;
}

HealthReport timingHealth(const TimingState& t) {
  HealthReport r;
  for (int s = 0; s < kInputStreamCount; ++s) {
    r.add(std::string("delay of ") + inputStreamName(static_cast<InputStream>(s)) + " stamps [ms]",
          formatted(FMT_STRING("{:+.2f}"), t.applied_delays[s] * 1e3));
  }
  r.add("joint", t.joint_name.empty() ? std::string("(default)") : t.joint_name);
  r.add("velocity derived from position [samples]", t.derived_velocity_samples);
  r.add("latency of the velocity stage [ms]", formatted(FMT_STRING("{:.1f}"), t.velocity_delay * 1e3));
  r.add("time base restarts", t.time_base_restarts);
  if (!t.joint_ambiguity.empty()) {
    r.summary(HealthLevel::kWarn, t.joint_ambiguity);
    return r;
  }
  if (t.time_base_restarts > 0 && t.since_restart < kRestartWarnFor) {
    r.summary(
        HealthLevel::kWarn,
        formatted(
            FMT_STRING(
                "the stamps jumped back {:.1f} s ago (rosbag play --loop, or a driver restarted): the "
                "identification, the model comparison and the ranking started over from the initial values "
                "({:.0f} restarts so far)"),
            t.since_restart, static_cast<double>(t.time_base_restarts)));
    return r;
  }
  if (t.delays_configured && !t.estimate) {
    r.summary(HealthLevel::kOk, "topic delays configured (~topic_delays)");
    return r;
  }
  if (!t.estimate) {
    r.summary(HealthLevel::kOk,
              "clock offsets between the topics not estimated yet (needs strokes in the ranking window)");
    return r;
  }
  double largest = 0.0;
  for (double d : t.estimate->delays) largest = std::max(largest, std::abs(d));
  r.add("estimated position offset [ms]", formatted(FMT_STRING("{:+.2f}"), t.estimate->delays[1] * 1e3));
  r.add("estimated valve offset [ms]", formatted(FMT_STRING("{:+.2f}"), t.estimate->delays[2] * 1e3));
  if (t.estimate->valve_model_timing > 0.0) {
    // Without a measured spool the valve's offset also holds the default valve model's timing error.
    r.add("valve offset uncertain by the valve model's timing [ms]",
          formatted(FMT_STRING("+-{:.2f}"), t.estimate->valve_model_timing * 1e3));
  }
  const double valve = std::abs(t.estimate->delays[2]);
  if (valve > kLargeTopicDelay && valve >= largest && t.estimate->valve_model_timing > 0.0) {
    r.summary(HealthLevel::kWarn, valveTimingWarning(t.estimate->delays[2], true));
  } else if (largest > kLargeTopicDelay) {
    r.summary(HealthLevel::kWarn,
              "topics stamped by different clocks: up to " +
                  formatted(FMT_STRING("{:.1f} ms"), largest * 1e3) +
                  " apart (estimated and corrected); stamp at the measurement or set ~topic_delays");
  } else {
    r.summary(HealthLevel::kOk,
              "topics in step (largest offset " + formatted(FMT_STRING("{:.2f} ms"), largest * 1e3) + ")");
  }
  return r;
}

HealthReport stepTestHealth(const std::optional<StepResponse>& response, const std::string& status,
                            bool failed, double sample_period) {
  HealthReport r;
  if (!response) {
    r.summary(failed ? HealthLevel::kWarn : HealthLevel::kOk, status);
    return r;
  }
  const StepResponse& s = *response;
  const bool too_slow = sample_period > s.recommendedMaxSamplingTime();
  r.summary(
      too_slow ? HealthLevel::kWarn : HealthLevel::kOk,
      too_slow
          ? formatted(FMT_STRING("sample_period {:.4g} s exceeds 0.1 t63"), sample_period) +
                formatted(FMT_STRING(" = {:.4g} s: the identification cannot resolve the pressure build-up"),
                          s.recommendedMaxSamplingTime())
          : status);
  r.add("t63 [s]", formatted(FMT_STRING("{:g}"), s.t63));
  r.add("recommended max sampling time [s]", formatted(FMT_STRING("{:g}"), s.recommendedMaxSamplingTime()));
  r.add("step voltage [V]", formatted(FMT_STRING("{:g}"), s.step_voltage));
  r.add("initial pressure [bar]", formatted(FMT_STRING("{:g}"), s.initial_pressure * 1e-5));
  r.add("final pressure [bar]", formatted(FMT_STRING("{:g}"), s.final_pressure * 1e-5));
  r.add("last test", status);
  return r;
}

}  // namespace die_cushion_ident
