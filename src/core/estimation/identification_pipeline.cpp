#include "die_cushion_ident/core/estimation/identification_pipeline.h"

#include <cmath>

namespace die_cushion_ident {

IdentificationPipeline::IdentificationPipeline(const IdentificationConfig& config)
    : resampler_(config.resamplerConfig()),
      velocity_(config.velocityHalfWidth()),
      identifier_(config),
      delays_(config.appliedTopicDelays()),
      sample_period_(config.resampler.sample_period),
      spool_predictor_(config.valve),
      max_gap_(config.resampler.max_gap) {
  grid_.reserve(64);
  resampled_.reserve(64);
}

UniformResampler::PushResult IdentificationPipeline::push(InputStream stream, const StreamSample& sample) {
  StreamSample corrected = sample;
  corrected.stamp -= delays_[static_cast<int>(stream)];
  if (stream == InputStream::kValve) predictSpool(&corrected);
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
  spool_predictor_.reset();
  last_valve_stamp_ = -std::numeric_limits<double>::infinity();
  last_voltage_ = last_measured_spool_ = 0.0;
  predicting_ = false;
}

void IdentificationPipeline::predictSpool(StreamSample* valve) {
  if (!std::isfinite(valve->stamp) || !std::isfinite(valve->first)) return;  // the resampler rejects it
  const double dt = valve->stamp - last_valve_stamp_;
  if (std::isfinite(valve->second)) {
    last_measured_spool_ = valve->second;
    predicting_ = false;
  } else if (!predicting_ || !(dt > 0.0 && dt <= max_gap_)) {
    // Start (or restart after a gap or a backward jump) from the last measured or a steady spool.
    spool_predictor_.reset(predicting_ ? spool_predictor_.position() : last_measured_spool_);
    predicting_ = true;
    valve->second = spool_predictor_.position();
  } else {
    // The previous voltage was in force until now (held by the amplifier).
    valve->second = spool_predictor_.advance(dt, last_voltage_);
  }
  if (dt > 0.0 || dt < -max_gap_) {  // not for a duplicate or a slightly late message
    last_valve_stamp_ = valve->stamp;
    last_voltage_ = valve->first;
  }
}

void IdentificationPipeline::setValveModel(const ServoValveParameters& valve) {
  identifier_.setValveModel(valve);
  spool_predictor_ = ServoValve(valve);
  predicting_ = false;  // restart the prediction from the last measured spool
}

void IdentificationPipeline::consume() {
  for (const GridSample& g : grid_) {
    const bool stepped = identifier_.push(g);
    if (on_grid_) on_grid_(g, identifier_);
    if (stepped && on_step_) on_step_(identifier_);
  }
  grid_.clear();
}

}  // namespace die_cushion_ident
