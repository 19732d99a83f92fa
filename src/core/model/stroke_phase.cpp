#include "die_cushion_ident/core/model/stroke_phase.h"

namespace die_cushion_ident {

const char* strokePhaseName(StrokePhase phase) {
  switch (phase) {
    case StrokePhase::kRest:
      return "rest";
    case StrokePhase::kImpact:
      return "impact";
    case StrokePhase::kDrawing:
      return "drawing";
    case StrokePhase::kBottomHold:
      return "bottom_hold";
    case StrokePhase::kRelease:
      return "release";
    case StrokePhase::kReturn:
      return "return";
  }
  return "?";
}

}  // namespace die_cushion_ident
