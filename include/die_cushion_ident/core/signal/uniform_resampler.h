#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <limits>
#include <vector>

namespace die_cushion_ident {

/// The three input streams of shared/CONTRACT.md.
enum class InputStream : int { kPressure = 0, kPosition = 1, kValve = 2 };
constexpr int kInputStreamCount = 3;
const char* inputStreamName(InputStream stream);

/// One message of an input stream: stamp [s] and up to two values.
/// pressure: first = p [Pa]; position: first = x [m], second = v [m/s] or NaN;
/// valve: first = command voltage u [V], second = measured spool position y [-] or NaN.
struct StreamSample {
  double stamp = 0.0;
  double first = 0.0;
  double second = 0.0;
  /// valve only: the valve model's spool for the commands so far (IdentificationPipeline), NaN where none.
  double third = std::numeric_limits<double>::quiet_NaN();
  /// valve only: the exact mean of the valve model's spool since the previous message (ValveMessageSpool),
  /// NaN where none: the spool between messages, which a line or a cubic through `third` misses where the
  /// delayed command switches (doc/equations.md, "The free run's spool between samples").
  double third_mean = std::numeric_limits<double>::quiet_NaN();
};

/// One sample on the uniform grid. Channels of a stream that was stale or inside a gap are NaN and
/// `complete` is false; `discontinuity` marks the first sample after the grid was restarted. The pressure and
/// the position (with its velocity) are read between their messages by a cubic through four, the spool
/// linearly, and the valve voltage u is held from its stamp on (the amplifier holds it). The channels are
/// stored in single precision (56 bytes a sample instead of 104: an hour of grid is 101 MB, not 187): its
/// 24-bit mantissa resolves 1 Pa at 160 bar and 0.03 um of stroke, far below the sensors' noise; time stays
/// double (microseconds of a Unix stamp need 16 digits).
struct GridSample {
  double t = 0.0;
  float p = 0.0f, x = 0.0f, v = 0.0f, u = 0.0f, y = 0.0f;
  /// The means of the spool's drain part max(y, 0) and supply part min(y, 0) over the grid interval
  /// [t - T/2, t + T/2], from the line through the valve messages; NaN where the spool is not measured.
  /// A spool that crosses 0 between grid points (a controller dithering it at its own rate, faster than the
  /// grid) drains through one port and fills through the other within one interval: the valve flow over
  /// the interval needs both parts, which y at t alone cannot give (doc/equations.md).
  float y_drain = std::numeric_limits<float>::quiet_NaN();
  float y_supply = std::numeric_limits<float>::quiet_NaN();
  /// The mean of the held command over the same interval [t - T/2, t + T/2]; NaN where the valve stream
  /// has a gap there. u is the command in force at t alone: a controller faster than the grid issues
  /// others in between (every other one of a 1 kHz controller on the 2 ms grid), and a valve model run
  /// on u alone misses them (doc/equations.md, "The spool crossing 0 between grid points").
  float u_mean = std::numeric_limits<float>::quiet_NaN();
  /// The spool that drives the free run (FreeRunPressure): the valve model's response to the recorded
  /// commands, free of the spool sensor's noise (IdentificationPipeline, where the valve model is known to
  /// follow the spool: IdentificationConfig::valve_model_drives_free_run). A shut valve integrates every
  /// error of the spool it is driven by: the measured spool's 0.002 of white noise made the free run of a
  /// clean fast press 3 bar wrong (doc/equations.md, "The free run's spool"). NaN where there is none: the
  /// free run then takes the measured spool.
  float y_model = std::numeric_limits<float>::quiet_NaN();
  /// The exact mean of y_model's spool over the grid interval that ends here, [t - T, t]; NaN where none. The
  /// free run's spool between grid samples keeps it: the spool answers each command after the dead time,
  /// within the interval, with a kink no curve through the samples alone follows; at a 4 ms impact such a
  /// curve left the refined capacitance 1-2 % low (doc/equations.md, "The free run's spool between
  /// samples").
  float y_model_mean = std::numeric_limits<float>::quiet_NaN();
  /// The oil's temperature [degC] at t (the optional oil temperature topic, OilTemperatureInput, filled in by
  /// IdentificationPipeline); NaN where none was measured or the topic fell silent.
  float T = std::numeric_limits<float>::quiet_NaN();
  bool complete = true;
  bool discontinuity = false;
  /// v was derived from the position (VelocityFromPosition), not measured: the free run then takes the
  /// cushion's velocity from the position's own cubic between samples, whose integral over an interval is the
  /// position's change (FreeRunPressure).
  bool velocity_derived = false;
};

/// Stamp health of one stream, for diagnostics and reports.
struct StreamHealth {
  std::uint64_t received = 0;
  std::uint64_t accepted = 0;
  std::uint64_t non_finite = 0;    ///< rejected: NaN/Inf stamp or first value
  std::uint64_t duplicates = 0;    ///< rejected: same stamp as the previous one
  std::uint64_t out_of_order = 0;  ///< rejected: stamp before the previous one (small step back)
  std::uint64_t late = 0;          ///< accepted but too late for grid samples already emitted
  std::uint64_t gaps = 0;          ///< intervals longer than max_gap
  std::uint64_t implausible = 0;   ///< rejected: a value outside the physically plausible range
  std::uint64_t wild_stamps = 0;   ///< rejected: a stamp far off the others that no other topic confirmed
  double last_wild_offset = 0.0;   ///< [s] how far the last wild stamp was off the newest stamp
  double last_stamp = 0.0;
  std::uint64_t intervals = 0;  ///< message intervals in the statistics below
  double mean_interval = 0.0;  ///< [s]
  double interval_std = 0.0;   ///< jitter [s] (refreshed every 64 intervals)
  double interval_m2 = 0.0;    ///< Welford's sum of squared deviations [s^2]
  double max_interval = 0.0;   ///< [s]
  bool stale = false;          ///< silent for longer than stale_timeout while others run
  double rate() const { return mean_interval > 0.0 ? 1.0 / mean_interval : 0.0; }
};

/// Resamples the three asynchronous input streams onto one grid t_k = k * sample_period + grid_phase by
/// interpolation between the bracketing messages of each stream (a cubic through four for the pressure and
/// the position: a line through two misses a fast press's impact by tenths of a bar), so that the filters
/// downstream see the constant sampling interval they assume.
///
/// A grid point is emitted once every live stream has a message at or after it. Intervals longer than
/// max_gap are not interpolated across (the channels become NaN). A stream silent for stale_timeout while
/// the others run is declared stale and its channels are NaN until it speaks again.
///
/// Stamps far (beyond restart_jump) from the newest one are held, not used: a single wild stamp (one
/// message stamped 100 s in the past or 1000 s ahead) is rejected and counted once a message on the old
/// time base arrives, while a jump that the topics confirm (messages of two topics, or of the only one
/// speaking, three in all, on the new time base and none on the old) is taken: backwards (a bag played
/// again) it restarts the grid, forwards (a pause in the recording) the grid jumps; either way the next
/// emitted sample carries `discontinuity`. Values outside `plausible` are rejected like non-finite ones.
class UniformResampler {
  static constexpr double kNaNValue = std::numeric_limits<double>::quiet_NaN();

