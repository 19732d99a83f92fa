#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "die_cushion_ident/core/adequacy/model_assessment.h"
#include "die_cushion_ident/core/estimation/identification_pipeline.h"
#include "die_cushion_ident/core/simulation/die_cushion_simulator.h"

namespace die_cushion_ident {
namespace testing {

/// A plant with random base parameters (and effect parameters) inside realistic ranges, the acceptance
/// noise (0.2 bar, 2 um, 0.002 spool) and stamp jitter.
SimulatorConfig randomPlant(std::uint64_t seed, const std::vector<std::string>& effects = {});

/// Identification settings that match the plant's geometry, with the given model effects.
IdentificationConfig configFor(const SimulatorConfig& plant, const std::vector<std::string>& effects = {});

/// Runs the plant for `duration` seconds and feeds every message through `pipeline`.
void feed(DieCushionSimulator& plant, IdentificationPipeline& pipeline, double duration);
/// Runs the plant for `duration` seconds and hands every message to `take`, each topic's stamps shifted by
/// its `stamp_offsets` (a topic stamped by another clock).
void feed(DieCushionSimulator& plant, double duration, const std::array<double, kInputStreamCount>& stamp_offsets,
          const std::function<void(InputStream, const StreamSample&)>& take);

/// A simulated recording on the 2 ms grid, with its strokes.
struct Recording {
  SimulatorConfig plant;
  std::vector<GridSample> grid;
  StrokeSegmentation strokes;
  double truth(const std::string& name) const { return plant.parameters.at(name); }
};

/// `cycles` press cycles of `plant`, on the grid `resampler` makes (default: 2 ms, its points at k T).
Recording record(const SimulatorConfig& plant, int cycles = 8,
                 const UniformResampler::Config& resampler = {});

/// Value of a named estimate; fails the calling test if absent.
double estimateOf(const HydraulicEstimate& estimate, const std::string& name);
double stdOf(const HydraulicEstimate& estimate, const std::string& name);

}  // namespace testing
}  // namespace die_cushion_ident
