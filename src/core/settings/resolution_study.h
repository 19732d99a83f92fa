#pragma once

// The resolution study of SettingsFromRecording (private to src/core/settings): the model identified once
// at the finest period the recording supports, then run free at every period from the paper's 2 ms down.

#include <optional>
#include <string>
#include <vector>

#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"
#include "die_cushion_ident/core/fits/output_error_refinement.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/settings/settings_from_recording.h"
#include "die_cushion_ident/core/util/parallel_for.h"
#include "study_level.h"

namespace die_cushion_ident::settings_detail {

// The configured model identified on the whole grid at `period` (the survey's finest), and the position's
// clock offset refined by its free run there: the resolution study's start, and, alone, the offsets for an
// analysis whose settings are fixed (SettingsFromRecording::clockOffsets).
struct FinestFit {
  Level level;
  double shortest_drawing = 0.0;
  HydraulicEstimate fit;
  std::optional<OutputErrorFit> refined;
};

FinestFit identifyAndRefineOffset(const Messages& messages, double period, const HydraulicModel& model,
                                  int jobs, SettingsChoice& choice);

// What the resolution study decided.
struct StudyOutcome {
  double chosen_period = 0.0;
  double shortest_drawing = 0.0;
  bool studied = false;          // the configured model's fit was plausible, and its free run was studied
  bool resolved = false;         // a period's free run changed by less than the allowed share when it halved
  std::string implausible;       // the first implausible parameter, where the fit was
  bool no_press_stroke = false;  // the survey holds no press stroke (a step test or sweep at rest)
  double step_t63 = 0.0;         // [s] the first step test's t63 in such a survey (0: none found)
  double grid_error = 0.0;       // [Pa] the grid's own resolution error (the topics' rates not in it)
};

// The study itself: the model identified once, at the finest period, then run free at every period: how
// much the free run moves as the period halves is the grid's own error.
class ResolutionStudy {
 public:
  ResolutionStudy(const Messages& messages, std::vector<double> periods, int jobs, SettingsChoice& choice)
      : messages_(messages),
        periods_(std::move(periods)),
        jobs_(jobs),
        choice_(choice),
        model_(HydraulicModel::fromNames(choice.config.geometry, choice.config.effects,
                                         choice.config.custom_effects, choice.config.oil)),
        levels_(periods_.size()) {}

  StudyOutcome run(double allowed_change, double noise, double finest_interval, double configured_period);

 private:
  Level& level(std::size_t k) { return level(k, model_); }
  Level& level(std::size_t k, const HydraulicModel& model) {
    if (levels_[k].grid.empty())
      levels_[k] = levelAt(atPeriod(choice_.config, periods_[k], shortest_drawing_), messages_);
    if (levels_[k].t.empty()) runFree(model, theta_, choice_.config.min_pressure, &levels_[k]);
    return levels_[k];
  }
  // Levels k and k + 1 side by side (each its grid and free run), the second thread on its own copy of the
  // model (a user's formula holds one parser per instance). The same levels as one after the other.
  void prepareLevels(std::size_t k) {
    const HydraulicModel own(model_);
    parallelFor(2, jobs_, [&](std::size_t i) { level(k + i, i == 0 ? model_ : own); });
  }
  void identifyAtTheFinestPeriod(StudyOutcome& outcome);
  void chooseForTheStepTest(StudyOutcome& outcome);
  std::size_t halveUntilSettled(double allowed_change, bool* resolved);
  void judgeTheFinestPeriod(std::size_t chosen, double allowed_change, double noise, double finest_interval,
                            bool* resolved);

  const Messages& messages_;
  std::vector<double> periods_;
  int jobs_;
  SettingsChoice& choice_;
  HydraulicModel model_;
  std::vector<Level> levels_;
  HydraulicEstimate fit_;
  ParameterVector theta_;
  double shortest_drawing_ = 0.0;
};

}  // namespace die_cushion_ident::settings_detail
