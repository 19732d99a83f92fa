#pragma once

#include <cmath>

#include <functional>
#include <string>
#include <vector>

#include "die_cushion_ident/core/estimation/identification_config.h"
#include "die_cushion_ident/core/simulation/die_cushion_simulator.h"

namespace die_cushion_ident {

/// One setting of the paper's study (§5.1, §5.2) and what it does to one parameter over the noise seeds.
struct SettingsStudyPoint {
  RegressionForm form = RegressionForm::kIntegral;
  int moving_average_width = 31;  ///< [samples]
  int derivative_width = 25;      ///< [samples]
  double sample_period = 0.002;   ///< [s]
  std::string parameter;
  double bias = 0.0;  ///< mean relative error over the seeds (0.01 = 1 %)
  double std = 0.0;   ///< standard deviation of the relative error over the seeds
  int runs = 0;
  /// How far the bias itself is uncertain from the seeds' scatter: std / sqrt(runs).
  double biasStandardError() const { return runs > 1 ? std / std::sqrt(static_cast<double>(runs)) : 0.0; }
};

struct SettingsStudyOptions {
  std::vector<int> moving_average_widths = {1, 11, 21, 31, 41, 51};
  std::vector<int> derivative_widths = {5, 15, 25, 35};
  std::vector<double> sample_periods = {0.001, 0.002, 0.005};  ///< studied at the configured widths
  /// Noise seeds per setting. A run's dead volume scatters by up to 3.4 % at the widest windows (1.75 % at
  /// the paper's): 64 seeds know its bias to about 0.4 %, 16 only to 0.8 %, no better than the 1 % asked of it.
  int seeds = 64;
  int cycles = 3;   ///< press cycles per run
  int jobs = 2;     ///< threads
};

/// Runs the simulated press `plant` (its parameters and sensor noise: the press's own, identified) through
/// the identification with every setting: each moving-average width with each derivative width at the
/// configured sampling time, and each sampling time at the configured widths, for both regression forms
/// and `seeds` noise seeds each; returns bias and std of every base parameter's relative error.
/// `progress` (may be empty) is told "done of total" runs; runs go in parallel on `jobs` threads.
std::vector<SettingsStudyPoint> runSettingsStudy(const SimulatorConfig& plant, const IdentificationConfig& base,
                                                 const SettingsStudyOptions& options,
                                                 const std::function<void(int, int)>& progress = {});

/// The recommendation in words: the integral form's largest bias over the widths, the widths at which the
/// paper's form is least biased, and the sampling time the std and bias allow.
std::string recommendSettings(const std::vector<SettingsStudyPoint>& points, const IdentificationConfig& base);

}  // namespace die_cushion_ident
