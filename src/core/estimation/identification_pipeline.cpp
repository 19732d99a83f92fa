#include "die_cushion_ident/core/estimation/identification_pipeline.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace die_cushion_ident {

IdentificationPipeline::IdentificationPipeline(const IdentificationConfig& config)
    : resampler_(config.resamplerConfig()),
      velocity_(config.velocityHalfWidth()),
      identifier_(config),
      delays_(config.appliedTopicDelays()),
      sample_period_(config.resampler.sample_period),
      spool_model_(config.valve, config.resampler.max_gap, config.valve_model_drives_free_run),
      oil_temperature_(config.oilTemperatureInputConfig()) {
  grid_.reserve(64);
  resampled_.reserve(64);
}

UniformResampler::PushResult IdentificationPipeline::push(InputStream stream, const StreamSample& sample) {
  StreamSample corrected = sample;
  corrected.stamp -= delays_[static_cast<int>(stream)];
  if (stream == InputStream::kValve) spool_model_.process(&corrected);
  const auto result = resampler_.push(stream, corrected, &resampled_);
  if (result == UniformResampler::PushResult::kRestarted) {
    // Finish the old time base's samples (those the restart emitted come before the new base's first, which
    // carries the discontinuity) before the identifier starts again.
    std::size_t old_base = 0;
    while (old_base < resampled_.size() && !resampled_[old_base].discontinuity)
      velocity_.push(resampled_[old_base++], &grid_);
    resampled_.erase(resampled_.begin(), resampled_.begin() + static_cast<std::ptrdiff_t>(old_base));
    velocity_.flush(&grid_);
    consume();
    identifier_.reset();
    oil_temperature_.restart();
  }
  for (const GridSample& g : resampled_) velocity_.push(g, &grid_);
  resampled_.clear();
  consume();
  return result;
}

UniformResampler::PushResult IdentificationPipeline::pushOilTemperature(const StreamSample& sample) {
  // The other topics' newest stamp is the time base a wild stamp is judged against.
  double newest = std::numeric_limits<double>::quiet_NaN();
  for (int s = 0; s < kInputStreamCount; ++s) {
    const StreamHealth& h = resampler_.health(static_cast<InputStream>(s));
    if (h.accepted > 0) newest = std::isnan(newest) ? h.last_stamp : std::max(newest, h.last_stamp);
  }
  return oil_temperature_.push(sample.stamp, sample.first, newest);
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
  oil_temperature_.restart();
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
  for (GridSample& g : grid_) {
    if (oil_temperature_.any()) g.T = static_cast<float>(oil_temperature_.at(g.t));
    const bool stepped = identifying_ && identifier_.push(g);
    if (on_grid_) on_grid_(g, identifier_);
    if (stepped && on_step_) on_step_(identifier_);
  }
  grid_.clear();
}

}  // namespace die_cushion_ident
