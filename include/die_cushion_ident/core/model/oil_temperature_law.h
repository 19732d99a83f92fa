#pragma once

#include <cmath>
#include <limits>

namespace die_cushion_ident {

/// How the oil's properties follow its temperature (doc/equations.md, "The oil's temperature").
///
/// Temperatures are in degrees Celsius, as REP 103 and sensor_msgs/Temperature have them (no conversion
/// where they enter); a difference of 1 degC is 1 K, and the coefficients are per kelvin. With T0 the
/// temperature the model's parameters hold at (temperature_origin):
///
///   bulk modulus     K'(T) = K'(T0) (1 + alpha (T - T0))              alpha = bulk_modulus_coefficient [1/K]
///   laminar leakage  G(T)  = G(T0) exp(E (1/T0_K - 1/T_K)),  E = beta (T_ref + 273.15 K)^2
///                                                                    beta  = leakage_coefficient [1/K]
///
/// The leakage through a narrow gap is inversely proportional to the oil's viscosity, which follows an
/// Arrhenius law (the only place kelvin appear: T_K = T + 273.15) with the slope beta at the reference
/// temperature; against Walther's ASTM D341 line of an ISO VG 46 oil it is within 5.4 % over 25-60 degC (a
/// plain exponential with the same slope: 10 %). The valve's orifice flow barely depends on viscosity and is
/// left alone. The defaults are a mineral hydraulic oil's (ISO VG 46, viscosity index ~100; doc/equations.md
/// gives the data): alpha is identified from a recording whose oil warms (effect oil_temperature), beta
/// always taken as configured.
struct OilTemperatureLaw {
  /// [degC] the temperature every analysis also reports its parameters at.
  double reference_temperature = 40.0;
  /// [degC] the temperature the model's parameters hold at; NaN: reference_temperature. The offline
  /// analysis sets it to the recording's mean oil temperature (its fits are then centred: the coefficient's
  /// column is orthogonal to the bulk modulus's, and an isothermal recording leaves K' well determined).
  double temperature_origin = std::numeric_limits<double>::quiet_NaN();
  /// alpha [1/K]: the effective bulk modulus's relative change per kelvin (oil with its hoses and steel).
  double bulk_modulus_coefficient = -0.004;
  double bulk_modulus_coefficient_std = 0.0015;  ///< [1/K] its uncertainty where it is not identified
  /// beta [1/K]: a laminar leakage conductance's relative change per kelvin (1 / viscosity).
  double leakage_coefficient = 0.045;
  double leakage_coefficient_std = 0.008;  ///< [1/K]

  /// T0 [degC].
  double origin() const {
    return std::isnan(temperature_origin) ? reference_temperature : temperature_origin;
  }
  /// K'(T0) / K'(T) for coefficient `alpha` at oil temperature `celsius` (1 where the temperature is not
  /// known), and its derivative in alpha. The factor is kept finite for any alpha the estimator may pass
  /// through (1 + alpha dT is held above 0.2).
  void compressibility(double celsius, double alpha, double* factor, double* slope) const;
  /// G(T) / G(T0) at `celsius` (1 where the temperature is not known).
  double laminarFlowFactor(double celsius) const { return laminarFlowRatio(origin(), celsius); }
  /// G(to) / G(from) [-], and (optional) its derivative in beta [K].
  double laminarFlowRatio(double from, double to, double* per_beta = nullptr) const;
};

}  // namespace die_cushion_ident
