#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "die_cushion_ident/core/hydraulic_identifier.h"
#include "die_cushion_ident/core/uniform_resampler.h"

namespace die_cushion_ident {

/// The per-message path of the live node and of analyze_bag: raw stream messages -> UniformResampler ->
/// HydraulicIdentifier. A restart of the time base (bag played again) restarts the identification too.
class IdentificationPipeline {
 public:
  /// Called after every identification step with the identifier (estimate, last row, ...).
  using StepCallback = std::function<void(const HydraulicIdentifier&)>;

  explicit IdentificationPipeline(const IdentificationConfig& config);

  UniformResampler::PushResult push(InputStream stream, const StreamSample& sample);
  void flush();
  void reset();
  void setStepCallback(StepCallback callback) { on_step_ = std::move(callback); }

  const HydraulicIdentifier& identifier() const { return identifier_; }
  HydraulicIdentifier& identifier() { return identifier_; }
  const UniformResampler& resampler() const { return resampler_; }
  std::uint64_t messages() const { return messages_; }

 private:
  void consume();

  UniformResampler resampler_;
  HydraulicIdentifier identifier_;
  std::vector<GridSample> grid_;
  StepCallback on_step_;
  std::uint64_t messages_ = 0;
};

}  // namespace die_cushion_ident
