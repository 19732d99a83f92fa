#include "die_cushion_ident/core/valve/valve_experiments.h"

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {

const char* nameOf(ValveExperiments::Kind kind) {
  return kind == ValveExperiments::Kind::kSweep ? "valve sweep" : "step test";
}

}  // namespace

ValveExperiments::ValveExperiments(const SweepLimits& limits) : sweep_(limits), step_test_(limits) {}

std::string ValveExperiments::refuse(Kind kind, const std::string& reason, Instant now) {
  last_refusal_ = std::string(nameOf(kind)) + " refused: " + reason;
  last_refusal_time_ = now.steady;
  return reason;
}

std::string ValveExperiments::startSweep(const SweepRequest& request, Instant now,
                                         const PlantCondition& plant) {
  if (holdsValve()) return refuse(Kind::kSweep, holder() + " holds the valve; abort it first", now);
  const std::string refusal = sweep_.start(request, now, plant);
  return refusal.empty() ? "" : refuse(Kind::kSweep, refusal, now);
}

std::string ValveExperiments::startStepTest(const StepTestRequest& request, Instant now,
                                            const PlantCondition& plant) {
  if (holdsValve()) return refuse(Kind::kStepTest, holder() + " holds the valve; abort it first", now);
  const std::string refusal = step_test_.start(request, now, plant);
  return refusal.empty() ? "" : refuse(Kind::kStepTest, refusal, now);
}

std::string ValveExperiments::abort(const std::string& reason) {
  const Kind before = running();
  if (before == Kind::kNone) return "";
  double offset = 0.0;
  if (before == Kind::kSweep) {
    sweep_.abort(reason);
    offset = sweep_.request().offset;
  } else {
    step_test_.abort(reason);
    offset = step_test_.request().offset;
  }
  noteEndOf(before);
  return std::string(nameOf(before)) +
         formatted(FMT_STRING(" aborted; the valve command returns to {:g} V"), offset);
}

void ValveExperiments::supervise(Instant now, const PlantCondition& plant) {
  const Kind before = running();
  sweep_.supervise(now, plant);
  step_test_.supervise(now, plant);
  noteEndOf(before);
}

std::optional<double> ValveExperiments::command(double now) {
  const Kind owner = holding();
  if (owner == Kind::kNone) return std::nullopt;
  const Kind before = running();
  // Only the experiment that holds the valve commands it (the other one's hand-back went out long ago).
  const std::optional<double> u = owner == Kind::kSweep ? sweep_.command(now) : step_test_.command(now);
  noteEndOf(before);  // a step test ends on the command that completes it
  return u;
}

void ValveExperiments::addValveSample(double t, double voltage, double spool) {
  const Kind before = running();
  sweep_.addValveSample(t, voltage, spool);
  noteEndOf(before);
}

ValveExperiments::Kind ValveExperiments::running() const {
  if (sweep_.running()) return Kind::kSweep;
  if (step_test_.running()) return Kind::kStepTest;
  return Kind::kNone;
}

ValveExperiments::Kind ValveExperiments::holding() const {
  if (sweep_.running() || sweep_.offsetOwed()) return Kind::kSweep;
  if (step_test_.running() || step_test_.offsetOwed()) return Kind::kStepTest;
  return Kind::kNone;
}

std::string ValveExperiments::holder() const {
  const Kind kind = holding();
  return kind == Kind::kNone ? "" : std::string("a ") + nameOf(kind);
}

void ValveExperiments::noteEndOf(Kind before) {
  if (before == Kind::kNone || running() == before) return;
  const bool aborted = before == Kind::kSweep ? sweep_.state() == ValveSweep::State::kAborted
                                              : step_test_.state() == ValveStepTest::State::kAborted;
  const std::string& reason = before == Kind::kSweep ? sweep_.abortReason() : step_test_.abortReason();
  last_end_ = std::string(nameOf(before)) + (aborted ? " aborted: " + reason : std::string(" finished"));
}

}  // namespace die_cushion_ident
