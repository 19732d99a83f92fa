#pragma once

#include <vector>

#include "die_cushion_ident/core/adequacy/model_assessment.h"
#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"

namespace die_cushion_ident {

/// The model fitted to each group of press cycles alone: the cycles split into at most `groups` contiguous
/// groups (at most one per cycle), each fitted without forgetting (fitOnCycles). Press cycles are the
/// recording's independent units: a residual stays correlated over a stroke (a shut valve carries an
/// error through the hold), not from one stroke to the next. The test whether a parameter changes over the
/// recording (parametersThatVaryOverTheRecording) reads these fits.
class CycleGroupFits {
 public:
  /// Fits the groups on up to `jobs` threads (0: one per core).
  CycleGroupFits(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                 const IdentificationConfig& config, int groups = 10, int jobs = 1);

  /// At least 4 groups, every one fitted (with the same parameters).
  bool valid() const { return valid_; }
  int size() const { return static_cast<int>(estimates_.size()); }
  /// Group g's first cycle and its own estimate.
  int firstCycle(int g) const { return first_[g]; }
  const HydraulicEstimate& estimate(int g) const { return estimates_[g]; }

 private:
  std::vector<HydraulicEstimate> estimates_;
  std::vector<int> first_;
  bool valid_ = false;
};

}  // namespace die_cushion_ident
