#include "die_cushion_ident/core/adequacy/analysis_warning.h"

#include <algorithm>

namespace die_cushion_ident {

const char* warningCodeName(WarningCode code) {
  switch (code) {
    case WarningCode::kGeometryDefault:
      return "geometry_default";
    case WarningCode::kTopicMissing:
      return "topic_missing";
    case WarningCode::kMessagesRejected:
      return "messages_rejected";
    case WarningCode::kMessagesDamaged:
      return "messages_damaged";
    case WarningCode::kJointMissing:
      return "joint_missing";
    case WarningCode::kJointAmbiguous:
      return "joint_ambiguous";
    case WarningCode::kBagDamaged:
      return "bag_damaged";
    case WarningCode::kClockOffset:
      return "clock_offset";
    case WarningCode::kSettingBiased:
      return "setting_biased";
    case WarningCode::kFiltersTooLong:
      return "filters_too_long";
    case WarningCode::kResolutionLimited:
      return "resolution_limited";
    case WarningCode::kSamplingTooCoarse:
      return "sampling_too_coarse";
    case WarningCode::kNotRun:
      return "not_run";
    case WarningCode::kImplausibleParameter:
      return "implausible_parameter";
    case WarningCode::kUncertainParameter:
      return "uncertain_parameter";
    case WarningCode::kChangingParameter:
      return "changing_parameter";
    case WarningCode::kChangeWithinRecording:
      return "change_within_recording";
    case WarningCode::kValveModel:
      return "valve_model";
    case WarningCode::kNotFinite:
      return "not_finite";
    case WarningCode::kCyclesThinned:
      return "cycles_thinned";
    case WarningCode::kOilTemperature:
      return "oil_temperature";
    case WarningCode::kNoPressStroke:
      return "no_press_stroke";
  }
  return "unknown";
}

bool hasWarning(const std::vector<AnalysisWarning>& warnings, WarningCode code) {
  return std::any_of(warnings.begin(), warnings.end(),
                     [code](const AnalysisWarning& w) { return w.code == code; });
}

}  // namespace die_cushion_ident
