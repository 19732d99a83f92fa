#include "die_cushion_ident/core/valve/recorded_sweep.h"

#include <algorithm>
#include <cmath>

namespace die_cushion_ident {

namespace {

double medianInterval(const std::vector<ValveSample>& samples) {
  std::vector<double> intervals;
  intervals.reserve(samples.size());
  for (std::size_t i = 1; i < samples.size(); ++i) {
    const double dt = samples[i].t - samples[i - 1].t;
    if (dt > 0.0 && std::isfinite(dt)) intervals.push_back(dt);
  }
  if (intervals.empty()) return 0.0;
  auto middle = intervals.begin() + intervals.size() / 2;
  std::nth_element(intervals.begin(), middle, intervals.end());
  return *middle;
}

std::vector<ValveSample>::const_iterator firstAtOrAfter(const std::vector<ValveSample>& samples, double t) {
  return std::lower_bound(samples.begin(), samples.end(), t,
                          [](const ValveSample& s, double value) { return s.t < value; });
}

// Rising zero crossings of u - mean(u) with a Schmitt trigger at half the local amplitude, so that noise on
// the command cannot produce extra crossings.
std::vector<double> risingCrossings(const std::vector<ValveSample>& s, int window, double min_amplitude) {
  const std::size_t n = s.size();
  const double origin = s.front().voltage;
  std::vector<double> sum(n + 1, 0.0), sum_squares(n + 1, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    const double u = std::isfinite(s[i].voltage) ? s[i].voltage - origin : 0.0;
    sum[i + 1] = sum[i] + u;
    sum_squares[i + 1] = sum_squares[i] + u * u;
  }
  std::vector<double> crossings;
  bool high = false;
  double last_zero = std::numeric_limits<double>::quiet_NaN();
  double previous = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t lo = i >= static_cast<std::size_t>(window / 2) ? i - window / 2 : 0;
    const std::size_t hi = std::min(n, i + window / 2 + 1);
    const double count = static_cast<double>(hi - lo);
    const double mean = (sum[hi] - sum[lo]) / count;
    const double variance = std::max((sum_squares[hi] - sum_squares[lo]) / count - mean * mean, 0.0);
    const double amplitude = std::sqrt(2.0 * variance);
    const double d = (std::isfinite(s[i].voltage) ? s[i].voltage - origin : mean) - mean;
    if (i > 0 && previous <= 0.0 && d > 0.0) {
      last_zero = s[i - 1].t + (s[i].t - s[i - 1].t) * (-previous) / (d - previous);
    }
    const double hysteresis = 0.5 * amplitude;
    if (amplitude < min_amplitude) {
      high = false;
    } else if (!high && d > hysteresis) {
      high = true;
      if (std::isfinite(last_zero)) crossings.push_back(last_zero);
    } else if (high && d < -hysteresis) {
      high = false;
    }
    previous = d;
  }
  return crossings;
}

// Correlates the command over [begin, end) at `frequency` with the reference phase zero at `origin`.
OrthogonalCorrelator correlateCommand(const std::vector<ValveSample>& samples, double frequency,
                                      double origin, double begin, double end, int harmonics) {
  OrthogonalCorrelator c(frequency, harmonics, origin);
  for (auto it = firstAtOrAfter(samples, begin); it != samples.end() && it->t < end; ++it) {
    c.add(it->t, it->voltage);
  }
  c.solve();
  return c;
}

// Zero crossings around a running mean are disturbed where the mean moves (at the ends of a segment), so
// refine the frequency from the phase drift of the command between the two halves of the segment, then
// take amplitude and offset from the correlation.
void refineSegment(const std::vector<ValveSample>& samples, SweepSegment* segment) {
  const double middle = 0.5 * (segment->begin + segment->end);
  for (int iteration = 0; iteration < 3; ++iteration) {
    const auto first =
        correlateCommand(samples, segment->frequency, segment->begin, segment->begin, middle, 1);
    const auto second =
        correlateCommand(samples, segment->frequency, segment->begin, middle, segment->end, 1);
    const double drift = wrapAngle(std::arg(second.phasor(1)) - std::arg(first.phasor(1)));
    segment->frequency += drift / (2.0 * M_PI * (middle - segment->begin));
  }
  const auto whole =
      correlateCommand(samples, segment->frequency, segment->begin, segment->begin, segment->end, 1);
  segment->amplitude = std::abs(whole.phasor(1));
  segment->offset = whole.mean();
}

}  // namespace