 public:
  struct Config {
    double sample_period = 0.002;  ///< [s]
    double max_gap = 0.02;         ///< [s] longer message intervals are gaps
    double stale_timeout = 0.2;    ///< [s]
    double restart_jump = 1.0;     ///< [s]
    /// [s] where the grid's points fall within a period: t_k = k sample_period + (grid_phase mod
    /// sample_period). The survey sets it to the position messages' own phase, so that the stream the free
    /// run integrates is read where it was measured (SettingsFromRecording).
    double grid_phase = 0.0;
    /// Physically plausible range of each stream's first value (p [Pa], x [m], u [V]) and bound on the
    /// magnitude of its second (v [m/s], y [-]); outside is rejected and counted as implausible.
    struct Bounds {
      double min_first = -std::numeric_limits<double>::infinity();
      double max_first = std::numeric_limits<double>::infinity();
      double max_abs_second = std::numeric_limits<double>::infinity();
    };
    std::array<Bounds, kInputStreamCount> plausible;
  };
  /// kHeld: a stamp far off the time base, kept until the topics confirm or refute the jump.
  enum class PushResult { kAccepted, kNonFinite, kDuplicate, kOutOfOrder, kRestarted, kImplausible, kHeld };

  explicit UniformResampler(const Config& config);

  /// Adds one message; grid samples that became complete are appended to `out`.
  PushResult push(InputStream stream, const StreamSample& sample, std::vector<GridSample>* out);
  /// Declares the input finished (end of a bag): emits what the streams still cover.
  void flush(std::vector<GridSample>* out);
  void reset();

