#pragma once

#include <limits>

namespace die_cushion_ident {

/// The named signals of the volume balance (shared/CONTRACT.md), SI units; custom effects see exactly these.
struct HydraulicSignals {
  double t = 0.0;   ///< time [s]
  double p = 0.0;   ///< chamber pressure, gauge [Pa]
  double dp = 0.0;  ///< pressure rate [Pa/s]
  double x = 0.0;   ///< cushion stroke, 0 at the upper end, growing downwards [m]
  double v = 0.0;   ///< stroke velocity dx/dt [m/s]
  double u = 0.0;   ///< valve command voltage [V]
  double y = 0.0;   ///< spool position, normalised [-1, 1]; > 0 drains to tank
  double V = 0.0;   ///< chamber volume V_dead + A (s - x) [m^3]
  /// The oil's temperature [degC] (REP 103, as sensor_msgs/Temperature has it); NaN where none is measured.
  /// Read by the oil_temperature effect only; not offered to custom formulas.
  double T = std::numeric_limits<double>::quiet_NaN();
  /// The spool position that decides which port of the valve is open; NaN: y itself. The regression sets
  /// it from the neighbouring samples of a measured spool, whose own noise must not pick the port
  /// (doc/equations.md, "Spool noise at the port's kink"). Not offered to custom formulas.
  double port_side = std::numeric_limits<double>::quiet_NaN();
};

/// Cylinder and supply data that are known from the drawing, not identified.
struct CylinderGeometry {
  double piston_area = 0.05;       ///< A [m^2]
  double stroke_length = 0.25;     ///< s [m]
  double supply_pressure = 120e5;  ///< p_S [Pa]
};

constexpr double kAtmosphericPressure = 101325.0;  ///< p_atm [Pa]

}  // namespace die_cushion_ident
