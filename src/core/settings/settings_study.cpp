#include "die_cushion_ident/core/settings/settings_study.h"

#include <algorithm>
#include <atomic>
#include <climits>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <thread>

#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {

struct Setting {
  RegressionForm form;
  int moving_average_width, derivative_width;
  double sample_period;
};

// The relative errors of the base parameters after `cycles` press cycles with one noise seed.
std::vector<double> relativeErrors(SimulatorConfig plant, IdentificationConfig config, const Setting& s,
                                   std::uint64_t seed, int cycles) {
  plant.seed = seed;
  config.regression_form = s.form;
  config.moving_average_width = s.moving_average_width;
  config.derivative_width = s.derivative_width;
  config.resampler.sample_period = s.sample_period;
  config.resampler.max_gap = std::max(config.resampler.max_gap, 5.0 * s.sample_period);
  config.velocity_window = std::max(config.velocity_window, 2.0 * s.sample_period);
  config.identification_period = std::max(1.0, std::round(config.identification_period / s.sample_period)) *
                                 s.sample_period;
  DieCushionSimulator simulator(plant);
  const std::vector<GridSample> grid =
      simulateGrid(simulator, cycles * simulator.program().cycleDuration(), config.resamplerConfig());
  // The whole run without forgetting, as analyze_bag fits a recording: the settings' own bias and scatter,
  // not the forgetting window's.
  const HydraulicEstimate e = fitOnCycles(grid, segmentStrokes(grid), config, INT_MIN, INT_MAX);
  std::vector<double> errors;
  for (int k = 0; k < HydraulicModel::kFirstEffect; ++k) {
    errors.push_back(e.parameters[k].value / simulator.trueParameter(e.parameters[k].name) - 1.0);
  }
  return errors;
}

const char* const kBaseNames[] = {"bulk_modulus", "valve_flow_gain", "dead_volume"};

}  // namespace

std::vector<SettingsStudyPoint> runSettingsStudy(const SimulatorConfig& plant, const IdentificationConfig& base,
                                                 const SettingsStudyOptions& options,
                                                 const std::function<void(int, int)>& progress) {
  std::vector<Setting> settings;
  for (RegressionForm form : {RegressionForm::kDerivative, RegressionForm::kIntegral}) {
    for (int b : options.moving_average_widths) {
      for (int d : options.derivative_widths) settings.push_back({form, b, d, base.resampler.sample_period});
    }
    for (double period : options.sample_periods) {
      if (period == base.resampler.sample_period) continue;  // already in the width grid
      settings.push_back({form, base.moving_average_width, base.derivative_width, period});
    }
  }
  const int total = static_cast<int>(settings.size()) * options.seeds;
  std::vector<std::vector<std::vector<double>>> errors(settings.size(),
                                                       std::vector<std::vector<double>>(options.seeds));
  std::atomic<int> next{0}, done{0};
  std::mutex report;
  const auto worker = [&]() {
    for (int job = next++; job < total; job = next++) {
      const int s = job / options.seeds, seed = job % options.seeds;
      errors[s][seed] = relativeErrors(plant, base, settings[s], 1000 + seed, options.cycles);
      const int finished = ++done;
      if (progress) {
        std::lock_guard<std::mutex> lock(report);
        progress(finished, total);
      }
    }
  };
  std::vector<std::thread> threads;
  for (int j = 0; j < std::max(1, options.jobs); ++j) threads.emplace_back(worker);
  for (auto& t : threads) t.join();

  std::vector<SettingsStudyPoint> points;
  for (std::size_t s = 0; s < settings.size(); ++s) {
    for (int k = 0; k < HydraulicModel::kFirstEffect; ++k) {
      SettingsStudyPoint p;
      p.form = settings[s].form;
      p.moving_average_width = settings[s].moving_average_width;
      p.derivative_width = settings[s].derivative_width;
      p.sample_period = settings[s].sample_period;
      p.parameter = kBaseNames[k];
      double sum = 0.0, squares = 0.0;
      for (const auto& run : errors[s]) {
        sum += run[k];
        squares += run[k] * run[k];
      }
      const int n = options.seeds;
      p.runs = n;
      p.bias = sum / n;
      p.std = n > 1 ? std::sqrt(std::max(0.0, (squares - n * p.bias * p.bias) / (n - 1))) : 0.0;
      points.push_back(p);
    }
  }
  return points;
}

