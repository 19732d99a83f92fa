#include "die_cushion_ident/core/valve/valve_experiments.h"

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

ValveExperiments::ValveExperiments(const SweepLimits& limits) : sweep_(limits), step_test_(limits) {}

std::string ValveExperiments::refuse(const std::string& what, const std::string& reason, double now) {
  last_refusal_ = what + " refused: " + reason;
  last_refusal_time_ = now;
  return reason;
}

std::string ValveExperiments::startSweep(const SweepRequest& request, double now,
                                         const PlantCondition& plant) {
  if (holdsValve()) return refuse("valve sweep", holder() + " holds the valve; abort it first", now);
  const std::string refusal = sweep_.start(request, now, plant);
  if (!refusal.empty()) return refuse("valve sweep", refusal, now);
  last_started_ = Kind::kSweep;
  return "";
}

std::string ValveExperiments::startStepTest(const StepTestRequest& request, double now,
                                            const PlantCondition& plant) {
  if (holdsValve()) return refuse("step test", holder() + " holds the valve; abort it first", now);
  const std::string refusal = step_test_.start(request, now, plant);
  if (!refusal.empty()) return refuse("step test", refusal, now);
  last_started_ = Kind::kStepTest;
  return "";
}

std::string ValveExperiments::abort(const std::string& reason) {
  switch (running()) {
    case Kind::kSweep:
      sweep_.abort(reason);
      hand_back_pending_ = true;
      noteEnd(Kind::kSweep);
      return formatted("valve sweep aborted; the valve command returns to %g V", sweep_.request().offset);
    case Kind::kStepTest:
      step_test_.abort(reason);
      hand_back_pending_ = true;
      noteEnd(Kind::kStepTest);
      return formatted("step test aborted; the valve command returns to %g V", step_test_.request().offset);
    case Kind::kNone:
      break;
  }
  return "";
}

void ValveExperiments::supervise(double now, const PlantCondition& plant) {
  const Kind before = running();
  sweep_.supervise(now, plant);
  step_test_.supervise(now, plant);
  if (before != Kind::kNone && running() == Kind::kNone) {
    hand_back_pending_ = true;
    noteEnd(before);
  }
}

std::optional<double> ValveExperiments::command(double now) {
  const Kind before = running();
  // Only the experiment started last holds the valve; the other one's hand-back was sent long ago.
  std::optional<double> u = last_started_ == Kind::kSweep      ? sweep_.command(now)
                            : last_started_ == Kind::kStepTest ? step_test_.command(now)
                                                               : std::nullopt;
  if (before != Kind::kNone && running() == Kind::kNone) noteEnd(before);  // it ended on this command
  if (running() == Kind::kNone)
    hand_back_pending_ = false;  // the offset went out (or there was none to send)
  return u;
}

void ValveExperiments::addValveSample(double t, double voltage, double spool) {
  const bool was_running = sweep_.running();
  sweep_.addValveSample(t, voltage, spool);
  if (was_running && !sweep_.running()) {
    hand_back_pending_ = true;
    noteEnd(Kind::kSweep);
  }
}

ValveExperiments::Kind ValveExperiments::running() const {
  if (sweep_.running()) return Kind::kSweep;
  if (step_test_.running()) return Kind::kStepTest;
  return Kind::kNone;
}

std::string ValveExperiments::holder() const {
  const Kind kind = running() != Kind::kNone ? running() : hand_back_pending_ ? last_started_ : Kind::kNone;
  return kind == Kind::kSweep ? "a valve sweep" : kind == Kind::kStepTest ? "a step test" : "";
}

void ValveExperiments::noteEnd(Kind kind) {
  if (kind == Kind::kSweep) {
    last_end_ = sweep_.state() == ValveSweep::State::kAborted ? "valve sweep aborted: " + sweep_.abortReason()
                                                              : "valve sweep finished";
  } else if (kind == Kind::kStepTest) {
    last_end_ = step_test_.state() == ValveStepTest::State::kAborted
                    ? "step test aborted: " + step_test_.abortReason()
                    : "step test finished";
  }
}

}  // namespace die_cushion_ident
