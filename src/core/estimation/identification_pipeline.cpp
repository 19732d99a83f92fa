#include "die_cushion_ident/core/estimation/identification_pipeline.h"

#include <cmath>

namespace die_cushion_ident {

IdentificationPipeline::IdentificationPipeline(const IdentificationConfig& config)
    : resampler_(config.resamplerConfig()),
      velocity_(config.velocityHalfWidth()),
      identifier_(config),
      delays_(config.appliedTopicDelays()),
      sample_period_(config.resampler.sample_period),
      spool_model_(config.valve, config.resampler.max_gap, config.valve_model_drives_free_run) {
  grid_.reserve(64);
  resampled_.reserve(64);
}

UniformResampler::PushResult IdentificationPipeline::push(InputStream stream, const StreamSample& sample) {
  StreamSample corrected = sample;
  corrected.stamp -= delays_[static_cast<int>(stream)];
  if (stream == InputStream::kValve) spool_model_.process(&corrected);
  const auto result = resampler_.push(stream, corrected, &resampled_);
  if (result == UniformResampler::PushResult::kRestarted) {
    // Finish the old time base's samples before the identifier starts again.
    velocity_.flush(&grid_);
    consume();
    identifier_.reset();
  }
  for (const GridSample& g : resampled_) velocity_.push(g, &grid_);
  resampled_.clear();
  consume();
  return result;
}

void IdentificationPipeline::flush() {
  resampler_.flush(&resampled_);
  for (const GridSample& g : resampled_) velocity_.push(g, &grid_);
  resampled_.clear();
  velocity_.flush(&grid_);
  consume();
}

void IdentificationPipeline::reset() {
  resampler_.reset();
  velocity_.reset();
  identifier_.reset();
  resampled_.clear();
  grid_.clear();
  spool_model_.reset();
}

void IdentificationPipeline::setValveModel(const ServoValveParameters& valve) {
  identifier_.setValveModel(valve);
  spool_model_.setValve(valve);
}

void IdentificationPipeline::setValveModel(const ServoValveParameters& valve, bool drives_free_run) {
  setValveModel(valve);
  spool_model_.setDrivesFreeRun(drives_free_run);
}

void IdentificationPipeline::consume() {
  for (const GridSample& g : grid_) {
    const bool stepped = identifying_ && identifier_.push(g);
    if (on_grid_) on_grid_(g, identifier_);
    if (stepped && on_step_) on_step_(identifier_);
  }
  grid_.clear();
}

}  // namespace die_cushion_ident
