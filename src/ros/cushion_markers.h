#pragma once

#include <visualization_msgs/MarkerArray.h>

#include <string>

#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"
#include "die_cushion_ident/core/simulation/press_cycle.h"

namespace die_cushion_ident {

/// What the rviz view shows: the cylinder, the piston at its measured stroke, the oil column coloured by
/// pressure (blue at 0 bar, red at supply pressure) and the current estimates as text.
struct CushionView {
  double position = 0.0;          ///< x [m]
  double pressure = 0.0;          ///< p [Pa]
  double simulation_error = 0.0;  ///< free-run error RMS [Pa]
  StrokePhase phase = StrokePhase::kRest;
};

/// Markers in `frame` (z up, the cylinder's top at z = 0): ids 0 cylinder wall, 1 oil column, 2 piston,
/// 3 text of the estimates.
visualization_msgs::MarkerArray cushionMarkers(const CylinderGeometry& geometry, const CushionView& view,
                                               const HydraulicEstimate& estimate, const std::string& frame,
                                               const ros::Time& stamp);

}  // namespace die_cushion_ident
