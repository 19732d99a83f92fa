#pragma once

#include <ros/time.h>

#include <string>
#include <vector>

#include "die_cushion_ident/FrequencyResponse.h"
#include "die_cushion_ident/ModelComparison.h"
#include "die_cushion_ident/ParameterEstimate.h"
#include "die_cushion_ident/ValveModel.h"
#include "die_cushion_ident/core/hydraulic_model.h"
#include "die_cushion_ident/core/press_cycle.h"
#include "die_cushion_ident/core/servo_valve_fit.h"
#include "die_cushion_ident/core/uniform_resampler.h"

namespace die_cushion_ident {

/// The measured points and, when the fit succeeded, the fitted curve on a fine log grid across the measured
/// band with its phase unwrapped like the points'. Shared by the node and analyze_bag.
FrequencyResponse toFrequencyResponseMsg(const std::vector<FrequencyResponsePoint>& points,
                                         const ServoValveFit& fit, const std::string& state,
                                         const ros::Time& stamp);

ValveModel toValveModelMsg(const ServoValveFit& fit, const ros::Time& stamp);

/// The model's effects, parameter names and units with `values` and `stds` (model order), the base
/// parameters also as named fields. Counters and the equation error are left for the caller. Shared by the
/// node's ~estimate, analyze_bag's series and the simulator's ~truth.
ParameterEstimate toParameterEstimateMsg(const HydraulicModel& model, const std::vector<double>& values,
                                         const std::vector<double>& stds, const ros::Time& stamp);

/// One sample of measured against modelled (free-run) pressure with the signals and the stroke phase.
ModelComparison toModelComparisonMsg(const GridSample& sample, double modelled_pressure, StrokePhase phase,
                                     double simulation_error_rms, double equation_error_rms,
                                     const ros::Time& stamp);

}  // namespace die_cushion_ident
