#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <cstddef>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "die_cushion_ident/AbortSweep.h"
#include "die_cushion_ident/StartStepTest.h"
#include "die_cushion_ident/StartSweep.h"
#include "die_cushion_ident/core/monitoring/live_identification.h"
#include "die_cushion_ident/core/valve/step_response.h"
#include "supervised_valve.h"

namespace die_cushion_ident {

/// The valve experiments' ROS face: the services ~start_sweep, ~abort_sweep and ~start_step_test, the
/// sweep's ~frequency_response and ~valve_model, the step test's timing of the pressure's answer, and the
/// diagnostics "valve model", "step test" and "valve experiments". The experiments, their interlocks, their
/// commands and the hand-back are the SupervisedValve's; this class starts them and reports their results.
/// Its services lock the node's mutex (the sweep's result goes into the identification), then the
/// supervisor's; the node calls the on... methods with its mutex held.
class ValveExperimentServices {
 public:
  ValveExperimentServices(ros::NodeHandle pnh, std::mutex& mutex, LiveIdentification& live,
                          SupervisedValve& valve);

  void addDiagnostics(diagnostic_updater::Updater& updater);
  /// After a valve message or a grid sample (the node's mutex held): publishes new sweep points and an
  /// ended sweep's results, and notes an ended step test.
  void poll();
  /// A grid sample (the node's mutex held): times the step test's answer once the grid holds it.
  void onGridSample(double t);

  /// The last sweep's successful valve fit, or nullptr. The node's mutex held.
  const ServoValveParameters* sweptValve() const {
    return last_valve_fit_.success ? &last_valve_fit_.parameters : nullptr;
  }

 private:
  /// What a sweep's results need, copied out of the supervisor.
  struct SweepReport {
    std::vector<FrequencyResponsePoint> points;
    ValveSweep::State state;
    std::string abort_reason;
  };

  bool startSweep(StartSweep::Request& request, StartSweep::Response& response);
  bool abortSweep(AbortSweep::Request& request, AbortSweep::Response& response);
  bool startStepTest(StartStepTest::Request& request, StartStepTest::Response& response);
  void publishFrequencyResponse(const SweepReport& sweep, const ServoValveFit& fit);
  void finishSweep(const SweepReport& sweep);
  /// The step test's end: its status, and when to time the pressure's answer.
  void stepTestEnded(const ValveStepTest& test);

  ros::NodeHandle pnh_;
  std::mutex& mutex_;
  LiveIdentification& live_;
  SupervisedValve& valve_;

  ServoValveFit last_valve_fit_;  // the last successful sweep's
  ServoValveFit last_sweep_fit_;  // the last finished sweep's, successful or not
  bool sweep_reported_ = true;    // the last sweep's results have been published
  std::size_t published_points_ = 0;
  bool step_test_reported_ = true;                                      // the ended step test's status is set
  double step_time_ = 0.0;                                              // [s] the running step's own time
  double step_analysis_due_ = std::numeric_limits<double>::infinity();  // grid time to time the answer
  std::optional<StepResponse> last_step_response_;
  std::string step_status_ = "no step test run (~start_step_test)";
  bool step_failed_ = false;  // aborted, or its answer could not be timed

  ros::Publisher response_pub_, valve_model_pub_;
  ros::ServiceServer start_srv_, abort_srv_, step_srv_;
};

}  // namespace die_cushion_ident
