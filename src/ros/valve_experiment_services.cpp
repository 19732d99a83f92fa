#include "valve_experiment_services.h"

#include <cmath>
#include <utility>

#include "diagnostic_fill.h"
#include "die_cushion_ident/FrequencyResponse.h"
#include "die_cushion_ident/ValveModel.h"
#include "die_cushion_ident/ValveSignal.h"
#include "die_cushion_ident/core/monitoring/live_diagnostics.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "message_conversions.h"

namespace die_cushion_ident {

ValveExperimentServices::ValveExperimentServices(ros::NodeHandle nh, ros::NodeHandle pnh,
                                                 const SweepLimits& limits, double command_hold,
                                                 std::mutex& mutex, LiveIdentification& live,
                                                 const PlantSignals& signals,
                                                 std::function<bool()> feed_forward_engaged)
    : nh_(nh),
      pnh_(pnh),
      limits_(limits),
      mutex_(mutex),
      live_(live),
      signals_(signals),
      feed_forward_engaged_(std::move(feed_forward_engaged)),
      experiments_(limits) {
  experiments_.setCommandHold(command_hold);
  command_pub_ = nh_.advertise<ValveSignal>("valve_command", 10);
  response_pub_ = pnh_.advertise<FrequencyResponse>("frequency_response", 1, true);
  valve_model_pub_ = pnh_.advertise<ValveModel>("valve_model", 1, true);
  start_srv_ = pnh_.advertiseService("start_sweep", &ValveExperimentServices::startSweep, this);
  abort_srv_ = pnh_.advertiseService("abort_sweep", &ValveExperimentServices::abortSweep, this);
  step_srv_ = pnh_.advertiseService("start_step_test", &ValveExperimentServices::startStepTest, this);
}

ValveExperimentServices::~ValveExperimentServices() {
  std::lock_guard<std::mutex> lock(mutex_);
  experiments_.abort("shutdown");
  if (const auto u = experiments_.command(ros::Time::now().toSec())) publishCommand(*u);
}

void ValveExperimentServices::addDiagnostics(diagnostic_updater::Updater& updater) {
  updater.add("valve model", [this](diagnostic_updater::DiagnosticStatusWrapper& status) {
    std::lock_guard<std::mutex> lock(mutex_);
    fill(status, valveHealth(experiments_.sweep(), live_.config().valve, last_valve_fit_));
  });
  updater.add("step test", [this](diagnostic_updater::DiagnosticStatusWrapper& status) {
    std::lock_guard<std::mutex> lock(mutex_);
    fill(status, stepTestHealth(last_step_response_, step_status_, step_failed_,
                                live_.config().resampler.sample_period));
  });
  updater.add("valve experiments", [this](diagnostic_updater::DiagnosticStatusWrapper& status) {
    std::lock_guard<std::mutex> lock(mutex_);
    fill(status, valveExperimentsHealth(experiments_, feed_forward_engaged_(), ros::Time::now().toSec()));
  });
}

void ValveExperimentServices::onValveMessage(double stamp, double voltage, double spool) {
  if (experiments_.running() != ValveExperiments::Kind::kSweep) return;
  experiments_.addValveSample(stamp, voltage, spool);
  if (experiments_.sweep().points().size() != published_points_) publishFrequencyResponse();
  if (!experiments_.sweep().running()) finishSweep();
}

// ---- valve sweep ----

bool ValveExperimentServices::startSweep(StartSweep::Request& req, StartSweep::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  SweepRequest request;
  if (!req.frequencies.empty()) request.frequencies = req.frequencies;
  if (req.amplitude != 0.0) request.amplitude = req.amplitude;
  request.offset = req.offset;
  if (req.settle_periods != 0.0) request.settle_periods = req.settle_periods;
  if (req.integration_periods != 0.0) request.integration_periods = req.integration_periods;
  const double now = ros::Time::now().toSec();
  const std::string refusal = experiments_.startSweep(request, now, signals_.at(now));
  res.success = refusal.empty();
  if (!res.success) {
    res.message = "sweep refused: " + refusal;
    ROS_WARN("die_cushion_ident: %s", res.message.c_str());
    return true;
  }
  res.expected_duration = experiments_.sweep().request().totalDuration();
  res.message = "sweep started: " + std::to_string(request.frequencies.size()) + " frequencies, about " +
                formatted("%.1f", res.expected_duration) + " s";
  sweep_reported_ = false;
  published_points_ = 0;
  startTimer();
  ROS_INFO("die_cushion_ident: %s", res.message.c_str());
  return true;
}

bool ValveExperimentServices::abortSweep(AbortSweep::Request&, AbortSweep::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  // Whichever experiment holds the valve: the sweep or the step test.
  res.message = experiments_.abort("aborted by request (~abort_sweep)");
  res.success = !res.message.empty();
  if (!res.success) res.message = "no sweep or step test is running";
  return true;
}

void ValveExperimentServices::publishFrequencyResponse() {
  const ValveSweep& sweep = experiments_.sweep();
  published_points_ = sweep.points().size();
  response_pub_.publish(
      toFrequencyResponseMsg(sweep.points(), sweep.fit(), sweepStateName(sweep.state()), ros::Time::now()));
}

void ValveExperimentServices::finishSweep() {
  if (sweep_reported_) return;
  sweep_reported_ = true;
  publishFrequencyResponse();
  const ValveSweep& sweep = experiments_.sweep();
  const ServoValveFit& fit = sweep.fit();
  ValveModel msg = toValveModelMsg(fit, ros::Time::now());
  if (sweep.state() == ValveSweep::State::kAborted) {
    msg.success = false;
    msg.message = "sweep aborted: " + sweep.abortReason();
    ROS_WARN("die_cushion_ident: %s", msg.message.c_str());
  } else if (fit.success) {
    last_valve_fit_ = fit;
    live_.setValveModel(fit.parameters);
    ROS_INFO("die_cushion_ident: valve identified: %.1f Hz, damping %.2f, gain %.4f 1/V, dead time %.2f ms",
             fit.parameters.natural_frequency, fit.parameters.damping, fit.parameters.gain,
             fit.parameters.dead_time * 1e3);
  } else {
    ROS_WARN("die_cushion_ident: valve fit failed: %s", fit.message.c_str());
  }
  valve_model_pub_.publish(msg);
}

// ---- step test (paper, section 5.2) ----

bool ValveExperimentServices::startStepTest(StartStepTest::Request& req, StartStepTest::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  StepTestRequest request;
  request.offset = req.offset;
  request.step = req.step;
  request.duration = req.duration;
  request.settle = req.settle;
  const double now = ros::Time::now().toSec();
  const std::string refusal = experiments_.startStepTest(request, now, signals_.at(now));
  const ValveStepTest& test = experiments_.stepTest();
  res.success = refusal.empty();
  res.message = res.success ? formatted("step test started: %g V", test.request().step) +
                                  formatted(" from %g V", test.request().offset)
                            : "step test refused: " + refusal;
  if (!res.success) {
    ROS_WARN("die_cushion_ident: %s", res.message.c_str());
    return true;
  }
  step_status_ = "running";
  step_failed_ = false;
  step_test_reported_ = false;
  startTimer();
  ROS_INFO("die_cushion_ident: %s", res.message.c_str());
  return true;
}

void ValveExperimentServices::stepTestEnded() {
  if (step_test_reported_ || experiments_.stepTest().running()) return;
  step_test_reported_ = true;
  const ValveStepTest& test = experiments_.stepTest();
  if (test.state() == ValveStepTest::State::kAborted) {
    step_failed_ = true;
    step_status_ = "aborted: " + test.abortReason();
    ROS_WARN("die_cushion_ident: step test %s", step_status_.c_str());
  } else {
    step_status_ = "finished; timing the pressure's answer";
    step_analysis_due_ = test.stepTime() + test.request().duration + 0.2;
  }
}

void ValveExperimentServices::onGridSample(double t) {
  if (!(t >= step_analysis_due_)) return;
  step_analysis_due_ = std::numeric_limits<double>::infinity();
  const std::vector<GridSample> grid(live_.monitor().window().begin(), live_.monitor().window().end());
  for (const StepResponse& r : findStepResponses(grid)) {
    if (std::abs(r.start - experiments_.stepTest().stepTime()) > 0.05) continue;
    last_step_response_ = r;
    step_failed_ = false;
    step_status_ = formatted("t63 %.1f ms", r.t63 * 1e3);
    ROS_INFO("die_cushion_ident: step test: %.1f -> %.1f bar, t63 %.1f ms (sample_period at most %.2f ms)",
             r.initial_pressure * 1e-5, r.final_pressure * 1e-5, r.t63 * 1e3,
             r.recommendedMaxSamplingTime() * 1e3);
    return;
  }
  step_failed_ = true;
  step_status_ =
      "the pressure's answer could not be timed (it did not settle, changed less than 2 bar, or "
      "the cushion moved)";
}

// ---- the command ----

void ValveExperimentServices::startTimer() {
  // Commands at twice the valve rate, so that every valve update finds a fresh one despite scheduling jitter.
  timer_ =
      nh_.createTimer(ros::Duration(0.5 * limits_.command_period), &ValveExperimentServices::onTimer, this);
}

void ValveExperimentServices::onTimer(const ros::TimerEvent&) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double now = ros::Time::now().toSec();
  experiments_.supervise(now, signals_.at(now));
  if (const auto u = experiments_.command(now)) publishCommand(*u);
  if (experiments_.running() != ValveExperiments::Kind::kNone) return;
  if (!sweep_reported_) finishSweep();
  stepTestEnded();
  if (!experiments_.holdsValve()) timer_.stop();  // the offset has been sent
}

void ValveExperimentServices::publishCommand(double voltage) {
  ValveSignal msg;
  msg.header.stamp = ros::Time::now();
  msg.voltage = voltage;
  msg.spool_position = std::numeric_limits<double>::quiet_NaN();
  command_pub_.publish(msg);
}

}  // namespace die_cushion_ident
