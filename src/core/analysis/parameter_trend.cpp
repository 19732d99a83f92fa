#include "die_cushion_ident/core/analysis/parameter_trend.h"

#include <boost/math/distributions/fisher_f.hpp>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <map>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {

constexpr double kMedianChiSquare1 = 0.45493642311957283;  // median of chi-square with 1 degree of freedom

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

// The variance between recordings that the stds do not explain, from the second differences
// e_i = x_i - 2 x_{i-1} + x_{i-2}: var e_i = v_i + 4 v_{i-1} + v_{i-2} with v = std^2 + tau^2, so
// tau^2 = (median e^2 / median chi2_1 - median(std_i^2 + 4 std_{i-1}^2 + std_{i-2}^2)) / 6. A ramp cancels
// in e; a step disturbs two of them, which the medians ignore.
double dayToDayVariance(const std::vector<TrendPoint>& s) {
  std::vector<double> squares, explained;
  for (std::size_t i = 2; i < s.size(); ++i) {
    const double e = s[i].value - 2.0 * s[i - 1].value + s[i - 2].value;
    squares.push_back(e * e);
    explained.push_back(s[i].std * s[i].std + 4.0 * s[i - 1].std * s[i - 1].std + s[i - 2].std * s[i - 2].std);
  }
  if (squares.empty()) return 0.0;
  return std::max(0.0, (median(squares) / kMedianChiSquare1 - median(explained)) / 6.0);
}

// Weighted least squares of x on the columns (1, h): the residual sum of squares and the coefficients.
struct LineFit {
  double rss = 0.0, intercept = 0.0, slope = 0.0;
};

LineFit fitLine(const std::vector<double>& x, const std::vector<double>& h, const std::vector<double>& w) {
  double sw = 0, sh = 0, shh = 0, sx = 0, shx = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sw += w[i];
    sh += w[i] * h[i];
    shh += w[i] * h[i] * h[i];
    sx += w[i] * x[i];
    shx += w[i] * h[i] * x[i];
  }
  LineFit f;
  const double det = sw * shh - sh * sh;
  if (det > 0.0) {
    f.slope = (sw * shx - sh * sx) / det;
    f.intercept = (sx - f.slope * sh) / sw;
  } else {
    f.intercept = sx / sw;
  }
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double r = x[i] - f.intercept - f.slope * h[i];
    f.rss += w[i] * r * r;
  }
  return f;
}

}  // namespace

std::optional<ParameterChange> detectParameterChange(const std::vector<TrendPoint>& series,
                                                     const ChangeDetectionOptions& options) {
  const std::size_t n = series.size();
  const std::size_t first_change = static_cast<std::size_t>(std::max(options.min_baseline, 2));
  if (n < first_change + 3) return std::nullopt;
  for (const auto& p : series) {
    if (!std::isfinite(p.stamp) || !std::isfinite(p.value) || !(p.std >= 0.0) || !std::isfinite(p.std)) {
      return std::nullopt;
    }
  }
  const double tau2 = dayToDayVariance(series);
  std::vector<double> x(n), w(n), flat(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = series[i].value;
    const double variance = series[i].std * series[i].std + tau2;
    if (!(variance > 0.0)) return std::nullopt;  // identical values with zero stds: nothing to test
    w[i] = 1.0 / variance;
  }
  const double rss0 = fitLine(x, flat, w).rss;

  const std::size_t change_points = n - first_change;
  const double tests = 2.0 * static_cast<double>(change_points);
  // tau^2 comes from only n - 2 second differences, through a median (about 64 % efficient): the
  // statistic is then F(1, nu) rather than chi-square(1), which keeps short series from false alarms.
  const double nu = std::max(2.0, std::floor(0.64 * static_cast<double>(n - 2)));
  const boost::math::fisher_f_distribution<double> f(1.0, nu);
  const double threshold = boost::math::quantile(boost::math::complement(f, options.false_alarm_rate / tests));

  std::optional<ParameterChange> best;
  std::vector<double> h(n);
  for (std::size_t k = first_change; k < n; ++k) {
    for (const char* shape : {"step", "drift"}) {
      const bool step = std::string(shape) == "step";
      for (std::size_t i = 0; i < n; ++i) {
        h[i] = i < k ? 0.0 : (step ? 1.0 : series[i].stamp - series[k - 1].stamp);
      }
      const LineFit fit = fitLine(x, h, w);
      const double statistic = rss0 - fit.rss;
      if (!(statistic > threshold) || (best && statistic <= best->statistic)) continue;
      ParameterChange c;
      c.shape = shape;
      c.start_index = k;
      c.start_stamp = series[k].stamp;
      c.before = fit.intercept;
      c.after = fit.intercept + fit.slope * h[n - 1];
      c.statistic = statistic;
      c.threshold = threshold;
      c.day_to_day_std = std::sqrt(tau2);
      best = c;
    }
  }
  return best;
}

std::string isoTime(double stamp) {
  const std::time_t seconds = static_cast<std::time_t>(std::floor(stamp));
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

std::string explainChange(const std::string& parameter, const std::string& unit, const ParameterChange& change,
                          const std::string& since) {
  // What a rise and a fall of each parameter usually mean on a die cushion.
  static const std::map<std::string, std::pair<const char*, const char*>> kReadings = {
      {"leakage_conductance", {"a worn piston seal or valve leakage", "a seal replaced or a leak path closed"}},
      {"bulk_modulus", {"the oil de-aerated or a hose replaced", "air entering the oil or a hose softening"}},
      {"air_volume", {"air entering the oil (a leaking suction line, foaming)", "the oil de-aerated"}},
      {"dead_volume", {"more oil volume in the circuit (a hose, an accumulator's precharge)",
                       "less oil volume in the circuit"}},
      {"valve_flow_gain", {"the valve's metering edges eroding or its amplifier's gain drifting",
                           "the valve's metering edges silting up or its amplifier's gain drifting"}},
      {"overlap", {"the spool's control edges covering more (wear of the bushing, a changed offset)",
                   "the spool's control edges wearing round"}},
      {"tank_pressure", {"a clogging return filter or return line", "the return line cleared"}},
      {"natural_frequency", {"the valve responding faster", "the valve slowing (contamination, pilot pressure)"}},
      {"damping", {"the valve's spool moving less freely (contamination, friction)", "the valve less damped"}},
      {"dead_time", {"the valve or its amplifier answering later", "the valve answering sooner"}},
  };
  const bool rose = change.after > change.before;
  std::string reading = "check what was serviced or changed on the press then";
  for (const auto& [name, words] : kReadings) {
    if (parameter.size() >= name.size() && parameter.compare(parameter.size() - name.size(), name.size(), name) == 0) {
      reading = rose ? words.first : words.second;
    }
  }
  std::string size;
  const double ratio = change.before != 0.0 ? change.after / change.before : 0.0;
  if (ratio >= 2.0) {
    size = formatted("has risen %.1f-fold", ratio);
  } else if (ratio > 0.0 && ratio <= 0.5) {
    size = formatted("has fallen %.1f-fold", 1.0 / ratio);
  } else if (ratio > 0.0) {
    size = formatted(rose ? "has risen %.0f %%" : "has fallen %.0f %%", 100.0 * std::abs(ratio - 1.0));
  } else {
    size = rose ? "has risen" : "has fallen";
  }
  return parameter + " " + size + " (" + formatted("%.3g", change.before) + " -> " +
         formatted("%.3g", change.after) + " " + unit + ", " +
         (change.shape == "step" ? "a step" : "a drift") + ") since " + since + ": " + reading;
}

}  // namespace die_cushion_ident
