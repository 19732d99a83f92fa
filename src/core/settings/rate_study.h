#pragma once

// How the topics' message rates limit the free run (private to src/core/settings): the position's rate by
// Richardson's estimate over thinned position messages, the valve's by commands between its messages.

#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/settings/settings_from_recording.h"
#include "study_level.h"

namespace die_cushion_ident::settings_detail {

/// The error the position topic's rate leaves, by Richardson's estimate (rate_study.cpp).
void studyPositionRate(const Messages& messages, const IdentificationConfig& at_chosen,
                       const HydraulicModel& model, const ParameterVector& theta, const Level& native,
                       double allowed_change, double noise, SettingsChoice& choice);
/// [s] the velocity window the analysis derives over at `period` [s]: two periods, or the configured window
/// where it is configured (at least two periods).
double analysisVelocityWindow(double configured_window, bool configured, double period);
/// Whether commands a faster amplifier applied between valve messages `interval` [s] apart can move a valve
/// of natural frequency `frequency` [Hz] (`hold`: valve_command_hold).
bool commandsBetweenMessagesMatter(double frequency, double interval, double hold);
/// [Hz] the valve topic's rate that holds 4 messages a period of `frequency` [Hz].
double valveRecordingRate(double frequency);
/// The error the valve topic's rate leaves: commands between its messages (rate_study.cpp).
void studyValveRate(const Messages& messages, const IdentificationConfig& at_chosen,
                    const HydraulicModel& model, const ParameterVector& theta, const Level& native,
                    double allowed_change, double noise, int jobs, SettingsChoice& choice);

}  // namespace die_cushion_ident::settings_detail
