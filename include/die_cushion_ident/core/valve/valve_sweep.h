#pragma once

#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "die_cushion_ident/core/valve/frequency_response.h"
#include "die_cushion_ident/core/valve/instant.h"
#include "die_cushion_ident/core/valve/servo_valve_fit.h"

namespace die_cushion_ident {

/// What a user asks for (the ~start_sweep service): a sine of `amplitude` around `offset` at each frequency.
struct SweepRequest {
  std::vector<double> frequencies = defaultFrequencies();  ///< [Hz]
  double amplitude = 0.5;                                  ///< [V] (paper: 0.5 V, 5 % of nominal)
  double offset = 0.0;                                     ///< [V]
  double settle_periods = 3.0;        ///< periods left out before integrating (transient) ...
  double settle_time = 0.05;          ///< [s] ... but at least this long
  double integration_periods = 10.0;  ///< whole periods integrated ...
  double min_integration_time = 0.5;  ///< [s] ... but at least this long (noise averages as 1/sqrt(N))

  /// The paper's 10, 20, ..., 160 Hz.
  static std::vector<double> defaultFrequencies();
  /// Settle plus integration at one frequency [s].
  double durationAt(double frequency) const;
  double totalDuration() const;
};

/// Safety limits of the sweep, set by configuration (not by the requester). Keys are `sweep_<name>`.
struct SweepLimits {
  double max_amplitude = 1.0;        ///< [V]
  double min_voltage = -10.0;        ///< [V] the command never leaves [min_voltage, max_voltage]
  double max_voltage = 10.0;         ///< [V]
  double max_pressure = 80e5;        ///< [Pa] a sweep starts and continues only below
  double max_rest_velocity = 0.005;  ///< [m/s] the cushion counts as at rest below
  /// [s] steady time since an input's last message arrived beyond which it counts as lost: a valve test
  /// aborts and the feed-forward ramps out (the supervision of every output that drives the valve)
  double signal_timeout = 0.05;
  /// [s] an input stamped further than this ahead of or behind the clock it arrives on is not trusted
  /// (drive clocks off the node's, a stopped /clock): no valve test starts or goes on, the feed-forward
  /// ramps out
  double max_clock_offset = 0.1;
  double command_period = 0.001;  ///< [s] valve command rate (paper: 1 ms)
  double max_duration = 300.0;    ///< [s] longest sweep accepted
  double max_distortion = 0.02;   ///< harmonic distortion that flags a point (spool-velocity saturation)
  /// [Pa] a step test aborts above (a step that opens the supply edge raises the pressure towards the
  /// supply: the sweep's bound applies to its start only)
  double step_max_pressure = 250e5;

  /// Highest frequency accepted: a quarter of the command rate (at least 4 commands per period).
  double maxFrequency() const { return 0.25 / command_period; }
  /// Every problem as "sweep_name = value is invalid: allowed ..."; empty when usable.
  std::vector<std::string> validate() const;
};
std::vector<std::string> sweepLimitKeys();
bool setSweepLimit(SweepLimits& limits, const std::string& key, double value);
/// A limit's value by its key; NaN for an unknown key.
double sweepLimitValue(const SweepLimits& limits, const std::string& key);

/// Why a request is not acceptable under the limits ("" when it is).
std::string checkSweepRequest(const SweepRequest& request, const SweepLimits& limits);

/// The cushion's state as the safety logic sees it (PlantSignals). NaN = unknown. The ages are steady time
/// [s] since the signal's last message *arrived*: a dead bus ages every signal whatever the messages' stamps
/// said; infinite for a signal never received.
struct PlantCondition {
  double pressure = std::numeric_limits<double>::quiet_NaN();  ///< [Pa]
  double velocity = std::numeric_limits<double>::quiet_NaN();  ///< [m/s]
  double pressure_age = std::numeric_limits<double>::infinity();
  double position_age = std::numeric_limits<double>::infinity();  ///< the velocity's age
  double valve_age = std::numeric_limits<double>::infinity();     ///< any valve message (the amplifier alive)
  double spool_age = std::numeric_limits<double>::infinity();     ///< a valve message with a measured spool
  /// Why the inputs' stamps cannot be trusted against the clock (a topic stamped beyond
  /// sweep_max_clock_offset ahead of or behind it); empty when they agree.
  std::string clock_problem;
};

/// Why a valve test (`tests`: "sweeps", "step tests") may not start now: the pressure unknown, stale or
/// above sweep_max_pressure, or the cushion not known to be at rest; empty when it may.
std::string atRestRefusal(const PlantCondition& plant, const SweepLimits& limits, const std::string& tests);
/// Why a running valve test must stop: an input lost or off the clock, the pressure above `max_pressure`
/// (named `bound`), or the cushion moving or its velocity unknown; empty while it may go on.
std::string restLostReason(const PlantCondition& plant, const SweepLimits& limits, double max_pressure,
                           const std::string& bound);
/// Why a valve test started at `started` must stop at `now` ("" while it may run): longer than
/// `max_duration` on the steady clock, or on the clock than twice its `expected` duration plus 5 s (a
/// sweep that stopped advancing), or than `max_duration`.
std::string durationExceeded(Instant started, Instant now, double expected, double max_duration);

/// Runs a sine sweep on the valve safely and measures its frequency response point by point.
///
/// Each tick the owner reports the plant's condition (supervise), hands over the valve topic's samples
/// (addValveSample: the voltage in force from the stamp on, and the measured spool) and applies command().
/// Per frequency the sine starts at phase 0; after the settle time, whole periods of command echo and spool
/// are correlated; the next frequency starts once a sample past the window has arrived. On completion the
/// 2nd-order model with dead time is fitted. Any abort (request, a lost or non-finite spool, a lost pressure
/// or position, stamps off the clock, pressure over the limit, a sweep beyond its duration, shutdown) ends
/// the sweep and the next command is the offset.
class ValveSweep {
 public:
  enum class State { kIdle, kRunning, kFinished, kAborted };

