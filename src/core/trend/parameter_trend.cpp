#include "die_cushion_ident/core/trend/parameter_trend.h"

#include <Eigen/Dense>
#include <algorithm>
#include <boost/math/distributions/normal.hpp>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <ctime>
#include <limits>
#include <map>
#include <mutex>
#include <random>

#include "die_cushion_ident/core/util/formatted.h"
#include "die_cushion_ident/core/util/least_squares_line.h"

namespace die_cushion_ident {

namespace {

// The least-squares line through the points [begin, end) against their index.
LeastSquaresLine indexLine(const std::vector<TrendPoint>& p, std::size_t begin, std::size_t end) {
  return fitLeastSquaresLine([&](const auto& visit) {
    for (std::size_t i = begin; i < end; ++i) visit(static_cast<double>(i), p[i].value);
  });
}

// Whether that line fits the points much better than their mean (the change's shape).
bool rampFitsBetter(const std::vector<TrendPoint>& p, std::size_t begin, std::size_t end) {
  if (end < begin + 3) return false;
  const LeastSquaresLine line = indexLine(p, begin, end);
  double level = 0.0, ramp = 0.0;
  for (std::size_t i = begin; i < end; ++i) {
    level += (p[i].value - line.y_mean) * (p[i].value - line.y_mean);
    ramp += (p[i].value - line.at(static_cast<double>(i))) * (p[i].value - line.at(static_cast<double>(i)));
  }
  return ramp < 0.25 * level;
}

// That line at the last of the points (their mean where it has no slope).
double lineEnd(const std::vector<TrendPoint>& p, std::size_t begin, std::size_t end) {
  const LeastSquaresLine line = indexLine(p, begin, end);
  return std::isfinite(line.slope) ? line.at(static_cast<double>(end - 1)) : line.y_mean;
}

double meanOf(const std::vector<TrendPoint>& p, std::size_t begin, std::size_t end) {
  double sum = 0.0;
  for (std::size_t i = begin; i < end; ++i) sum += p[i].value;
  return end > begin ? sum / static_cast<double>(end - begin) : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

double cusumRunLength(double threshold, double reference) {
  // Brook and Evans's Markov chain: state 0 is S = 0, state i the cell around i w, w = h / (N - 1/2); the
  // run length from each state solves (I - P) L = 1.
  constexpr int kStates = 240;
  const double w = threshold / (kStates - 0.5);
  const boost::math::normal normal;
  Eigen::MatrixXd transitions(kStates, kStates);
  for (int i = 0; i < kStates; ++i) {
    const double from = i * w;
    transitions(i, 0) = boost::math::cdf(normal, 0.5 * w - from + reference);
    for (int j = 1; j < kStates; ++j) {
      transitions(i, j) = boost::math::cdf(normal, (j + 0.5) * w - from + reference) -
                          boost::math::cdf(normal, (j - 0.5) * w - from + reference);
    }
  }
  const Eigen::MatrixXd system = Eigen::MatrixXd::Identity(kStates, kStates) - transitions;
  const Eigen::VectorXd lengths = system.partialPivLu().solve(Eigen::VectorXd::Ones(kStates));
  return lengths(0);
}

double cusumThreshold(const SequentialDetectionOptions& options) {
  const double k = 0.5 * options.shift;
  const double target = std::max(options.recordings_between_false_alarms, 2.0);
  // Solved once per design (a detector per parameter and series asks again).
  static std::mutex mutex;
  static std::map<std::pair<double, double>, double> designed;
  std::lock_guard<std::mutex> lock(mutex);
  if (const auto it = designed.find({k, target}); it != designed.end()) return it->second;
  // Two symmetric sides alarm twice as often as one: each side needs twice the run length.
  double low = 0.0, high = 30.0;
  for (int i = 0; i < 30; ++i) {
    const double h = 0.5 * (low + high);
    (cusumRunLength(h, k) < 2.0 * target ? low : high) = h;
  }
  return designed[{k, target}] = 0.5 * (low + high);
}

SelfStartingCusum::SelfStartingCusum(const SequentialDetectionOptions& options)
    : options_(options), threshold_(cusumThreshold(options)), reference_(0.5 * options.shift) {}

void SelfStartingCusum::restartFrom(std::size_t first) {
  baseline_begin_ = first;
  high_ = low_ = 0.0;
  high_start_ = low_start_ = points_.size();
}

SelfStartingCusum::Baseline SelfStartingCusum::baselineFor(const TrendPoint& point, std::size_t m) const {
  // The in-control recordings before this one: their mean and scatter (Welford), their covariates' likewise,
  // and their reported variances' mean.
  Baseline b;
  b.m = m;
  double squares = 0.0, reported = 0.0, c_mean = 0.0, c_squares = 0.0, cross = 0.0;
  bool covariates = std::isfinite(point.covariate);
  for (std::size_t i = baseline_begin_, j = 1; i < baseline_begin_ + m; ++i, ++j) {
    const TrendPoint& p = points_[i];
    const double n = static_cast<double>(j);
    const double delta = p.value - b.mean;
    b.mean += delta / n;
    squares += delta * (p.value - b.mean);
    reported += p.std * p.std;
    covariates = covariates && std::isfinite(p.covariate);
    if (covariates) {
      const double c_delta = p.covariate - c_mean;
      c_mean += c_delta / n;
      c_squares += c_delta * (p.covariate - c_mean);
      cross += c_delta * (p.value - b.mean);
    }
  }
  b.reported = reported / static_cast<double>(m);
  const double spread = covariates ? std::sqrt(c_squares / static_cast<double>(m)) : 0.0;
  if (covariates && m >= 4 && spread >= options_.min_covariate_spread && c_squares > 0.0) {
    // The least-squares line in the covariate: its scatter about it has m - 2 degrees of freedom.
    b.slope = cross / c_squares;
    b.covariate_mean = c_mean;
    b.covariate_squares = c_squares;
    b.scatter2 = std::max(squares - b.slope * cross, 0.0) / static_cast<double>(m - 2);
    b.degrees = static_cast<double>(m - 2);
  } else {
    b.scatter2 = squares / static_cast<double>(m - 1);
    b.degrees = static_cast<double>(m - 1);
  }
  return b;
}

double SelfStartingCusum::normalScore(const TrendPoint& point, std::size_t m) const {
  const Baseline b = baselineFor(point, m);
  if (!(b.scatter2 > 0.0)) return std::numeric_limits<double>::quiet_NaN();  // nothing to standardise against
  // Recordings differ in length and so in their reported std: the scatter is the day-to-day variance tau^2
  // (what the stds miss) plus their mean variance, and this recording's own is tau^2 plus its std^2. With
  // the baseline's scatter alone, stds varying 3-fold gave one false alarm per 321 recordings instead of the
  // designed 500.
  const double own = point.std >= 0.0 && std::isfinite(point.std) ? point.std * point.std : 0.0;
  const double day_to_day = std::max(0.0, b.scatter2 - b.reported);
  // The baseline's own uncertainty at this recording: its mean's, or its line's at this covariate.
  double leverage = 1.0 / static_cast<double>(m);
  if (b.regressed()) leverage += std::pow(point.covariate - b.covariate_mean, 2) / b.covariate_squares;
  const double variance = std::max(day_to_day + own, 1e-6 * b.scatter2) + b.scatter2 * leverage;
  const double t = (point.value - b.predict(point.covariate)) / std::sqrt(variance);
  const boost::math::students_t student(b.degrees);
  // Far in the tails the t distribution's cdf rounds to 0 or 1: its complement keeps the precision there.
  const double upper = boost::math::cdf(boost::math::complement(student, std::abs(t)));
  const boost::math::normal normal;
  const double z = upper > 0.0 ? boost::math::quantile(boost::math::complement(normal, upper)) : 38.0;
  return t >= 0.0 ? z : -z;
}

ParameterChange SelfStartingCusum::describeAlarm(std::size_t index, bool rise) const {
  ParameterChange change;
  // With a covariate regressed out over the baseline, the recordings are compared at its mean: each value
  // moved along the baseline's line.
  const std::size_t m = index - baseline_begin_;
  const Baseline b = baselineFor(points_[index], m);
  std::vector<TrendPoint> adjusted = points_;
  if (b.regressed()) {
    for (TrendPoint& p : adjusted) {
      if (std::isfinite(p.covariate)) p.value -= b.slope * (p.covariate - b.covariate_mean);
    }
    change.slope = b.slope;
    change.covariate = b.covariate_mean;
  }
  // Dated by maximum likelihood among the recordings since the CUSUM last stood at 0: the split whose later
  // part's mean lies farthest from the baseline's, weighted by its length (the last zero alone dated a step
  // one recording early where the one before it happened to lie high).
  const std::size_t last_zero = std::min(rise ? high_start_ : low_start_, index);
  const double baseline = meanOf(adjusted, baseline_begin_, last_zero > baseline_begin_ ? last_zero : index);
  double best = -1.0;
  for (std::size_t j = last_zero; j <= index; ++j) {
    const double d = meanOf(adjusted, j, index + 1) - baseline;
    const double score = static_cast<double>(index + 1 - j) * d * d;
    if (score > best) {
      best = score;
      change.start_index = j;
    }
  }
  change.alarm_index = index;
  change.alarm_stamp = points_[index].stamp;
  change.start_stamp = points_[change.start_index].stamp;
  change.before = meanOf(adjusted, baseline_begin_, change.start_index);
  change.after = meanOf(adjusted, change.start_index, index + 1);
  change.statistic = rise ? high_ : low_;
  change.threshold = threshold_;
  change.shape = rampFitsBetter(adjusted, change.start_index, index + 1) ? "drift" : "step";
  return change;
}

DetectableChange SelfStartingCusum::smallestDetectableChange(int within, double probability,
                                                             int draws) const {
  DetectableChange d;
  d.within = within;
  d.probability = probability;
  const std::size_t m = points_.size() - baseline_begin_;
  d.baseline = m;
  if (m < static_cast<std::size_t>(std::max(options_.warm_up, 3)) || within < 1 || draws < 1) return d;
  // The baseline as the next recording would see it, at the baseline's own typical covariate.
  TrendPoint typical = points_.back();
  double c_sum = 0.0;
  std::size_t c_count = 0;
  for (std::size_t i = baseline_begin_; i < points_.size(); ++i) {
    if (std::isfinite(points_[i].covariate)) {
      c_sum += points_[i].covariate;
      ++c_count;
    }
  }
  typical.covariate =
      c_count == m ? c_sum / static_cast<double>(c_count) : std::numeric_limits<double>::quiet_NaN();
  const Baseline b = baselineFor(typical, m);
  if (!(b.scatter2 > 0.0)) return d;
  d.level = b.predict(typical.covariate);
  d.scatter = std::sqrt(b.scatter2);
  d.regressed = b.regressed();
  // Futures: `within` recordings shifted by `step`, each with a covariate and a reported std drawn from the
  // baseline's. The baseline's mean, line and scatter are estimates from m recordings: each future draws the
  // true ones from their distribution given the baseline (the scatter's scaled chi-square, the level's and
  // slope's normal errors, common to its recordings), then its recordings' deviations. With the estimates
  // taken as the truth, a 20-recording history promised 90 % and gave 77 %. The share alarmed in time.
  // A recording's deviation is one of the baseline's own (its distribution, skewed where the oil's swing is
  // in the values), scaled to the scatter drawn: a normal one made the stated change of a leakage recorded
  // without its temperature 1.5 times its level where half of that was found every time.
  const double m_count = static_cast<double>(m);
  std::vector<double> deviations;
  for (std::size_t i = baseline_begin_; i < points_.size(); ++i) {
    deviations.push_back((points_[i].value - b.predict(points_[i].covariate)) / d.scatter *
                         std::sqrt(m_count / b.degrees));
  }
  // The next recordings' covariates: the baseline's spread about where its newest ones lie (the season moves
  // the oil's temperature; drawn about the baseline's mean, the stated change of a series whose oil kept
  // warming was found in 79 % instead of 90 %).
  double shift = 0.0;
  if (b.regressed()) {
    const std::size_t recent = std::min<std::size_t>(m, 5);
    double sum = 0.0;
    for (std::size_t i = points_.size() - recent; i < points_.size(); ++i) sum += points_[i].covariate;
    shift = sum / static_cast<double>(recent) - b.covariate_mean;
  }
  const auto detected = [&](double step) {
    std::mt19937 rng(20260046);
    std::normal_distribution<double> normal(0.0, 1.0);
    std::chi_squared_distribution<double> chi_square(b.degrees);
    std::uniform_int_distribution<std::size_t> pick(baseline_begin_, points_.size() - 1);
    std::uniform_int_distribution<std::size_t> deviation(0, deviations.size() - 1);
    int alarmed = 0;
    for (int draw = 0; draw < draws; ++draw) {
      const double sigma = d.scatter * std::sqrt(b.degrees / std::max(chi_square(rng), 1e-12));
      const double level_error = sigma / std::sqrt(m_count) * normal(rng);
      const double slope_error = b.regressed() ? sigma / std::sqrt(b.covariate_squares) * normal(rng) : 0.0;
      SelfStartingCusum future = *this;
      for (int k = 0; k < within; ++k) {
        const TrendPoint& like = points_[pick(rng)];
        TrendPoint next = like;
        next.stamp = points_.back().stamp + (k + 1);
        if (b.regressed()) next.covariate += shift;
        const double offset = b.regressed() ? next.covariate - b.covariate_mean : 0.0;
        next.value = b.predict(next.covariate) + level_error + slope_error * offset + step +
                     sigma * deviations[deviation(rng)];
        if (future.add(next)) {
          ++alarmed;
          break;
        }
      }
    }
    return static_cast<double>(alarmed) / draws;
  };
  // Bisection on the step's size (rises; a fall is as large by symmetry of the scheme), in scatters.
  double low = 0.0, high = 1.0;
  while (detected(high * d.scatter) < probability && high < 1e4) high *= 2.0;
  if (!(high < 1e4)) return d;
  for (int i = 0; i < 8; ++i) {  // to 0.4 % of the bracket
    const double mid = 0.5 * (low + high);
    (detected(mid * d.scatter) < probability ? low : high) = mid;
  }
  d.step = high * d.scatter;
  return d;
}

std::optional<ParameterChange> SelfStartingCusum::add(const TrendPoint& point) {
  if (!std::isfinite(point.value) || !std::isfinite(point.stamp)) return std::nullopt;
  const std::size_t m = points_.size() - baseline_begin_;
  points_.push_back(point);
  const std::size_t index = points_.size() - 1;
  if (m < static_cast<std::size_t>(std::max(options_.warm_up, 3))) {
    high_start_ = low_start_ = index + 1;
    return std::nullopt;
  }
  const double u = normalScore(point, m);
  if (std::isnan(u)) return std::nullopt;
  if (high_ == 0.0) high_start_ = index;
  if (low_ == 0.0) low_start_ = index;
  high_ = std::max(0.0, high_ + u - reference_);
  low_ = std::max(0.0, low_ - u - reference_);
  if (high_ == 0.0) high_start_ = index + 1;
  if (low_ == 0.0) low_start_ = index + 1;
  const bool rise = high_ > threshold_, fall = low_ > threshold_;
  if (!rise && !fall) return std::nullopt;
  const ParameterChange change = describeAlarm(index, rise);
  // The new regime's baseline starts with the next recording: the ones that raised the alarm are a biased
  // sample of it (restarted from the change's start, a false alarm was followed by more: one per 404
  // recordings instead of the designed 500).
  restartFrom(index + 1);
  return change;
}

std::vector<ParameterChange> detectChangesSequentially(const std::vector<TrendPoint>& series,
                                                       const SequentialDetectionOptions& options,
                                                       DetectableChange* detectable) {
  const bool logarithms = options.relative && !series.empty() &&
                          std::all_of(series.begin(), series.end(), [](const TrendPoint& p) {
                            return !std::isfinite(p.value) || p.value > 0.0;
                          });
  if (logarithms) {
    std::vector<TrendPoint> logs = series;
    for (TrendPoint& p : logs) {
      p.std = p.std / p.value;
      p.value = std::log(p.value);
    }
    SequentialDetectionOptions linear = options;
    linear.relative = false;
    std::vector<ParameterChange> changes = detectChangesSequentially(logs, linear, detectable);
    for (ParameterChange& c : changes) {
      c.before = std::exp(c.before);
      c.after = std::exp(c.after);
    }
    if (detectable && std::isfinite(detectable->level)) {
      const double level = std::exp(detectable->level);
      detectable->step = level * std::expm1(detectable->step);
      detectable->scatter = level * detectable->scatter;
      detectable->level = level;
    }
    return changes;
  }
  SelfStartingCusum cusum(options);
  std::vector<ParameterChange> changes;
  std::vector<TrendPoint> finite;
  for (const TrendPoint& p : series) {
    if (std::isfinite(p.value) && std::isfinite(p.stamp)) finite.push_back(p);
    if (auto change = cusum.add(p)) changes.push_back(*change);
  }
  if (detectable) *detectable = cusum.smallestDetectableChange();
  // Each change described by its whole regime, up to the next change or the newest recording: its shape,
  // and the level reached (a drift's line at the regime's end), at the covariate's baseline mean where it
  // was regressed out. Only the description uses the later recordings; where and when the change was found
  // does not move.
  for (std::size_t c = 0; c < changes.size(); ++c) {
    const std::size_t begin = changes[c].start_index;
    const std::size_t end = c + 1 < changes.size() ? changes[c + 1].start_index : finite.size();
    if (end <= begin) continue;
    std::vector<TrendPoint> adjusted = finite;
    if (std::isfinite(changes[c].slope)) {
      for (TrendPoint& p : adjusted) {
        if (std::isfinite(p.covariate)) p.value -= changes[c].slope * (p.covariate - changes[c].covariate);
      }
    }
    const bool drift = rampFitsBetter(adjusted, begin, end);
    changes[c].shape = drift ? "drift" : "step";
    changes[c].after = drift ? lineEnd(adjusted, begin, end) : meanOf(adjusted, begin, end);
  }
  return changes;
}

std::string isoTime(double stamp) {
  const std::time_t seconds = static_cast<std::time_t>(std::floor(stamp));
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

std::string explainChange(const std::string& parameter, const std::string& unit,
                          const ParameterChange& change, const std::string& since) {
  // What a rise and a fall of each parameter usually mean on a die cushion.
  static const std::map<std::string, std::pair<const char*, const char*>> kReadings = {
      {"leakage_conductance",
       {"a worn piston seal or valve leakage", "a seal replaced or a leak path closed"}},
      {"bulk_modulus", {"the oil de-aerated or a hose replaced", "air entering the oil or a hose softening"}},
      {"air_volume", {"air entering the oil (a leaking suction line, foaming)", "the oil de-aerated"}},
      {"dead_volume",
       {"more oil volume in the circuit (a hose, an accumulator's precharge)",
        "less oil volume in the circuit"}},
      {"valve_flow_gain",
       {"the valve's metering edges eroding or its amplifier's gain drifting",
        "the valve's metering edges silting up or its amplifier's gain drifting"}},
      {"overlap",
       {"the spool's control edges covering more (wear of the bushing, a changed offset)",
        "the spool's control edges wearing round"}},
      {"tank_pressure", {"a clogging return filter or return line", "the return line cleared"}},
      {"natural_frequency",
       {"the valve responding faster", "the valve slowing (contamination, pilot pressure)"}},
      {"damping",
       {"the valve's spool moving less freely (contamination, friction)", "the valve less damped"}},
      {"dead_time", {"the valve or its amplifier answering later", "the valve answering sooner"}},
  };
  const bool rose = change.after > change.before;
  std::string reading = "check what was serviced or changed on the press then";
  for (const auto& [name, words] : kReadings) {
    if (parameter.size() >= name.size() &&
        parameter.compare(parameter.size() - name.size(), name.size(), name) == 0) {
      reading = rose ? words.first : words.second;
    }
  }
  std::string size;
  const double ratio = change.before != 0.0 ? change.after / change.before : 0.0;
  if (ratio >= 2.0) {
    size = formatted(FMT_STRING("has risen {:.1f}-fold"), ratio);
  } else if (ratio > 0.0 && ratio <= 0.5) {
    size = formatted(FMT_STRING("has fallen {:.1f}-fold"), 1.0 / ratio);
  } else if (ratio > 0.0) {
    size = (rose ? "has risen " : "has fallen ") +
           formatted(FMT_STRING("{:.0f} %"), 100.0 * std::abs(ratio - 1.0));
  } else {
    size = rose ? "has risen" : "has fallen";
  }
  return parameter + " " + size + " (" + formatted(FMT_STRING("{:.3g}"), change.before) + " -> " +
         formatted(FMT_STRING("{:.3g}"), change.after) + " " + unit + ", " +
         (change.shape == "step" ? "a step" : "a drift") + ") since " + since + ": " + reading;
}

}  // namespace die_cushion_ident
