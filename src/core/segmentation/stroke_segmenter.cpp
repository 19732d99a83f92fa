#include "die_cushion_ident/core/segmentation/stroke_segmenter.h"

#include <algorithm>
#include <cmath>

namespace die_cushion_ident {

namespace {
// A recording's last cycle is complete once the cushion is back within this share of its stroke from
// where the ram met it.
constexpr double kTopTolerance = 0.05;
}  // namespace

StrokeSegmenter::Step StrokeSegmenter::push(const GridSample& sample) {
  if (sample.discontinuity) {
    classifier_.reset();
    rest_samples_ = 0;
  }
  const StrokePhase phase = classifier_.classify(sample);
  const bool after_rest = previous_ == StrokePhase::kRest && rest_samples_ >= kMinRestSamples;
  const bool impact = phase == StrokePhase::kImpact || (phase == StrokePhase::kDrawing && after_rest);
  rest_samples_ = phase == StrokePhase::kRest ? rest_samples_ + 1 : 0;
  const bool start = impact && previous_ != StrokePhase::kImpact && previous_ != StrokePhase::kDrawing;
  if (start) {
    ++impacts_;
    returned_ = false;
    impact_x_ = deepest_ = std::isfinite(sample.x) ? sample.x : 0.0;
  }
  if (phase == StrokePhase::kReturn) returned_ = true;
  if (std::isfinite(sample.x)) {
    last_x_ = sample.x;
    deepest_ = std::max(deepest_, last_x_);
  }
  previous_ = phase;
  return {phase, start};
}

bool StrokeSegmenter::lastCycleComplete() const {
  const double stroke = deepest_ - impact_x_;
  return impacts_ > 0 && returned_ && stroke > 0.0 && last_x_ - impact_x_ <= kTopTolerance * stroke;
}

}  // namespace die_cushion_ident
