#include "die_cushion_ident/core/uniform_resampler.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace die_cushion_ident {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
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

UniformResampler::UniformResampler(const Config& config) : config_(config) {
  if (!(config.sample_period > 0.0) || !std::isfinite(config.sample_period)) {
    throw std::invalid_argument("sample_period must be > 0 s");
  }
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
  emitted_ = 0;
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
  // Welford's running mean and variance of the message interval.
  const double n = static_cast<double>(h.accepted - 1);  // intervals so far: the first message has none
  const double delta = interval - h.mean_interval;
  h.mean_interval += delta / n;
  const double m2 = h.interval_std * h.interval_std * (n - 1.0) + delta * (interval - h.mean_interval);
  h.interval_std = n > 1.0 ? std::sqrt(std::max(m2 / n, 0.0)) : 0.0;
  h.max_interval = std::max(h.max_interval, interval);
  if (interval > config_.max_gap) ++h.gaps;
}

UniformResampler::PushResult UniformResampler::push(InputStream stream, const StreamSample& sample,
                                                    std::vector<GridSample>* out) {
  const int s = static_cast<int>(stream);
  StreamHealth& h = health_[s];
  Channel& c = channels_[s];
  ++h.received;
  if (!std::isfinite(sample.stamp) || !std::isfinite(sample.first)) {
    ++h.non_finite;
    return PushResult::kNonFinite;
  }
  PushResult result = PushResult::kAccepted;
  if (started_ && newest_stamp_ - sample.stamp > config_.restart_jump) {
    restartGrid();
    result = PushResult::kRestarted;
  } else if (c.has_any && sample.stamp == h.last_stamp) {
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
  if (grid_started_ && stored.stamp < (next_index_ - 1) * config_.sample_period) ++h.late;
  c.buffer.push_back(stored);
  c.has_any = true;
  h.last_stamp = stored.stamp;
  h.stale = false;
  if (!started_) first_stamp_ = stored.stamp;
  newest_stamp_ = started_ ? std::max(newest_stamp_, stored.stamp) : stored.stamp;
  started_ = true;
  emitReady(out, false);
  return result;
}

void UniformResampler::flush(std::vector<GridSample>* out) { emitReady(out, true); }

bool UniformResampler::interpolate(int stream, double t, double* first, double* second) const {
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
      const bool held = stream == static_cast<int>(InputStream::kValve);
      *first = held ? (t < b.stamp ? a.first : b.first) : a.first + w * (b.first - a.first);
      *second = a.second + w * (b.second - a.second);  // NaN stays NaN: not measured
      return true;
    }
  }
  if (!buffer.empty() && buffer.back().stamp == t) {
    *first = buffer.back().first;
    *second = buffer.back().second;
    return true;
  }
  *first = kNaN;
  *second = kNaN;
  return false;
}

void UniformResampler::emitReady(std::vector<GridSample>* out, bool flushing) {
  const double dt = config_.sample_period;
  if (!grid_started_) {
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
    if (speaking == 0) return;
    if (speaking < kInputStreamCount && newest_stamp_ - earliest_first < config_.stale_timeout && !flushing)
      return;
    next_index_ = static_cast<std::int64_t>(std::ceil(latest_first / dt - 1e-9));
    grid_started_ = true;
  }

  for (;;) {
    const double t = static_cast<double>(next_index_) * dt;
    bool must_wait = false;
    bool any_bracketed = false;
    double resume = std::numeric_limits<double>::infinity();
    // Each stream's interpolated (first, second) at t; NaN where it has nothing to bracket t with.
    double first[kInputStreamCount] = {kNaN, kNaN, kNaN};
    double second[kInputStreamCount] = {kNaN, kNaN, kNaN};
    for (int s = 0; s < kInputStreamCount; ++s) {
      const Channel& c = channels_[s];
      StreamHealth& h = health_[s];
      const bool has_future = c.has_any && c.buffer.back().stamp >= t;
      if (has_future) {
        for (const auto& m : c.buffer) {
          if (m.stamp >= t) {
            resume = std::min(resume, m.stamp);
            break;
          }
        }
        if (interpolate(s, t, &first[s], &second[s])) any_bracketed = true;
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
        next_index_ = static_cast<std::int64_t>(std::ceil(resume / dt - 1e-9));
        pending_discontinuity_ = true;
        continue;
      }
    }

    constexpr int kP = static_cast<int>(InputStream::kPressure);
    constexpr int kX = static_cast<int>(InputStream::kPosition);
    constexpr int kV = static_cast<int>(InputStream::kValve);
    GridSample g;
    g.t = t;
    g.p = first[kP];
    g.x = first[kX];
    g.v = second[kX];
    g.u = first[kV];
    g.y = second[kV];
    g.complete = std::isfinite(g.p) && std::isfinite(g.x) && std::isfinite(g.u);
    g.discontinuity = pending_discontinuity_;
    pending_discontinuity_ = false;
    out->push_back(g);
    ++emitted_;
    ++next_index_;

    const double t_next = static_cast<double>(next_index_) * dt;
    for (auto& c : channels_) {
      while (c.buffer.size() >= 2 && c.buffer[1].stamp <= t_next) c.buffer.pop_front();
    }
  }
}

}  // namespace die_cushion_ident