  explicit ValveSweep(const SweepLimits& limits);

  /// Starts if the request is valid and the plant is safe; otherwise returns the reason and stays put.
  std::string start(const SweepRequest& request, Instant now, const PlantCondition& plant);
  /// Checks the running sweep's safety conditions and its duration; aborts with a reason when one is
  /// violated.
  void supervise(Instant now, const PlantCondition& plant);
  void addValveSample(double t, double voltage, double spool);
  /// The command to apply at `now` while running; after the sweep ends, the offset exactly once (so the
  /// valve returns to it); otherwise nothing.
  std::optional<double> command(double now);
  /// The sine of the frequency being measured at time `t` (no state change), for a continuous signal
  /// generator between commands; the offset when no frequency is running.
  double commandAt(double t) const;
  /// How long the amplifier holds each command [s] (0 = a continuous command; NaN, the default, = the
  /// command period). The measured response is divided by the hold's response.
  void setCommandHold(double seconds) { command_hold_ = seconds; }
  /// Whether the sweep fits the valve model itself when its last frequency is measured (the default).
  /// Where the sweep runs under a lock that the valve's supervision shares (the node), the fit (tens of ms
  /// for hundreds of frequencies) is the caller's, from points(), after the hand-back went out.
  void setFitOnFinish(bool fit) { fit_on_finish_ = fit; }
  void abort(const std::string& reason);

  State state() const { return state_; }
  bool running() const { return state_ == State::kRunning; }
  /// Ended, and the offset not yet sent: the next command() hands the valve back.
  bool offsetOwed() const { return offset_owed_; }
  const std::string& abortReason() const { return abort_reason_; }
  const SweepRequest& request() const { return request_; }
  /// Index of the frequency being measured and its value [Hz] (progress).
  int currentIndex() const { return index_; }
  double currentFrequency() const;
  /// Points measured so far, by frequency, phases unwrapped.
  const std::vector<FrequencyResponsePoint>& points() const { return points_; }
  /// The model fit once finished (where setFitOnFinish(false): never, the caller fits points()).
  const ServoValveFit& fit() const { return fit_; }

 private:
  void beginFrequency(double now);
  void finishFrequency();
  void end(State state, const std::string& reason);

  SweepLimits limits_;
  SweepRequest request_;
  Instant started_;
  State state_ = State::kIdle;
  std::string abort_reason_;
  int index_ = 0;
  double segment_start_ = 0.0;
  bool segment_pending_ = false;  // the next command() begins the next frequency
  std::unique_ptr<FrequencyPointEstimator> estimator_;
  std::vector<FrequencyResponsePoint> points_;
  ServoValveFit fit_;
  bool offset_owed_ = false;
  double command_hold_ = std::numeric_limits<double>::quiet_NaN();
  bool fit_on_finish_ = true;
};

const char* sweepStateName(ValveSweep::State state);

}  // namespace die_cushion_ident
