#pragma once

#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"
#include "die_cushion_ident/core/simulation/press_cycle.h"

namespace die_cushion_ident {

/// Free-run pressure error of the samples that fall into one region of operation.
struct RegionError {
  std::string dimension;         ///< "phase", "pressure", "velocity" or "opening"
  std::string label;             ///< "drawing", "100...150 bar", ...
  double low = 0.0, high = 0.0;  ///< bin edges in SI units (phases: the phase index twice)
  int samples = 0;
  double rms = 0.0;            ///< [Pa] free-run error RMS
  double mean_residual = 0.0;  ///< [Pa] measured - modelled: > 0 where the model under-predicts
  /// The error the model makes in the region, as opposed to what it carries in from before: the model
  /// restarted from the measurement every ModelAssessment::kMadeHorizon, its error RMS and mean residual
  /// [Pa] at the region's samples (NaN where not computed).
  double made_rms = std::numeric_limits<double>::quiet_NaN();
  double made_mean_residual = std::numeric_limits<double>::quiet_NaN();
};

/// Stroke phase and cycle of every grid sample: phases from StrokePhaseClassifier, a new cycle at every
/// impact (the ram hitting the cushion). Samples before the first impact belong to cycle -1 (a recording
/// that starts mid-stroke). A cycle is complete at the next impact, or, for the recording's last one, once
/// the return stroke has brought the cushion back to within 5 % of its stroke from where the ram met it.
struct StrokeSegmentation {
  std::vector<StrokePhase> phase;
  /// Grid index where cycle k begins (its impact), for every impact seen; cycles are contiguous stretches of
  /// the grid, so they are stored by their starts (not a cycle number per sample: 7 MB an hour).
  std::vector<std::size_t> cycle_start;
  std::size_t samples = 0;  ///< grid samples segmented
  int cycles = 0;           ///< complete cycles (indices 0 ... cycles-1)

  /// Grid indices [first, second) of cycles `first` ... `last`; first < 0 reaches back to the recording's
  /// start (samples before the first impact), last beyond the last impact to its end.
  std::pair<std::size_t, std::size_t> range(int first, int last) const;
  /// The cycle of grid sample i (-1 before the first impact).
  int cycleOf(std::size_t i) const;
};
StrokeSegmentation segmentStrokes(const std::vector<GridSample>& grid);

/// Whether a recording holds no press stroke: no impact began a cycle and the cushion travelled less than
/// a tenth of `stroke_length` [m] (a valve step test or sine sweep with the cushion at rest). At rest the
/// chamber's volume does not change, so the bulk modulus and the dead volume cannot be told apart (a fit
/// gave K' = -1.4e10 on a step test): such a recording is judged for its step responses and sweeps, never
/// as a press.
bool holdsNoPressStroke(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                        double stroke_length);

/// The identified model against the measurement over a recording: free run (FreeRunPressure) with the
/// given parameters, and where it fails.
struct ModelAssessment {
  int samples = 0;                    ///< grid samples compared (model running free, not re-anchored)
  double simulation_error_rms = 0.0;  ///< [Pa]
  /// [Pa] the free run at every kModelledStride-th grid sample (0, 5, 10, ...); NaN where it is not running
  static constexpr std::size_t kModelledStride = 5;
  /// [s] how long the model runs from the measurement before it is restarted, for the error each phase makes:
  /// a shut valve carries an error made while it closes through the whole bottom hold, and the free run
  /// alone would blame the hold.
  static constexpr double kMadeHorizon = 0.05;
  std::vector<float> modelled;
  std::vector<RegionError> by_phase, by_pressure, by_velocity, by_opening;
  /// The worst regions in words, by the error made there (made_rms), e.g. "the model under-predicts the
  /// pressure during bottom_hold by 3.8 bar on average within 50 ms of the measurement".
  std::vector<std::string> worst_regions;
};

ModelAssessment assessModel(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                            const HydraulicModel& model, const ParameterVector& parameters,
                            double min_pressure);

}  // namespace die_cushion_ident
