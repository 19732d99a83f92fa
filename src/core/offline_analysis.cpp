#include "die_cushion_ident/core/offline_analysis.h"

#include <climits>
#include <cmath>

namespace die_cushion_ident {

OfflineAnalysis::OfflineAnalysis(const IdentificationConfig& config) : config_(config), pipeline_(config) {
  pipeline_.setGridCallback([this](const GridSample& g, const HydraulicIdentifier&) { grid_.push_back(g); });
  pipeline_.setStepCallback([this](const HydraulicIdentifier& identifier) {
    const HydraulicEstimate e = identifier.estimate();
    EstimateSample s;
    s.t = e.t;
    for (const auto& p : e.parameters) {
      s.values.push_back(p.value);
      s.stds.push_back(p.std);
    }
    s.equation_error_rms = e.equation_error_rms;
    estimates_.push_back(std::move(s));
  });
}

void OfflineAnalysis::push(InputStream stream, const StreamSample& sample) {
  ++messages_;
  pipeline_.push(stream, sample);
  // The sweep analysis wants the raw valve signal, not the 2 ms grid (sweeps reach 160 Hz).
  if (stream == InputStream::kValve && std::isfinite(sample.stamp) && std::isfinite(sample.first)) {
    if (valve_.empty() || sample.stamp > valve_.back().t)
      valve_.push_back({sample.stamp, sample.first, sample.second});
  }
}

OfflineResult OfflineAnalysis::finish(const std::function<void(const std::string&)>& progress) {
  const auto tell = [&](const std::string& what) {
    if (progress) progress(what);
  };
  pipeline_.flush();
  OfflineResult r;
  r.messages = messages_;
  r.grid_samples = grid_.size();
  for (int s = 0; s < kInputStreamCount; ++s)
    r.health[s] = pipeline_.resampler().health(static_cast<InputStream>(s));
  r.restarts = pipeline_.resampler().restarts();
  r.estimates = std::move(estimates_);
  const HydraulicModel model =
      HydraulicModel::fromNames(config_.geometry, config_.effects, config_.custom_effects);
  r.effects = model.effectNames();

  r.hydraulics = r.health[0].accepted > 0 && r.health[1].accepted > 0;
  if (r.hydraulics) {
    tell("segmenting the strokes");
    r.strokes = segmentStrokes(grid_);
    tell("fitting the model to the whole recording");
    r.model = fitOnCycles(grid_, r.strokes, config_, INT_MIN, INT_MAX);
    if (r.model.updates == 0) {
      r.warnings.push_back(
          "the recording never excites the hydraulics (no press stroke): no parameters identified");
    }
    ParameterVector theta(model.parameterCount());
    for (int i = 0; i < model.parameterCount(); ++i) theta(i) = r.model.parameters[i].value;
    tell("running the model free against the measurement");
    r.assessment = assessModel(grid_, r.strokes, model, theta, config_.min_pressure);
    tell("trying the library's other effects on held-out cycles");
    r.ranking = rankEffects(grid_, r.strokes, config_);
  } else {
    r.warnings.push_back("pressure or position missing: the hydraulics were not identified");
  }

  if (!valve_.empty()) {
    tell("looking for valve sine sweeps");
    RecordedSweep sweep = analyzeRecordedSweep(valve_);
    if (!sweep.segments.empty()) r.valve = std::move(sweep);
  }
  return r;
}

}  // namespace die_cushion_ident