  const StreamHealth& health(InputStream stream) const { return health_[static_cast<int>(stream)]; }
  std::uint64_t restarts() const { return restarts_; }
  const Config& config() const { return config_; }

 private:
  struct Channel {
    std::deque<StreamSample> buffer;
    bool has_any = false;
  };
  void restartGrid();
  PushResult accept(InputStream stream, const StreamSample& sample, std::vector<GridSample>* out);
  /// True once the held messages confirm a jump of the time base.
  bool jumpConfirmed() const;
  /// kLive: as the streams allow; kClosing: the same, but the position's cubic does not wait for a next
  /// message (a restart ends the time base); kFlushing: the recording's end, whatever the streams cover.
  enum class Emit { kLive, kClosing, kFlushing };
  void emitReady(std::vector<GridSample>* out, Emit mode);
  /// Starts the grid at the first point every stream covers (or a silent one is overdue); false: not yet.
  bool startGrid(bool flushing);
  /// Each stream's interpolated (first, second) at a grid point, and the valve model's spool.
  struct GridValues {
    double first[kInputStreamCount] = {kNaNValue, kNaNValue, kNaNValue};
    double second[kInputStreamCount] = {kNaNValue, kNaNValue, kNaNValue};
    double modelled_spool = kNaNValue;
  };
  GridSample sampleAt(double t, const GridValues& values) const;
  /// Drops the messages no grid point from t_next on needs.
  void dropMessagesBefore(double t_next);
  bool interpolate(int stream, double t, double* first, double* second, double* third = nullptr) const;
  /// Over [from, to], from the valve messages: the mean of the command (each held from its stamp to the next
  /// message's), and of the drain part max(y, 0) and the supply part min(y, 0) of the line through the
  /// spool positions. NaN where the interval is not covered or lies in a gap; the parts also where the
  /// spool is not measured.
  struct ValveIntervalMeans {
    double command = std::numeric_limits<double>::quiet_NaN();
    double drain = std::numeric_limits<double>::quiet_NaN();
    double supply = std::numeric_limits<double>::quiet_NaN();
  };
  ValveIntervalMeans valveIntervalMeans(double from, double to) const;
  /// The mean of the valve model's spool over [from, to] from the messages' exact stretch means
  /// (StreamSample::third_mean); a stretch covered in part by the quadratic through its ends with its mean.
  /// NaN where a stretch has none or the interval is not covered.
  double modelSpoolMean(double from, double to) const;
  /// How far past a grid point a stream must have spoken before the point is emitted: the valve half a
  /// sample, for the spool's mean over the interval around the point.
  double lead(int stream) const;
  /// [s] the grid's point of index k, and the index of the first point at or after t.
  double gridTime(std::int64_t index) const;
  std::int64_t firstIndexAtOrAfter(double t) const;
  /// How far before a grid point a stream's messages are kept: the valve a whole sample, for the model
  /// spool's mean over the interval that ends at the point.
  double history(int stream) const;
  /// Calls piece(a, b, lo, hi) on each valve stretch between messages a and b that overlaps [from, to]
  /// ([lo, hi] the overlap); the time covered, NaN where a stretch is a gap or piece returns false.
  template <typename Piece>
  double overValveStretches(double from, double to, Piece piece) const;
  void updateIntervalStatistics(StreamHealth& h, double interval);

  Config config_;
  std::array<Channel, kInputStreamCount> channels_;
  std::array<StreamHealth, kInputStreamCount> health_;
  double newest_stamp_ = 0.0;
  double first_stamp_ = 0.0;  // first message since the (re)start
  bool started_ = false;
  bool grid_started_ = false;
  bool pending_discontinuity_ = false;
  std::int64_t next_index_ = 0;  // grid index of the next sample to emit
  double phase_ = 0.0;           // [s] config_.grid_phase within [0, sample_period)
  std::uint64_t restarts_ = 0;
  struct Held {
    InputStream stream;
    StreamSample sample;
  };
  std::deque<Held> held_;  // messages on a candidate new time base, oldest first
};

/// Whether any grid sample holds a measured spool (its drain and supply parts are NaN otherwise).
bool spoolMeasured(const std::vector<GridSample>& grid);
/// Whether any grid sample holds an oil temperature.
bool oilTemperatureMeasured(const std::vector<GridSample>& grid);

/// Why a message was not taken, in words ("" for kAccepted, kRestarted and kHeld).
const char* pushResultText(UniformResampler::PushResult result);

}  // namespace die_cushion_ident
