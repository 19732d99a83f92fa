#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"
#include "die_cushion_ident/core/signal/oil_temperature_input.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"
#include "die_cushion_ident/core/signal/velocity_from_position.h"
#include "die_cushion_ident/core/valve/servo_valve.h"
#include "die_cushion_ident/core/valve/valve_message_spool.h"

namespace die_cushion_ident {

/// The per-message path of the live node and of analyze_bag: raw stream messages (stamps corrected by the
/// topic delays) -> UniformResampler -> VelocityFromPosition -> HydraulicIdentifier. A restart of the time
/// base (bag played again) restarts the identification too. The configured valve model runs on the valve
/// messages (ValveMessageSpool): its spool drives the free run, and stands in where the valve topic carries
/// no spool position (NaN). Where the position topic carries no velocity, it
/// is derived from the positions on the grid; every sample then leaves the pipeline velocityDelay() later.
class IdentificationPipeline {
 public:
  /// Called after every identification step with the identifier (estimate, last row, ...).
  using StepCallback = std::function<void(const HydraulicIdentifier&)>;

  explicit IdentificationPipeline(const IdentificationConfig& config);

  UniformResampler::PushResult push(InputStream stream, const StreamSample& sample);
  /// One message of the optional oil temperature topic (`sample.first` in degC): every grid sample from now
  /// on carries the temperature at its time (GridSample::T; OilTemperatureInput).
  UniformResampler::PushResult pushOilTemperature(const StreamSample& sample);
  void flush();
  void reset();
  void setStepCallback(StepCallback callback) { on_step_ = std::move(callback); }
  /// Called for every uniform sample, after the identifier has taken it (model comparison, phases).
  using GridCallback = std::function<void(const GridSample&, const HydraulicIdentifier&)>;
  void setGridCallback(GridCallback callback) { on_grid_ = std::move(callback); }
  /// Whether the identifier takes the grid (default). Off, the pipeline only resamples: the settings' study
  /// reads grids at several periods and fits on them itself, and the identifier's filters and RLS were a
  /// third of its time in building them.
  void setIdentifying(bool identifying) { identifying_ = identifying; }
  /// Replaces the valve model that predicts an unmeasured spool and judges the port side near its kink (e.g.
  /// after a sweep identified it).
  void setValveModel(const ServoValveParameters& valve);
  /// ... and whether it drives the free run (IdentificationConfig::valve_model_drives_free_run).
  void setValveModel(const ServoValveParameters& valve, bool drives_free_run);
  /// [s] subtracted from each stream's stamps (pressure, position, valve) from now on.
  void setTopicDelays(const std::array<double, kInputStreamCount>& delays) { delays_ = delays; }
  const std::array<double, kInputStreamCount>& topicDelays() const { return delays_; }
  /// [s] latency of the velocity stage (half the differentiator window).
  double velocityDelay() const { return velocity_.delaySamples() * sample_period_; }
  /// Grid samples whose velocity was derived from the position.
  std::uint64_t derivedVelocitySamples() const { return velocity_.derived(); }
  /// Valve messages whose spool the valve model stood in for (the topic carries none).
  std::uint64_t predictedSpoolMessages() const { return spool_model_.predicted(); }

  const HydraulicIdentifier& identifier() const { return identifier_; }
  HydraulicIdentifier& identifier() { return identifier_; }
  const UniformResampler& resampler() const { return resampler_; }
  const OilTemperatureInput& oilTemperature() const { return oil_temperature_; }
  /// Takes over another pipeline's oil temperature messages and counts (a pipeline rebuilt with new
  /// settings).
  void adoptOilTemperature(const OilTemperatureInput& input) { oil_temperature_ = input; }

 private:
  void consume();

  UniformResampler resampler_;
  VelocityFromPosition velocity_;
  HydraulicIdentifier identifier_;
  std::vector<GridSample> resampled_, grid_;
  std::array<double, kInputStreamCount> delays_;
  double sample_period_;
  bool identifying_ = true;
  StepCallback on_step_;
  GridCallback on_grid_;
  ValveMessageSpool spool_model_;
  OilTemperatureInput oil_temperature_;
};

}  // namespace die_cushion_ident
