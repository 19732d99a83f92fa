#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <cstddef>
#include <functional>
#include <limits>
#include <mutex>
#include <optional>
#include <string>

#include "die_cushion_ident/AbortSweep.h"
#include "die_cushion_ident/StartStepTest.h"
#include "die_cushion_ident/StartSweep.h"
#include "die_cushion_ident/core/monitoring/live_identification.h"
#include "die_cushion_ident/core/valve/plant_signals.h"
#include "die_cushion_ident/core/valve/step_response.h"
#include "die_cushion_ident/core/valve/valve_experiments.h"

namespace die_cushion_ident {

/// The valve experiments' ROS face: the services ~start_sweep, ~abort_sweep and ~start_step_test, the
/// command on valve_command while an experiment holds the valve, the sweep's ~frequency_response and
/// ~valve_model, the step test's timing of the pressure's answer, and the diagnostics "valve model",
/// "step test" and "valve experiments". The experiments themselves, their interlocks and the hand-back are
/// ValveExperiments's; this class wires them to topics, services and a timer. It shares the node's mutex:
/// its callbacks lock it, the node calls the on... methods with it held.
class ValveExperimentServices {
 public:
  ValveExperimentServices(ros::NodeHandle nh, ros::NodeHandle pnh, const SweepLimits& limits,
                          double command_hold, std::mutex& mutex, LiveIdentification& live,
                          const PlantSignals& signals, std::function<bool()> feed_forward_engaged);
  /// Aborts a running experiment ("shutdown") and sends the valve back to its offset.
  ~ValveExperimentServices();

  void addDiagnostics(diagnostic_updater::Updater& updater);
  /// A valve message (the mutex held): the sweep's samples.
  void onValveMessage(double stamp, double voltage, double spool);
  /// A grid sample (the mutex held): times the step test's answer once the grid holds it.
  void onGridSample(double t);

  /// Who holds the valve ("" when nobody; the feed-forward pauses otherwise). The mutex held.
  std::string holder() const { return experiments_.holder(); }
  /// True while an experiment commands the valve. The mutex held.
  bool holdsValve() const { return experiments_.holdsValve(); }
  /// The last sweep's successful valve fit, or nullptr. The mutex held.
  const ServoValveParameters* sweptValve() const {
    return last_valve_fit_.success ? &last_valve_fit_.parameters : nullptr;
  }

 private:
  bool startSweep(StartSweep::Request& request, StartSweep::Response& response);
  bool abortSweep(AbortSweep::Request& request, AbortSweep::Response& response);
  bool startStepTest(StartStepTest::Request& request, StartStepTest::Response& response);
  /// Supervises the experiment that holds the valve and sends its command; stops once it handed back.
  void onTimer(const ros::TimerEvent&);
  void startTimer();
  void publishCommand(double voltage);
  void publishFrequencyResponse();
  void finishSweep();
  /// The step test's end: its status, and when to time the pressure's answer.
  void stepTestEnded();

  ros::NodeHandle nh_, pnh_;
  SweepLimits limits_;
  std::mutex& mutex_;
  LiveIdentification& live_;
  const PlantSignals& signals_;
  std::function<bool()> feed_forward_engaged_;

  // The sweep and the step test, one at a time, behind the same interlocks.
  ValveExperiments experiments_;
  ros::Timer timer_;  // runs while an experiment holds the valve (until it handed it back)
  ServoValveFit last_valve_fit_;
  bool sweep_reported_ = false;  // the ended sweep's results have been published
  std::size_t published_points_ = 0;
  bool step_test_reported_ = true;                                      // the ended step test's status is set
  double step_analysis_due_ = std::numeric_limits<double>::infinity();  // grid time to time the answer
  std::optional<StepResponse> last_step_response_;
  std::string step_status_ = "no step test run (~start_step_test)";
  bool step_failed_ = false;  // aborted, or its answer could not be timed

  ros::Publisher command_pub_, response_pub_, valve_model_pub_;
  ros::ServiceServer start_srv_, abort_srv_, step_srv_;
};

}  // namespace die_cushion_ident
