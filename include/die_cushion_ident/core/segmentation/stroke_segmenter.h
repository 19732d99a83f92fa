#pragma once

#include <cstddef>
#include <limits>

#include "die_cushion_ident/core/segmentation/stroke_phase_classifier.h"

namespace die_cushion_ident {

/// segmentStrokes one sample at a time: the stroke phase of each grid sample and whether it begins a cycle
/// (an impact, or drawing after a rest of a few samples: a recording may start mid-stroke), for a store that
/// must cut the grid into cycles while it is read (EvenlyThinnedCycles).
class StrokeSegmenter {
 public:
  struct Step {
    StrokePhase phase;
    bool cycle_start;  ///< this sample is the impact that begins a cycle
  };
  Step push(const GridSample& sample);
  /// Cycles begun so far (impacts seen).
  int impacts() const { return impacts_; }
  /// Whether the last cycle begun is complete: the cushion went back up to within 5 % of its stroke from
  /// where the ram met it.
  bool lastCycleComplete() const;

 private:
  // A drawing seen first is not an impact, only drawing after this many samples at rest is (the classifier
  // calls its very first sample rest, whatever the cushion does).
  static constexpr int kMinRestSamples = 5;
  StrokePhaseClassifier classifier_;
  StrokePhase previous_ = StrokePhase::kRest;
  int rest_samples_ = 0;
  int impacts_ = 0;
  bool returned_ = false;
  double impact_x_ = 0.0, deepest_ = 0.0, last_x_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace die_cushion_ident
