#include "die_cushion_ident/core/signal/velocity_from_position.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "die_cushion_ident/core/util/least_squares_line.h"

namespace die_cushion_ident {

namespace {

// Least-squares slope of (t, x) pairs; NaN with fewer than two distinct instants.
template <typename Range, typename T, typename X>
double slope(const Range& points, T time_of, X position_of) {
  return fitLeastSquaresLine([&](const auto& visit) {
           for (const auto& p : points) visit(time_of(p), position_of(p));
         }).slope;
}

}  // namespace

VelocityFromPosition::VelocityFromPosition(int half_width) : half_width_(half_width) {
  if (half_width < 1) throw std::invalid_argument("VelocityFromPosition: half width must be >= 1 sample");
}

void VelocityFromPosition::reset() {
  buffer_.clear();
  next_ = 0;
  derived_ = 0;
}

void VelocityFromPosition::push(const GridSample& sample, std::vector<GridSample>* out) {
  if (next_ == buffer_.size() && (std::isfinite(sample.v) || !std::isfinite(sample.x))) {
    // Nothing waiting and nothing to derive (velocity measured, or no position): straight through, with
    // no delay. A later sample without velocity starts its window afresh (one-sided at first).
    buffer_.clear();
    next_ = 0;
    out->push_back(sample);
    return;
  }
  if (sample.discontinuity) {
    // The window must not reach across a restart of the time base: finish the old segment first.
    flush(out);
  }
  buffer_.push_back(sample);
  const std::size_t k = static_cast<std::size_t>(half_width_);
  while (buffer_.size() - next_ > k) emit(next_++, out);
  while (next_ > k) {
    buffer_.pop_front();
    --next_;
  }
}

void VelocityFromPosition::flush(std::vector<GridSample>* out) {
  while (next_ < buffer_.size()) emit(next_++, out);
  buffer_.clear();
  next_ = 0;
}

void VelocityFromPosition::emit(std::size_t index, std::vector<GridSample>* out) {
  GridSample g = buffer_[index];
  if (!std::isfinite(g.v) && std::isfinite(g.x)) {
    const std::size_t k = static_cast<std::size_t>(half_width_);
    const std::size_t first = index >= k ? index - k : 0;
    const std::size_t last = std::min(buffer_.size() - 1, index + k);
    // Only the contiguous stretch of finite positions around the sample: a gap (NaN x) ends the window.
    std::size_t lo = index, hi = index;
    while (lo > first && std::isfinite(buffer_[lo - 1].x)) --lo;
    while (hi < last && std::isfinite(buffer_[hi + 1].x)) ++hi;
    const auto begin = buffer_.begin() + static_cast<std::ptrdiff_t>(lo);
    const auto end = buffer_.begin() + static_cast<std::ptrdiff_t>(hi + 1);
    struct View {
      std::deque<GridSample>::const_iterator b, e;
      auto begin() const { return b; }
      auto end() const { return e; }
    };
    g.v = slope(View{begin, end}, [](const GridSample& s) { return s.t; },
                [](const GridSample& s) { return s.x; });
    g.velocity_derived = std::isfinite(g.v);
    if (g.velocity_derived) ++derived_;
  }
  out->push_back(g);
}

CausalVelocity::CausalVelocity(double window) : window_(window) {
  if (!(window > 0.0)) throw std::invalid_argument("CausalVelocity: window must be > 0 s");
}

void CausalVelocity::push(double t, double x) {
  if (!std::isfinite(t) || !std::isfinite(x)) return;
  if (!samples_.empty() && !(t > samples_.back().first)) return;
  if (!samples_.empty() && t - samples_.back().first > window_) samples_.clear();
  samples_.emplace_back(t, x);
  while (samples_.front().first < t - window_) samples_.pop_front();
}

double CausalVelocity::velocity() const {
  if (samples_.size() < 3 || samples_.back().first - samples_.front().first < 0.25 * window_) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return slope(samples_, [](const auto& p) { return p.first; }, [](const auto& p) { return p.second; });
}

}  // namespace die_cushion_ident
