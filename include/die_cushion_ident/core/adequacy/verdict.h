#pragma once

#include <ostream>

namespace die_cushion_ident {

/// The judgement on an extension of the model (a library effect, a pair, a formula) from held-out cycles.
enum class Verdict {
  kMissing,       ///< it removes enough of the free-run error, consistently over the cycles
  kNotNeeded,     ///< it changes the error too little, or its fit is outside the physical range
  kInconclusive,  ///< neither: too few cycles, or not consistent over them
};

/// "missing", "not_needed", "inconclusive": the words of summary.yaml and the EffectRanking message.
const char* verdictName(Verdict verdict);

inline std::ostream& operator<<(std::ostream& out, Verdict verdict) { return out << verdictName(verdict); }

}  // namespace die_cushion_ident
