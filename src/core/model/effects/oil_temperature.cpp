#include "die_cushion_ident/core/model/effects/oil_temperature.h"

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

std::string OilTemperature::explanation() const {
  return formatted(
      FMT_STRING(
          "the oil's temperature: its bulk modulus falls as it warms (linear, about -0.4 %/K) and a laminar "
          "leakage grows with its falling viscosity ({:+.1f} %/K, configured)"),
      100.0 * law_.leakage_coefficient);
}

std::string OilTemperature::explanationFor(double alpha) const {
  return formatted(FMT_STRING("the bulk modulus follows the oil temperature at {:+.2f} %/K, and a laminar "
                              "leakage its viscosity at "
                              "{:+.1f} %/K (configured)"),
                   100.0 * alpha, 100.0 * law_.leakage_coefficient);
}

}  // namespace die_cushion_ident
