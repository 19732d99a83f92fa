#pragma once

#include <cstdint>

namespace die_cushion_ident {

/// Phases of a die-cushion stroke, as the analysis classifies a recording and the simulator's press program
/// runs it; the names are used in reports and summary.yaml.
enum class StrokePhase : std::uint8_t { kRest, kImpact, kDrawing, kBottomHold, kRelease, kReturn };
constexpr int kStrokePhaseCount = 6;
const char* strokePhaseName(StrokePhase phase);

}  // namespace die_cushion_ident