namespace {

// Per form and widths (at the configured sampling time): the worst parameter's |bias| + 2 std, and the
// worst |bias| with its parameter.
struct Worst {
  double error = 0.0, bias = 0.0, bias_standard_error = 0.0;
  std::string parameter;
};
using ByWidths = std::map<std::pair<int, int>, Worst>;

struct StudyTable {
  ByWidths integral, derivative;
  std::map<double, double> period_error;  // integral form at the configured widths
};

StudyTable tabulate(const std::vector<SettingsStudyPoint>& points, const IdentificationConfig& base) {
  StudyTable table;
  for (const auto& p : points) {
    const double error = std::abs(p.bias) + 2.0 * p.std;
    if (p.sample_period == base.resampler.sample_period) {
      Worst& w = (p.form == RegressionForm::kIntegral
                      ? table.integral
                      : table.derivative)[{p.moving_average_width, p.derivative_width}];
      w.error = std::max(w.error, error);
      if (std::abs(p.bias) >= std::abs(w.bias)) {
        w.bias = p.bias;
        w.bias_standard_error = p.biasStandardError();
        w.parameter = p.parameter;
      }
    }
    if (p.form == RegressionForm::kIntegral && p.moving_average_width == base.moving_average_width &&
        p.derivative_width == base.derivative_width) {
      double& e = table.period_error[p.sample_period];
      e = std::max(e, error);
    }
  }
  return table;
}

// The first widths whose `key` is least.
template <typename Key>
ByWidths::const_iterator leastBy(const ByWidths& by_widths, Key key) {
  auto at = by_widths.begin();
  for (auto it = by_widths.begin(); it != by_widths.end(); ++it) {
    if (key(it->second) < key(at->second)) at = it;
  }
  return at;
}

}  // namespace

std::string recommendSettings(const std::vector<SettingsStudyPoint>& points,
                              const IdentificationConfig& base) {
  const StudyTable table = tabulate(points, base);
  const ByWidths& integral = table.integral;
  const ByWidths& derivative = table.derivative;
  if (integral.empty() || derivative.empty()) return "The study has no points at the configured sampling time.";
  const auto configured = integral.find({base.moving_average_width, base.derivative_width});
  const auto integral_best = leastBy(integral, [](const Worst& w) { return w.error; });
  // The integral form's bias may change sign over the widths (on the default cushion it is slightly positive
  // without a moving average and slightly negative at the widest windows): its range, each end with its widths.
  const auto integral_low = leastBy(integral, [](const Worst& w) { return w.bias; });
  const auto integral_high = leastBy(integral, [](const Worst& w) { return -w.bias; });
  const auto derivative_best = leastBy(derivative, [](const Worst& w) { return w.error; });
  const auto derivative_worst = leastBy(derivative, [](const Worst& w) { return -std::abs(w.bias); });
  double best_period = base.resampler.sample_period, best_period_error = 1e300;
  for (const auto& [period, error] : table.period_error) {
    if (error < best_period_error) {
      best_period_error = error;
      best_period = period;
    }
  }
  return formatted(
      FMT_STRING(
          "Integral form (the default): at the configured widths (b {}, d {}) the largest bias is "
          "{:+.2f} +- {:.2f} % ({}; +- the seeds' standard error); over the widths the largest bias "
          "of a parameter lies between {:+.2f} +- {:.2f} % ({} at b {}, d {}) and {:+.2f} +- {:.2f} % "
          "({} at b {}, d {}). Least bias + 2 std: b {}, d {} ({:.2f} %, worst parameter) - set "
          "moving_average_width {} and derivative_width {}. The paper's filtered-derivative form is "
          "biased by up to {:+.1f} % ({} at b {}, d {}), least at b {}, d {} ({:.2f} %). Sampling time "
          "at the configured widths: {:.4g} s gives the least bias + 2 std ({:.2f} %); keep it at most "
          "a tenth of the pressure's t63 (step test)."),
      base.moving_average_width, base.derivative_width,
      configured != integral.end() ? 100 * configured->second.bias : 0.0,
      configured != integral.end() ? 100 * configured->second.bias_standard_error : 0.0,
      configured != integral.end() ? configured->second.parameter : "not studied",
      100 * integral_low->second.bias, 100 * integral_low->second.bias_standard_error,
      integral_low->second.parameter, integral_low->first.first, integral_low->first.second,
      100 * integral_high->second.bias, 100 * integral_high->second.bias_standard_error,
      integral_high->second.parameter, integral_high->first.first, integral_high->first.second,
      integral_best->first.first, integral_best->first.second, 100 * integral_best->second.error,
      integral_best->first.first, integral_best->first.second, 100 * derivative_worst->second.bias,
      derivative_worst->second.parameter, derivative_worst->first.first, derivative_worst->first.second,
      derivative_best->first.first, derivative_best->first.second, 100 * derivative_best->second.error,
      best_period, 100 * best_period_error);
}

}  // namespace die_cushion_ident
