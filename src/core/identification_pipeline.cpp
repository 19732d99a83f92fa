#include "die_cushion_ident/core/identification_pipeline.h"

namespace die_cushion_ident {

IdentificationPipeline::IdentificationPipeline(const IdentificationConfig& config)
    : resampler_(config.resampler), identifier_(config) {
  grid_.reserve(64);
}

UniformResampler::PushResult IdentificationPipeline::push(InputStream stream, const StreamSample& sample) {
  ++messages_;
  const auto result = resampler_.push(stream, sample, &grid_);
  if (result == UniformResampler::PushResult::kRestarted) identifier_.reset();
  consume();
  return result;
}

void IdentificationPipeline::flush() {
  resampler_.flush(&grid_);
  consume();
}

void IdentificationPipeline::reset() {
  resampler_.reset();
  identifier_.reset();
  grid_.clear();
  messages_ = 0;
}

void IdentificationPipeline::consume() {
  for (const GridSample& g : grid_) {
    if (identifier_.push(g) && on_step_) on_step_(identifier_);
  }
  grid_.clear();
}

}  // namespace die_cushion_ident
