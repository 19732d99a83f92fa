#pragma once

#include <string>
#include <vector>

namespace die_cushion_ident {

/// What kind of doubt a warning of the analysis raises: tools and tests match warnings by this code, not by
/// their words (summary.yaml: `warning_codes`, one a warning, in the order of `warnings`).
enum class WarningCode {
  kGeometryDefault,    ///< a geometry key left at its default
  kTopicMissing,       ///< an input topic is not in the recording
  kMessagesRejected,   ///< messages not used: implausible, stamped far off, another definition, no position
  kMessagesDamaged,    ///< messages whose bytes do not decode
  kJointMissing,       ///< the configured joint is not in the position topic's JointState
  kJointAmbiguous,     ///< several joints and no joint_name: position[0] taken
  kBagDamaged,         ///< the bag is damaged, lost its index or was cut off
  kClockOffset,        ///< the topics' stamps are offset from each other (corrected, suspected or unknown)
  kSettingBiased,      ///< a configured setting leaves a resolution error on this recording
  kFiltersTooLong,     ///< the filter windows are longer than the shortest drawing
  kResolutionLimited,  ///< the recording's own resolution limits what the analysis can tell
  kSamplingTooCoarse,  ///< the sample period exceeds a tenth of the pressure's t63 (step test)
  kNotRun,             ///< a stage could not run: the result is partial
  kImplausibleParameter,   ///< an estimate outside its physical range: the model does not describe the data
  kUncertainParameter,     ///< an estimate the recording does not pin down
  kChangingParameter,      ///< a parameter that changes over the recording
  kChangeWithinRecording,  ///< an effect that starts within the recording
  kValveModel,             ///< the valve model the analysis had to assume or replace
  kNotFinite,              ///< figures that could not be computed, written as null
  kCyclesThinned,          ///< a long recording's cycle-based analyses judged evenly spaced cycles
  kOilTemperature,         ///< the oil temperature the model needs is missing in part or whole
  kNoPressStroke,  ///< a recording at rest (step test, sweep): the hydraulics are not identified from it
};

/// The code's name in summary.yaml ("geometry_default", ...).
const char* warningCodeName(WarningCode code);

struct AnalysisWarning {
  WarningCode code;
  std::string text;
};

/// Whether any of `warnings` has the code.
bool hasWarning(const std::vector<AnalysisWarning>& warnings, WarningCode code);

}  // namespace die_cushion_ident