std::vector<SweepSegment> detectSweepSegments(const std::vector<ValveSample>& samples,
                                              const RecordedSweepOptions& options) {
  std::vector<SweepSegment> segments;
  if (samples.size() < 16) return segments;
  const double interval = medianInterval(samples);
  if (!(interval > 0.0)) return segments;
  const int window = std::max(3, static_cast<int>(std::lround(1.0 / (options.min_frequency * interval))));
  const auto crossings = risingCrossings(samples, window, options.min_amplitude);

  std::vector<SweepSegment> runs;
  std::size_t first = 0;
  while (first + 1 < crossings.size()) {
    // Grow a run of crossings whose spacing stays within the tolerance of the run's mean period.
    std::size_t last = first + 1;
    double period_sum = crossings[last] - crossings[first];
    while (last + 1 < crossings.size()) {
      const double period = crossings[last + 1] - crossings[last];
      const double mean_period = period_sum / (last - first);
      if (std::abs(period - mean_period) > options.period_tolerance * mean_period) break;
      period_sum += period;
      ++last;
    }
    SweepSegment run;
    run.begin = crossings[first];
    run.end = crossings[last];
    run.frequency = (last - first) / (run.end - run.begin);
    const bool short_run = last - first < 3;  // an odd period or two: noise, a lost message, a step
    first = last;
    if (short_run) continue;
    // A lost message next to a crossing can split one frequency into two runs: join them again.
    if (!runs.empty() && std::abs(run.frequency / runs.back().frequency - 1.0) < options.period_tolerance &&
        run.begin - runs.back().end < 4.0 / run.frequency) {
      runs.back().end = run.end;
    } else {
      runs.push_back(run);
    }
  }
  for (auto segment : runs) {
    if ((segment.end - segment.begin) * segment.frequency + 0.5 < options.min_periods) continue;
    refineSegment(samples, &segment);
    // Confirm the command is a sine at this frequency (a square wave or controller activity is not).
    const auto check =
        correlateCommand(samples, segment.frequency, segment.begin, segment.begin, segment.end, 3);
    const double ac = check.acVariance();
    const double unexplained = ac > 0.0 ? 1.0 - 0.5 * std::norm(check.phasor(1)) / ac : 1.0;
    if (unexplained < options.max_command_distortion) segments.push_back(segment);
  }
  return segments;
}

RecordedSweep analyzeRecordedSweep(const std::vector<ValveSample>& samples,
                                   const RecordedSweepOptions& options) {
  RecordedSweep result;
  result.segments = detectSweepSegments(samples, options);
  const double interval = medianInterval(samples);
  FrequencyPointEstimator::Options point_options;
  point_options.command_hold = std::isfinite(options.command_hold) ? options.command_hold : interval;
  result.message_interval = interval;
  point_options.sample_rate = interval > 0.0 ? 1.0 / interval : 1000.0;
  point_options.max_distortion = options.max_distortion;
  for (const auto& segment : result.segments) {
    const double settle = std::max(options.settle_periods / segment.frequency, options.settle_time);
    const double begin = segment.begin + settle;
    const double periods = std::floor((segment.end - begin) * segment.frequency + 1e-6);
    if (periods < 3.0) continue;
    FrequencyPointEstimator estimator(segment.frequency, begin, periods, point_options);
    for (auto it = firstAtOrAfter(samples, begin); it != samples.end(); ++it) {
      if (estimator.add(it->t, it->voltage, it->spool)) break;
    }
    result.points.push_back(estimator.result());
  }
  unwrapPhases(&result.points);
  result.fit = fitServoValve(result.points);
  return result;
}

SweepCandidateFilter::SweepCandidateFilter(double block, double min_amplitude, double spread)
    : block_(block), min_amplitude_(min_amplitude), spread_(spread) {}

bool SweepCandidateFilter::periodic(const std::vector<ValveSample>& block) const {
  if (block.size() < 8) return false;
  double low = block.front().voltage, high = low, mean = 0.0;
  for (const auto& s : block) {
    low = std::min(low, s.voltage);
    high = std::max(high, s.voltage);
    mean += s.voltage / static_cast<double>(block.size());
  }
  const double amplitude = 0.5 * (high - low);
  if (amplitude < min_amplitude_) return false;
  const double hysteresis = amplitude / 3.0;
  std::vector<double> rising;
  bool below = block.front().voltage < mean - hysteresis;
  for (const auto& s : block) {
    if (below && s.voltage > mean + hysteresis) {
      rising.push_back(s.t);
      below = false;
    } else if (!below && s.voltage < mean - hysteresis) {
      below = true;
    }
  }
  if (rising.size() < 4) return false;
  // Locally periodic: successive periods agree (a sweep's block may hold several frequencies, a controller's
  // command crosses at random), allowing for crossings quantised to the message interval.
  const double interval = (block.back().t - block.front().t) / static_cast<double>(block.size() - 1);
  int pairs = 0, agreeing = 0;
  for (std::size_t i = 2; i < rising.size(); ++i) {
    const double a = rising[i - 1] - rising[i - 2], b = rising[i] - rising[i - 1];
    ++pairs;
    if (std::abs(a - b) <= spread_ * std::max(a, b) + 2.0 * interval) ++agreeing;
  }
  return agreeing >= 2 && agreeing >= 0.7 * pairs;
}

void SweepCandidateFilter::closeBlock(std::vector<ValveSample>* kept) {
  // The previous block is decided now that both its neighbours are known: kept when it or either is periodic.
  const bool current_periodic = periodic(current_);
  if (previous_periodic_ || before_periodic_ || current_periodic)
    kept->insert(kept->end(), previous_.begin(), previous_.end());
  before_periodic_ = previous_periodic_;
  previous_periodic_ = current_periodic;
  previous_.swap(current_);
  current_.clear();
}

void SweepCandidateFilter::push(const ValveSample& sample, std::vector<ValveSample>* kept) {
  const double last = !current_.empty()    ? current_.back().t
                      : !previous_.empty() ? previous_.back().t
                                           : -INFINITY;
  if (!(sample.t > last)) return;
  if (current_.empty()) block_start_ = sample.t;
  if (sample.t - block_start_ >= block_) {
    closeBlock(kept);
    block_start_ = sample.t;
  }
  current_.push_back(sample);
}

void SweepCandidateFilter::flush(std::vector<ValveSample>* kept) {
  closeBlock(kept);  // decides the previous block with the current as its neighbour
  closeBlock(kept);  // and the current one itself
  previous_.clear();
}

}  // namespace die_cushion_ident
