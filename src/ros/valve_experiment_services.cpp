#include "valve_experiment_services.h"

#include <cmath>
#include <utility>

#include "diagnostic_fill.h"
#include "die_cushion_ident/FrequencyResponse.h"
#include "die_cushion_ident/ValveModel.h"
#include "die_cushion_ident/core/monitoring/live_diagnostics.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "message_conversions.h"

namespace die_cushion_ident {

ValveExperimentServices::ValveExperimentServices(ros::NodeHandle pnh, std::mutex& mutex,
                                                 LiveIdentification& live, SupervisedValve& valve)
    : pnh_(pnh), mutex_(mutex), live_(live), valve_(valve) {
  response_pub_ = pnh_.advertise<FrequencyResponse>("frequency_response", 1, true);
  valve_model_pub_ = pnh_.advertise<ValveModel>("valve_model", 1, true);
  start_srv_ = pnh_.advertiseService("start_sweep", &ValveExperimentServices::startSweep, this);
  abort_srv_ = pnh_.advertiseService("abort_sweep", &ValveExperimentServices::abortSweep, this);
  step_srv_ = pnh_.advertiseService("start_step_test", &ValveExperimentServices::startStepTest, this);
}

void ValveExperimentServices::addDiagnostics(diagnostic_updater::Updater& updater) {
  updater.add("valve model", [this](diagnostic_updater::DiagnosticStatusWrapper& status) {
    std::lock_guard<std::mutex> lock(mutex_);
    poll();
    valve_.locked([&](const ValveSupervisor& s) {
      fill(status,
           valveHealth(s.experiments().sweep(), live_.config().valve, last_sweep_fit_, last_valve_fit_));
    });
  });
  updater.add("step test", [this](diagnostic_updater::DiagnosticStatusWrapper& status) {
    std::lock_guard<std::mutex> lock(mutex_);
    fill(status, stepTestHealth(last_step_response_, step_status_, step_failed_,
                                live_.config().resampler.sample_period));
  });
  updater.add("valve experiments", [this](diagnostic_updater::DiagnosticStatusWrapper& status) {
    valve_.locked(
        [&](const ValveSupervisor& s) { fill(status, valveExperimentsHealth(s, SupervisedValve::now())); });
  });
}

void ValveExperimentServices::poll() {
  // What changed, copied out under the supervisor's lock; published and handed to the identification after
  // it, so that the watchdog never waits for them.
  std::optional<SweepReport> sweep;
  std::optional<ValveStepTest> ended_step_test;
  valve_.locked([&](const ValveSupervisor& s) {
    const ValveSweep& current = s.experiments().sweep();
    if (!sweep_reported_ && (current.points().size() != published_points_ || !current.running())) {
      sweep = SweepReport{current.points(), current.state(), current.abortReason()};
    }
    if (!step_test_reported_ && !s.experiments().stepTest().running())
      ended_step_test = s.experiments().stepTest();
  });
  if (sweep) {
    if (sweep->points.size() != published_points_) publishFrequencyResponse(*sweep, ServoValveFit());
    if (sweep->state != ValveSweep::State::kRunning) finishSweep(*sweep);
  }
  if (ended_step_test) stepTestEnded(*ended_step_test);
}

// ---- valve sweep ----

bool ValveExperimentServices::startSweep(StartSweep::Request& req, StartSweep::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  poll();  // the previous sweep's results, before a new one replaces them
  SweepRequest request;
  if (!req.frequencies.empty()) request.frequencies = req.frequencies;
  if (req.amplitude != 0.0) request.amplitude = req.amplitude;
  request.offset = req.offset;
  if (req.settle_periods != 0.0) request.settle_periods = req.settle_periods;
  if (req.integration_periods != 0.0) request.integration_periods = req.integration_periods;
  const std::string refusal = valve_.startSweep(request);
  res.success = refusal.empty();
  if (!res.success) {
    res.message = "sweep refused: " + refusal;
    ROS_WARN("die_cushion_ident: %s", res.message.c_str());
    return true;
  }
  res.expected_duration = request.totalDuration();
  res.message = "sweep started: " + std::to_string(request.frequencies.size()) + " frequencies, about " +
                formatted(FMT_STRING("{:.1f}"), res.expected_duration) + " s";
  sweep_reported_ = false;
  published_points_ = 0;
  ROS_INFO("die_cushion_ident: %s", res.message.c_str());
  return true;
}

bool ValveExperimentServices::abortSweep(AbortSweep::Request&, AbortSweep::Response& res) {
  // Whichever experiment holds the valve: the sweep or the step test.
  res.message = valve_.locked([](ValveSupervisor& s) {
    return s.abortExperiment("aborted by request (~abort_sweep)", SupervisedValve::now());
  });
  res.success = !res.message.empty();
  if (!res.success) res.message = "no sweep or step test is running";
  return true;
}

void ValveExperimentServices::publishFrequencyResponse(const SweepReport& sweep, const ServoValveFit& fit) {
  published_points_ = sweep.points.size();
  response_pub_.publish(toFrequencyResponseMsg(sweep.points, fit, sweepStateName(sweep.state), ros::Time::now()));
}

void ValveExperimentServices::finishSweep(const SweepReport& sweep) {
  sweep_reported_ = true;
  // The model fitted here, outside the supervisor's lock: the valve was handed back before.
  const bool finished = sweep.state == ValveSweep::State::kFinished;
  const ServoValveFit fit = finished ? fitServoValve(sweep.points) : ServoValveFit();
  if (finished) last_sweep_fit_ = fit;
  publishFrequencyResponse(sweep, fit);
  ValveModel msg = toValveModelMsg(fit, ros::Time::now());
  if (sweep.state == ValveSweep::State::kAborted) {
    msg.success = false;
    msg.message = "sweep aborted: " + sweep.abort_reason;
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
  poll();
  StepTestRequest request;
  request.offset = req.offset;
  request.step = req.step;
  request.duration = req.duration;
  request.settle = req.settle;
  const std::string refusal = valve_.startStepTest(request);
  res.success = refusal.empty();
  if (!res.success) {
    res.message = "step test refused: " + refusal;
    ROS_WARN("die_cushion_ident: %s", res.message.c_str());
    return true;
  }
  const StepTestRequest started =
      valve_.locked([](const ValveSupervisor& s) { return s.experiments().stepTest().request(); });
  step_time_ = valve_.locked([](const ValveSupervisor& s) { return s.experiments().stepTest().stepTime(); });
  res.message = formatted(FMT_STRING("step test started: {:g} V"), started.step) +
                formatted(FMT_STRING(" from {:g} V"), started.offset);
  step_status_ = "running";
  step_failed_ = false;
  step_test_reported_ = false;
  ROS_INFO("die_cushion_ident: %s", res.message.c_str());
  return true;
}

void ValveExperimentServices::stepTestEnded(const ValveStepTest& test) {
  step_test_reported_ = true;
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
    if (std::abs(r.start - step_time_) > 0.05) continue;
    last_step_response_ = r;
    step_failed_ = false;
    step_status_ = formatted(FMT_STRING("t63 {:.1f} ms"), r.t63 * 1e3);
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

}  // namespace die_cushion_ident
