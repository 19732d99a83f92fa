#include "die_cushion_ident/core/signal/uniform_resampler.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <stdexcept>

namespace die_cushion_ident {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Messages on a new time base needed to confirm a jump, and the most held at once (a topic stamped by a
// wild clock for seconds must not grow memory).
constexpr std::size_t kHeldToConfirm = 3;
constexpr std::size_t kMaxHeld = 64;
}

const char* inputStreamName(InputStream stream) {
  switch (stream) {
    case InputStream::kPressure:
      return "pressure";
    case InputStream::kPosition:
      return "position";
    case InputStream::kValve:
      return "valve";
  }
  return "?";
}

UniformResampler::UniformResampler(const Config& config)
    : config_(config),
      phase_(std::isfinite(config.grid_phase)
                 ? config.grid_phase -
                       std::floor(config.grid_phase / config.sample_period) * config.sample_period
                 : 0.0) {
  if (!(config.sample_period > 0.0) || !std::isfinite(config.sample_period)) {
    throw std::invalid_argument("sample_period must be > 0 s");
  }
  if (!std::isfinite(config.grid_phase)) throw std::invalid_argument("grid_phase must be finite");
  if (!(config.max_gap > config.sample_period))
    throw std::invalid_argument("max_gap must exceed sample_period");
  if (!(config.stale_timeout >= config.max_gap))
    throw std::invalid_argument("stale_timeout must be >= max_gap");
  if (!(config.restart_jump > config.stale_timeout)) {
    throw std::invalid_argument("restart_jump must exceed stale_timeout");
  }
}

void UniformResampler::reset() {
  for (auto& c : channels_) c = Channel{};
  for (auto& h : health_) h = StreamHealth{};
  started_ = false;
  grid_started_ = false;
  pending_discontinuity_ = false;
  next_index_ = 0;
  restarts_ = 0;
  held_.clear();
}

void UniformResampler::restartGrid() {
  for (auto& c : channels_) c = Channel{};
  for (auto& h : health_) h.stale = false;
  started_ = false;
  grid_started_ = false;
  pending_discontinuity_ = true;
  ++restarts_;
}

void UniformResampler::updateIntervalStatistics(StreamHealth& h, double interval) {
  if (interval > config_.restart_jump) {
    // A pause in the recording is a gap, not a message interval: it must not drag the rate to 1e-5 Hz.
    ++h.gaps;
    return;
  }
  // Welford's running mean and variance of the message interval. The square root is the costliest step of
  // a message's path (a quarter of the pipeline's time when taken per message): the std is refreshed every
  // 64 intervals, which no reader of a jitter figure can tell apart.
  const double n = static_cast<double>(++h.intervals);
  const double delta = interval - h.mean_interval;
  h.mean_interval += delta / n;
  h.interval_m2 += delta * (interval - h.mean_interval);
  if ((h.intervals & 63u) == 0 || h.intervals < 64) {
    h.interval_std = n > 1.0 ? std::sqrt(std::max(h.interval_m2 / n, 0.0)) : 0.0;
  }
  h.max_interval = std::max(h.max_interval, interval);
  if (interval > config_.max_gap) ++h.gaps;
}

UniformResampler::PushResult UniformResampler::push(InputStream stream, const StreamSample& sample,
                                                    std::vector<GridSample>* out) {
  const int s = static_cast<int>(stream);
  StreamHealth& h = health_[s];
  ++h.received;
  if (!std::isfinite(sample.stamp) || !std::isfinite(sample.first)) {
    ++h.non_finite;
    return PushResult::kNonFinite;
  }
  const Config::Bounds& bounds = config_.plausible[s];
  if (sample.first < bounds.min_first || sample.first > bounds.max_first ||
      std::abs(sample.second) > bounds.max_abs_second) {  // NaN second ("not measured") passes
    ++h.implausible;
    return PushResult::kImplausible;
  }
  if (started_ && std::abs(sample.stamp - newest_stamp_) > config_.restart_jump) {
    // Far off the time base: hold it until the other topics confirm the jump or refute it.
    if (!held_.empty() && std::abs(sample.stamp - held_.back().sample.stamp) > config_.restart_jump) {
      for (const Held& wild : held_) ++health_[static_cast<int>(wild.stream)].wild_stamps;
      held_.clear();  // not even consistent with each other
    }
    h.last_wild_offset = sample.stamp - newest_stamp_;
    held_.push_back({stream, sample});
    if (held_.size() > kMaxHeld) {
      ++health_[static_cast<int>(held_.front().stream)].wild_stamps;
      held_.pop_front();
    }
    if (!jumpConfirmed()) return PushResult::kHeld;
    const bool backwards = held_.front().sample.stamp < newest_stamp_;
    if (backwards) {
      // The old time base's points that wait only for the position's next message get the chord: a
      // restart must not lose them.
      emitReady(out, Emit::kClosing);
      restartGrid();
    }
    std::deque<Held> replay;
    replay.swap(held_);
    if (!backwards) newest_stamp_ = replay.front().sample.stamp;  // a pause: the grid jumps ahead
    for (const Held& m : replay) accept(m.stream, m.sample, out);
    return backwards ? PushResult::kRestarted : PushResult::kAccepted;
  }
  if (!held_.empty()) {
    // A message on the old time base: the held stamps were wild.
    for (const Held& wild : held_) ++health_[static_cast<int>(wild.stream)].wild_stamps;
    held_.clear();
  }
  return accept(stream, sample, out);
}

bool UniformResampler::jumpConfirmed() const {
  bool streams[kInputStreamCount] = {false, false, false};
  int distinct = 0;
  for (const Held& m : held_) {
    if (!streams[static_cast<int>(m.stream)]) ++distinct;
    streams[static_cast<int>(m.stream)] = true;
  }
  int speaking = 0;
  for (const auto& c : channels_) speaking += c.has_any ? 1 : 0;
  return held_.size() >= kHeldToConfirm && distinct >= std::min(2, std::max(speaking, 1));
}

UniformResampler::PushResult UniformResampler::accept(InputStream stream, const StreamSample& sample,
                                                      std::vector<GridSample>* out) {
  const int s = static_cast<int>(stream);
  StreamHealth& h = health_[s];
  Channel& c = channels_[s];
  if (c.has_any && sample.stamp == h.last_stamp) {
    ++h.duplicates;
    return PushResult::kDuplicate;
  } else if (c.has_any && sample.stamp < h.last_stamp) {
    ++h.out_of_order;
    return PushResult::kOutOfOrder;
  }

  StreamSample stored = sample;
  if (!std::isfinite(stored.second)) stored.second = kNaN;  // "not measured"
  ++h.accepted;
  if (c.has_any) updateIntervalStatistics(h, stored.stamp - h.last_stamp);
  if (grid_started_ && stored.stamp < gridTime(next_index_ - 1)) ++h.late;
  c.buffer.push_back(stored);
  c.has_any = true;
  h.last_stamp = stored.stamp;
  h.stale = false;
  if (!started_) first_stamp_ = stored.stamp;
  newest_stamp_ = started_ ? std::max(newest_stamp_, stored.stamp) : stored.stamp;
  started_ = true;
  emitReady(out, Emit::kLive);
  return PushResult::kAccepted;
}

void UniformResampler::flush(std::vector<GridSample>* out) { emitReady(out, Emit::kFlushing); }

namespace {
// The pressure and the position are read between their messages by a cubic: a line through them misses
// their curvature, the pressure's at a fast press's 4 ms impact by a few tenths of a bar where its messages
// fall between the grid's points.
bool interpolatedByCubic(int stream) {
  return stream == static_cast<int>(InputStream::kPressure) ||
         stream == static_cast<int>(InputStream::kPosition);
}

// The cubic Hermite between messages a and b at w in [0, 1], its slopes the secants through the neighbours
// (Catmull-Rom on the messages' own, uneven stamps; the chord a-b where a neighbour is missing or not
// finite).
double cubicBetween(const StreamSample* before, const StreamSample& a, const StreamSample& b,
                    const StreamSample* after, double w, double StreamSample::*channel) {
  const double span = b.stamp - a.stamp;
  const double chord = b.*channel - a.*channel;
  const double slope_a = before && std::isfinite(before->*channel)
                             ? (b.*channel - before->*channel) / (b.stamp - before->stamp) * span
                             : chord;
  const double slope_b = after && std::isfinite(after->*channel)
                             ? (after->*channel - a.*channel) / (after->stamp - a.stamp) * span
                             : chord;
  const double w2 = w * w, w3 = w2 * w;
  return a.*channel + w * slope_a + w2 * (3.0 * chord - 2.0 * slope_a - slope_b) +
         w3 * (slope_a + slope_b - 2.0 * chord);
}
}  // namespace

bool UniformResampler::interpolate(int stream, double t, double* first, double* second, double* third) const {
  const auto& buffer = channels_[stream].buffer;
  // The buffer is popped so that buffer[0] is the last message at or before the previous grid point.
  for (std::size_t i = 0; i + 1 < buffer.size(); ++i) {
    const StreamSample& a = buffer[i];
    const StreamSample& b = buffer[i + 1];
    if (a.stamp <= t && t <= b.stamp) {
      if (b.stamp - a.stamp > config_.max_gap) break;
      const double w = (t - a.stamp) / (b.stamp - a.stamp);
      // The valve voltage is in force from its stamp on (held by the amplifier), so it is held, not
      // interpolated: interpolation would lead the real command by half a message period.
      if (interpolatedByCubic(stream)) {
        const StreamSample* before =
            i > 0 && a.stamp - buffer[i - 1].stamp <= config_.max_gap ? &buffer[i - 1] : nullptr;
        const StreamSample* after = i + 2 < buffer.size() && buffer[i + 2].stamp - b.stamp <= config_.max_gap
                                        ? &buffer[i + 2]
                                        : nullptr;
        *first = cubicBetween(before, a, b, after, w, &StreamSample::first);
        *second = cubicBetween(before, a, b, after, w, &StreamSample::second);  // NaN stays NaN
      } else {
        const bool held = stream == static_cast<int>(InputStream::kValve);
        *first = held ? (t < b.stamp ? a.first : b.first) : a.first + w * (b.first - a.first);
        *second = a.second + w * (b.second - a.second);  // NaN stays NaN: not measured
      }
      if (third) *third = a.third + w * (b.third - a.third);
      return true;
    }
  }
  if (!buffer.empty() && buffer.back().stamp == t) {
    *first = buffer.back().first;
    *second = buffer.back().second;
    if (third) *third = buffer.back().third;
    return true;
  }
  *first = kNaN;
  *second = kNaN;
  if (third) *third = kNaN;
  return false;
}

double UniformResampler::gridTime(std::int64_t index) const {
  return static_cast<double>(index) * config_.sample_period + phase_;
}

std::int64_t UniformResampler::firstIndexAtOrAfter(double t) const {
  return static_cast<std::int64_t>(std::ceil((t - phase_) / config_.sample_period - 1e-9));
}

double UniformResampler::lead(int stream) const {
  return stream == static_cast<int>(InputStream::kValve) ? 0.5 * config_.sample_period : 0.0;
}

double UniformResampler::history(int stream) const {
  return stream == static_cast<int>(InputStream::kValve) ? config_.sample_period : 0.0;
}

template <typename Piece>
double UniformResampler::overValveStretches(double from, double to, Piece piece) const {
  const auto& buffer = channels_[static_cast<int>(InputStream::kValve)].buffer;
  double covered = 0.0;
  for (std::size_t i = 0; i + 1 < buffer.size(); ++i) {
    const StreamSample& a = buffer[i];
    const StreamSample& b = buffer[i + 1];
    const double lo = std::max(a.stamp, from), hi = std::min(b.stamp, to);
    if (!(hi > lo)) continue;
    if (b.stamp - a.stamp > config_.max_gap || !piece(a, b, lo, hi)) return kNaN;
    covered += hi - lo;
  }
  return covered;
}

double UniformResampler::modelSpoolMean(double from, double to) const {
  double integral = 0.0;
  const double covered =
      overValveStretches(from, to, [&](const StreamSample& a, const StreamSample& b, double lo, double hi) {
        if (!std::isfinite(b.third_mean)) return false;
        const double stretch = b.stamp - a.stamp;
        if (lo == a.stamp && hi == b.stamp) {
          integral += b.third_mean * stretch;
          return true;
        }
        // Part of the stretch: the quadratic q(w) = a + (b - a) w + 6 c w (1 - w) through its ends with its
        // mean (c = mean - (a + b) / 2), integrated from w0 to w1.
        if (!std::isfinite(a.third) || !std::isfinite(b.third)) return false;
        const double c = b.third_mean - 0.5 * (a.third + b.third);
        const double w0 = (lo - a.stamp) / stretch, w1 = (hi - a.stamp) / stretch;
        const double squares = 0.5 * (w1 * w1 - w0 * w0), cubes = (w1 * w1 * w1 - w0 * w0 * w0) / 3.0;
        integral +=
            stretch * (a.third * (w1 - w0) + (b.third - a.third) * squares + 6.0 * c * (squares - cubes));
        return true;
      });
  return covered >= (to - from) * (1.0 - 1e-9) ? integral / covered : kNaN;
}

UniformResampler::ValveIntervalMeans UniformResampler::valveIntervalMeans(double from, double to) const {
  double command = 0.0, positive = 0.0, total = 0.0;
  bool spool_measured = true;
  const double covered =
      overValveStretches(from, to, [&](const StreamSample& a, const StreamSample& b, double lo, double hi) {
        const double span = hi - lo;
        command += a.first * span;  // held from its stamp to the next message's
        if (!std::isfinite(a.second) || !std::isfinite(b.second)) {
          spool_measured = false;
          return true;
        }
        // The spool along the line through the two messages.
        const double slope = (b.second - a.second) / (b.stamp - a.stamp);
        const double y_lo = a.second + slope * (lo - a.stamp), y_hi = a.second + slope * (hi - a.stamp);
        total += 0.5 * (y_lo + y_hi) * span;
        if (y_lo >= 0.0 && y_hi >= 0.0) {
          positive += 0.5 * (y_lo + y_hi) * span;
        } else if (y_lo > 0.0 || y_hi > 0.0) {  // crosses 0: the triangle on the drain side
          const double top = std::max(y_lo, y_hi);
          positive += 0.5 * top * span * top / (top - std::min(y_lo, y_hi));
        }
        return true;
      });
  ValveIntervalMeans means;
  if (!(covered > 0.0)) return means;
  means.command = command / covered;
  if (spool_measured) {
    means.drain = positive / covered;
    means.supply = (total - positive) / covered;
  }
  return means;
}

bool UniformResampler::startGrid(bool flushing) {
  // Start once every stream has spoken, or once a silent stream is overdue (it is then reported stale).
  double latest_first = -std::numeric_limits<double>::infinity();
  double earliest_first = std::numeric_limits<double>::infinity();
  int speaking = 0;
  for (const auto& c : channels_) {
    if (c.buffer.empty()) continue;
    ++speaking;
    latest_first = std::max(latest_first, c.buffer.front().stamp);
    earliest_first = std::min(earliest_first, c.buffer.front().stamp);
  }
  if (speaking == 0) return false;
  if (speaking < kInputStreamCount && newest_stamp_ - earliest_first < config_.stale_timeout && !flushing)
    return false;
  next_index_ = firstIndexAtOrAfter(latest_first);
  grid_started_ = true;
  return true;
}

GridSample UniformResampler::sampleAt(double t, const GridValues& values) const {
  constexpr int kP = static_cast<int>(InputStream::kPressure);
  constexpr int kX = static_cast<int>(InputStream::kPosition);
  constexpr int kV = static_cast<int>(InputStream::kValve);
  const double dt = config_.sample_period;
  GridSample g;
  g.t = t;
  g.p = values.first[kP];
  g.x = values.first[kX];
  g.v = values.second[kX];
  g.u = values.first[kV];
  g.y = values.second[kV];
  const ValveIntervalMeans means = valveIntervalMeans(t - 0.5 * dt, t + 0.5 * dt);
  if (std::isfinite(g.y)) {
    g.y_drain = static_cast<float>(means.drain);
    g.y_supply = static_cast<float>(means.supply);
  }
  if (std::isfinite(g.u)) g.u_mean = static_cast<float>(means.command);
  g.y_model = static_cast<float>(values.modelled_spool);
  if (std::isfinite(g.y_model)) g.y_model_mean = static_cast<float>(modelSpoolMean(t - dt, t));
  g.complete = std::isfinite(g.p) && std::isfinite(g.x) && std::isfinite(g.u);
  return g;
}

void UniformResampler::dropMessagesBefore(double t_next) {
  for (int s = 0; s < kInputStreamCount; ++s) {
    auto& buffer = channels_[s].buffer;
    const double keep_from = t_next - history(s);
    // The pressure and the position keep one message more: the neighbour before the bracket, for the cubic.
    const std::size_t kept = interpolatedByCubic(s) ? 2 : 1;
    while (buffer.size() >= kept + 1 && buffer[kept].stamp <= keep_from) buffer.pop_front();
  }
}

void UniformResampler::emitReady(std::vector<GridSample>* out, Emit mode) {
  const bool flushing = mode == Emit::kFlushing;
  if (!grid_started_ && !startGrid(flushing)) return;
  for (;;) {
    const double t = gridTime(next_index_);
    bool must_wait = false;
    bool any_bracketed = false;
    double resume = std::numeric_limits<double>::infinity();
    GridValues values;  // NaN where a stream has nothing to bracket t with
    for (int s = 0; s < kInputStreamCount; ++s) {
      const Channel& c = channels_[s];
      StreamHealth& h = health_[s];
      const auto ahead =
          std::find_if(c.buffer.begin(), c.buffer.end(), [t](const StreamSample& m) { return m.stamp >= t; });
      const bool reaches = c.has_any && c.buffer.back().stamp >= t + (flushing ? 0.0 : lead(s));
      // A cubic (pressure, position) waits for the neighbour after the bracket too, unless the grid is being closed
      // or the stream has fallen silent (then the chord ends it, as at the end of a recording).
      const bool has_future =
          reaches && (mode != Emit::kLive || !interpolatedByCubic(s) || std::next(ahead) != c.buffer.end() ||
                      newest_stamp_ - c.buffer.back().stamp >= config_.stale_timeout);
      if (has_future) {
        if (ahead != c.buffer.end()) resume = std::min(resume, ahead->stamp);
        const bool valve = s == static_cast<int>(InputStream::kValve);
        if (interpolate(s, t, &values.first[s], &values.second[s],
                        valve ? &values.modelled_spool : nullptr)) {
          any_bracketed = true;
        }
        continue;
      }
      const double silent_since = c.has_any ? c.buffer.back().stamp : first_stamp_;
      h.stale = newest_stamp_ - silent_since >= config_.stale_timeout;
      if (!h.stale && !flushing) must_wait = true;
    }
    if (must_wait) return;
    if (flushing && t > newest_stamp_) return;
    if (!any_bracketed) {
      if (!std::isfinite(resume)) return;  // nothing ahead of t at all: wait for data
      if (resume - t > config_.restart_jump) {
        // A long silence in every stream: jump the grid rather than emit hours of empty samples.
        next_index_ = firstIndexAtOrAfter(resume);
        pending_discontinuity_ = true;
        continue;
      }
    }
    GridSample g = sampleAt(t, values);
    g.discontinuity = pending_discontinuity_;
    pending_discontinuity_ = false;
    out->push_back(g);
    ++next_index_;
    dropMessagesBefore(gridTime(next_index_));
  }
}

bool spoolMeasured(const std::vector<GridSample>& grid) {
  return std::any_of(grid.begin(), grid.end(), [](const GridSample& g) { return std::isfinite(g.y_drain); });
}

bool oilTemperatureMeasured(const std::vector<GridSample>& grid) {
  return std::any_of(grid.begin(), grid.end(), [](const GridSample& g) { return std::isfinite(g.T); });
}

const char* pushResultText(UniformResampler::PushResult result) {
  switch (result) {
    case UniformResampler::PushResult::kNonFinite:
      return "non-finite stamp or value";
    case UniformResampler::PushResult::kDuplicate:
      return "duplicate stamp";
    case UniformResampler::PushResult::kOutOfOrder:
      return "stamp older than the previous one";
    case UniformResampler::PushResult::kImplausible:
      return "value outside the physically plausible range";
    default:
      return "";
  }
}

}  // namespace die_cushion_ident
