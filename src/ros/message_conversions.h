#pragma once

#include <ros/time.h>

#include <string>
#include <vector>

#include "die_cushion_ident/FrequencyResponse.h"
#include "die_cushion_ident/ValveModel.h"
#include "die_cushion_ident/core/servo_valve_fit.h"

namespace die_cushion_ident {

/// The measured points and, when the fit succeeded, the fitted curve on a fine log grid across the measured
/// band with its phase unwrapped like the points'. Shared by the node and analyze_bag.
FrequencyResponse toFrequencyResponseMsg(const std::vector<FrequencyResponsePoint>& points,
                                         const ServoValveFit& fit, const std::string& state,
                                         const ros::Time& stamp);

ValveModel toValveModelMsg(const ServoValveFit& fit, const ros::Time& stamp);

}  // namespace die_cushion_ident
