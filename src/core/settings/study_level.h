#pragma once

// What the studies of SettingsFromRecording share (private to src/core/settings): the paper's windows and
// candidate periods, the survey's grid at a period, the resolution study's levels (one sample period each:
// the survey on its grid and one model run free on it) and Richardson's estimate of the error left.

#include <chrono>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "die_cushion_ident/core/adequacy/model_assessment.h"
#include "die_cushion_ident/core/estimation/identification_config.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"

namespace die_cushion_ident::settings_detail {

using Messages = std::vector<std::pair<InputStream, StreamSample>>;

// The paper's filter windows in time (31 and 25 samples at 2 ms) and identification period.
constexpr double kMovingAverageWindow = 0.062;   // [s]
constexpr double kDerivativeWindow = 0.050;      // [s]
constexpr double kIdentificationPeriod = 0.010;  // [s]
// The candidate periods: the paper's 2 ms halved down to 0.25 ms.
constexpr double kCoarsestPeriod = 0.002;
constexpr double kFinestPeriod = 0.00025;

int oddSamples(double seconds, double period, int lowest);
double median(std::vector<double> values);
/// The configuration at `period` with the paper's windows in time (study_level.cpp).
IdentificationConfig atPeriod(IdentificationConfig c, double period, double shortest_drawing);
double secondsSince(std::chrono::steady_clock::time_point start);
std::vector<GridSample> gridAt(const IdentificationConfig& config, const Messages& messages);

// One sample period of the study: the survey on its grid, and one model run free on it.
struct Level {
  double period = 0.0;
  std::vector<GridSample> grid;
  StrokeSegmentation strokes;
  std::vector<double> t, modelled;  // the free run, NaN where it is not running
  double error_rms = std::numeric_limits<double>::quiet_NaN();
  double numerical_error = std::numeric_limits<double>::quiet_NaN();  // [Pa] against a 20 times tighter run
};

Level levelAt(const IdentificationConfig& config, const Messages& messages);
/// The shortest drawing phase (impact included) of the complete cycles [s], 0 where there is none.
double shortestDrawing(const Level& level);
/// The free run of `theta` on the level's grid.
void runFree(const HydraulicModel& model, const ParameterVector& theta, double min_pressure, Level* level);
/// The free run's own numerical error on a level already run (study_level.cpp).
double numericalError(const HydraulicModel& model, const ParameterVector& theta, double min_pressure,
                      Level* level);
/// rms difference of two levels' free runs at the samples both have.
double changeBetween(const Level& coarse, const Level& fine, double fine_period);

// Richardson's estimate of the error left at a step from how the result changed as the step halved to it
// (`change`) and on the halving before (`earlier_change`): change / (2^q - 1), the order q = log2 of their
// ratio, held between 1 and 4 (1 where the earlier change is unknown).
struct Richardson {
  double order = 1.0;
  double error = 0.0;
  // The step at which the error would fall to `allowed`, at the same order, from `step`.
  double stepFor(double allowed, double step) const { return step * std::pow(allowed / error, 1.0 / order); }
};

Richardson richardson(double change, double earlier_change);

/// The message rate [Hz] to record at for a sample interval [s], rounded up to 100 Hz.
double recordingRate(double interval);

}  // namespace die_cushion_ident::settings_detail
