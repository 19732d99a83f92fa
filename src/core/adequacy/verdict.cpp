#include "die_cushion_ident/core/adequacy/verdict.h"

namespace die_cushion_ident {

const char* verdictName(Verdict verdict) {
  switch (verdict) {
    case Verdict::kMissing:
      return "missing";
    case Verdict::kNotNeeded:
      return "not_needed";
    case Verdict::kInconclusive:
      return "inconclusive";
  }
  return "?";
}

}  // namespace die_cushion_ident
