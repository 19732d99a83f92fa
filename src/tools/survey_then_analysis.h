#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "die_cushion_ident/core/analysis/offline_analysis.h"
#include "die_cushion_ident/core/settings/settings_from_recording.h"
#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

// Where the messages go: the survey keeps the recording's first seconds; once it is complete (or the bag
// ends) it chooses the settings, and the analysis starts with them on what was kept, then takes the rest as
// it comes. Without a survey (--fixed-settings, a second reading) the analysis takes them from the start.
class SurveyThenAnalysis {
 public:
  SurveyThenAnalysis(const IdentificationConfig& config, const std::set<std::string>& configured, bool survey,
                     int jobs, const std::function<void(const std::string&)>& log)
      : config_(config), jobs_(jobs), log_(log) {
    // Without a survey the analysis starts at once; the survey's messages still give the clock offsets
    // where they are to be estimated.
    if (survey || !config.topicDelaysSet()) {
      survey_ = std::make_unique<SettingsFromRecording>(config, configured);
      survey_->setJobs(jobs);
    }
    if (!survey) start(config);
  }
  /// [s] how long the bag's index says the recording is (a hint for reserving memory).
  void expect(double seconds) {
    expected_ = seconds;
    if (analysis_) analysis_->reserve(expected_, 48 * 3600.0);
  }
  void push(InputStream stream, const StreamSample& sample) {
    if (!analysis_) {
      if (!survey_->push(stream, sample)) chooseAndStart();
      return;
    }
    analysis_->push(stream, sample);
    if (survey_) survey_->push(stream, sample);  // keeps nothing once it has its seconds
  }
  /// The optional oil temperature: kept while the survey runs (it does not need it), then the analysis's.
  void pushOilTemperature(const StreamSample& sample) {
    if (!analysis_) {
      survey_oil_.push_back(sample);
      return;
    }
    analysis_->pushOilTemperature(sample);
  }
  /// The analysis, its settings chosen (at the end of a recording shorter than the survey, now).
  OfflineAnalysis& analysis() {
    if (!analysis_) chooseAndStart();
    return *analysis_;
  }
  const std::optional<SettingsChoice>& choice() const { return choice_; }
  /// Without a survey: the topics' clock offsets on its messages at the finest period they support
  /// (SettingsFromRecording::clockOffsets); nothing where it kept none.
  std::optional<TopicDelayEstimate> clockOffsets() const {
    if (!survey_ || survey_->messages().empty()) return std::nullopt;
    return survey_->clockOffsets();
  }
  const IdentificationConfig& config() const { return config_; }

 private:
  void start(const IdentificationConfig& config) {
    config_ = config;
    analysis_ = std::make_unique<OfflineAnalysis>(config_);
    analysis_->setJobs(jobs_);
    if (expected_ > 0.0) analysis_->reserve(expected_, 48 * 3600.0);
  }
  void chooseAndStart() {
    log_("choosing the sample period and filters from the recording's first " +
         formatted(FMT_STRING("{:.0f} s"),
                   survey_->messages().empty()
                       ? 0.0
                       : survey_->messages().back().second.stamp - survey_->messages().front().second.stamp));
    choice_ = survey_->choose();
    for (const auto& setting : choice_->settings) {
      log_(setting.key + " = " + formatted(FMT_STRING("{:g}"), setting.value) + ": " + setting.reason);
    }
    start(choice_->config);
    // The kept messages in their order, the oil temperature's among them by stamp.
    std::size_t oil = 0;
    for (const auto& [stream, sample] : survey_->messages()) {
      while (oil < survey_oil_.size() && !(survey_oil_[oil].stamp > sample.stamp))
        analysis_->pushOilTemperature(survey_oil_[oil++]);
      analysis_->push(stream, sample);
    }
    while (oil < survey_oil_.size()) analysis_->pushOilTemperature(survey_oil_[oil++]);
    survey_oil_.clear();
    survey_.reset();
  }

  IdentificationConfig config_;
  int jobs_;
  std::function<void(const std::string&)> log_;
  std::unique_ptr<SettingsFromRecording> survey_;
  std::vector<StreamSample> survey_oil_;  // the oil temperature's messages while the survey runs
  std::unique_ptr<OfflineAnalysis> analysis_;
  std::optional<SettingsChoice> choice_;
  double expected_ = 0.0;
};

}  // namespace die_cushion_ident
