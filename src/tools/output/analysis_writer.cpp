#include "output/analysis_writer.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <future>
#include <regex>
#include <stdexcept>

#include "bag/bag_stream_writer.h"
#include "die_cushion_ident/FrequencyResponse.h"
#include "die_cushion_ident/ModelComparison.h"
#include "die_cushion_ident/ParameterEstimate.h"
#include "die_cushion_ident/ValveModel.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "message_conversions.h"
#include "output/csv_file.h"
#include "output/output_files.h"
#include "output/summary_yaml.h"

namespace die_cushion_ident {

namespace {

constexpr std::size_t kComparisonDecimation = 5;  // 2 ms grid -> 100 Hz in analysis.bag and CSV

// A zero ros::Time means "unset" to its users: stamps are kept just above it.
ros::Time stampOf(double t) { return ros::Time(std::max(t, 1e-6)); }

/// Seconds since 1970 to the microsecond in the CSVs (16 digits, more than a value's 10).
constexpr int kStampDecimals = 6;

void writeEstimatesCsv(const std::string& path, const OfflineResult& r, const HydraulicModel& model) {
  CsvFile csv(path);
  csv.text("t");
  for (int i = 0; i < model.parameterCount(); ++i) {
    const std::string& name = model.parameterInfos()[i].name;
    csv.text(name).text(name + "_std");
  }
  csv.text("equation_error_rms").endLine();
  EstimateSeries::Reader step(r.estimates);
  const int parameters = r.estimates.parameters();
  while (step.next()) {
    csv.fixed(step.t(), kStampDecimals);
    for (int j = 0; j < parameters; ++j) csv.number(step.value(j)).number(step.std(j));
    csv.number(step.equationError()).endLine();
  }
  csv.close();
}

/// The grid index of the k-th modelled sample (every kModelledStride-th grid sample is stored).
std::size_t comparisonIndex(std::size_t k) { return k * ModelAssessment::kModelledStride; }
static_assert(kComparisonDecimation == ModelAssessment::kModelledStride, "the comparison series is the stored one");

void writeComparisonCsv(const std::string& path, const OfflineResult& r, const std::vector<GridSample>& grid) {
  CsvFile csv(path);
  csv.header({"t", "measured_pressure", "modelled_pressure", "residual", "position", "velocity",
              "spool_position", "phase"});
  const auto& modelled = r.assessment.modelled;
  for (std::size_t k = 0; k < modelled.size() && comparisonIndex(k) < grid.size(); ++k) {
    const std::size_t i = comparisonIndex(k);
    const GridSample& g = grid[i];
    // The residual and phase name as the message has them.
    const ModelComparison msg = toModelComparisonMsg(g, modelled[k], r.strokes.phase[i], 0.0, 0.0, ros::Time());
    csv.fixed(g.t, kStampDecimals).number(g.p).number(modelled[k]).number(msg.residual);
    csv.number(g.x).number(g.v).number(g.y).text(msg.phase_name).endLine();
  }
  csv.close();
}

// Written under their temporary names in `files` (renamed when the run is complete); the names written.
std::vector<std::string> writeSmallCsvs(const std::string& directory, const OfflineResult& r,
                                        OutputFiles& files) {
  std::vector<std::string> written;
  if (r.valve) {
    // Six significant digits: the points' own scatter is far larger.
    CsvFile csv(files.add(directory + "/frequency_response.csv"));
    csv.header({"frequency", "re", "im", "magnitude", "phase", "magnitude_std", "phase_std",
                "harmonic_distortion", "distorted"});
    for (const auto& p : r.valve->points) {
      csv.number(p.frequency, 6).number(p.re, 6).number(p.im, 6).number(p.magnitude, 6).number(p.phase, 6);
      csv.number(p.magnitude_std, 6).number(p.phase_std, 6).number(p.harmonic_distortion, 6);
      csv.integer(p.distorted).endLine();
    }
    csv.close();
    written.push_back("frequency_response.csv");
    // The fitted model's curve as the bag's FrequencyResponse message carries it, for the report's Bode plot.
    const FrequencyResponse response = toFrequencyResponseMsg(r.valve->points, r.valve->fit, "finished", ros::Time());
    if (!response.fit_frequency.empty()) {
      CsvFile fit(files.add(directory + "/valve_fit.csv"));
      fit.header({"frequency", "magnitude", "phase"});
      for (std::size_t k = 0; k < response.fit_frequency.size(); ++k) {
        fit.number(response.fit_frequency[k]).number(response.fit_magnitude[k]).number(response.fit_phase[k]);
        fit.endLine();
      }
      fit.close();
      written.push_back("valve_fit.csv");
    }
  }
  if (!r.ranking.proposals.empty()) {
    // For the report: each proposal's residual against its signal, with the fitted term drawn over it.
    CsvFile csv(files.add(directory + "/proposals.csv"));
    csv.header({"expression", "signal", "signal_value", "residual_flow", "term_flow"});
    for (const auto& p : r.ranking.proposals) {
      for (std::size_t b = 0; b < p.bin_signal.size(); ++b) {
        csv.quoted(p.spec()).text(std::string(1, p.signal)).number(p.bin_signal[b], 8).number(p.bin_residual[b], 8);
        csv.number(p.bin_term[b], 8).endLine();
      }
    }
    csv.close();
    written.push_back("proposals.csv");
  }
  return written;
}

}  // namespace

/// DIR/analysis.bag, written by BagStreamWriter: rosbag::Bag::write took 4-5 s for an hour's 720 000
/// messages, most of it in system calls (a seek before every message); this takes 0.3 s.
class AnalysisBag {
 public:
  explicit AnalysisBag(const std::string& path) : bag_(path) {}

  void writeSeries(const OfflineResult& r, const std::vector<GridSample>& grid, const HydraulicModel& model) {
    const int parameters = r.estimates.parameters();
    std::vector<double> values(parameters), stds(parameters);
    EstimateSeries::Reader step(r.estimates);
    while (step.next()) {
      for (int j = 0; j < parameters; ++j) {
        values[j] = step.value(j);
        stds[j] = step.std(j);
      }
      ParameterEstimate msg = toParameterEstimateMsg(model, values, stds, stampOf(step.t()));
      msg.equation_error_rms = step.equationError();
      bag_.write("/die_cushion_ident/estimate", msg.header.stamp, msg);
    }
    const auto& modelled = r.assessment.modelled;
    for (std::size_t k = 0; k < modelled.size() && comparisonIndex(k) < grid.size(); ++k) {
      const std::size_t i = comparisonIndex(k);
      const GridSample& g = grid[i];
      const ModelComparison msg =
          toModelComparisonMsg(g, modelled[k], r.strokes.phase[i], r.assessment.simulation_error_rms,
                               r.model.equation_error_rms, stampOf(g.t));
      // Messages only where every figure was computed (the model runs, the signals are there).
      if (isComputed(msg)) bag_.write("/die_cushion_ident/model_comparison", msg.header.stamp, msg);
    }
  }

  void writeValve(const OfflineResult& r) {
    if (!r.valve) return;
    const ros::Time stamp = stampOf(r.valve->segments.back().end);
    bag_.write("/die_cushion_ident/frequency_response", stamp,
                toFrequencyResponseMsg(r.valve->points, r.valve->fit, "finished", stamp));
    bag_.write("/die_cushion_ident/valve_model", stamp, toValveModelMsg(r.valve->fit, stamp));
  }

  void close() { bag_.close(); }

 private:
  BagStreamWriter bag_;
};

namespace {
const char* const kOutputs[] = {"summary.yaml",           "analysis.bag",  "estimates.csv", "model_comparison.csv",
                                "frequency_response.csv", "valve_fit.csv", "proposals.csv"};
}  // namespace

AnalysisWriter::AnalysisWriter(const std::string& directory, const IdentificationConfig& config,
                               const OfflineResult& result, const std::vector<GridSample>& grid)
    : directory_(directory),
      config_(config),
      model_(HydraulicModel::fromNames(config.geometry, config.effects, config.custom_effects, config.oil)) {
  // A reused output folder must not keep a previous run's files (a stale frequency_response.csv would
  // describe another recording), whole or partial.
  for (const char* name : kOutputs) {
    std::remove((directory + "/" + name).c_str());
    std::remove((directory + "/" + name + kPartialSuffix).c_str());
  }
  bag_ = std::make_unique<AnalysisBag>(files_.add(directory + "/analysis.bag"));
  const std::string comparison = files_.add(directory + "/model_comparison.csv");
  const std::string estimates = files_.add(directory + "/estimates.csv");
  bag_series_ = std::async(std::launch::async, [this, &result, &grid] { bag_->writeSeries(result, grid, model_); });
  comparison_csv_ = std::async(
      std::launch::async, [&result, &grid, comparison] { writeComparisonCsv(comparison, result, grid); });
  estimates_csv_ = std::async(std::launch::async,
                              [this, &result, estimates] { writeEstimatesCsv(estimates, result, model_); });
}

AnalysisWriter::~AnalysisWriter() {
  for (auto* running : {&bag_series_, &comparison_csv_, &estimates_csv_}) {
    if (running->valid()) running->wait();
  }
  // A run that failed (a full disk, an error) leaves no file under a final name, and no partial one: the
  // bag is closed (bag_ before files_), then files_ removes every temporary file.
  bag_.reset();
}

void AnalysisWriter::finish(const AnalysisInput& input, const OfflineResult& result) {
  estimates_csv_.get();
  comparison_csv_.get();
  bag_series_.get();
  bag_->writeValve(result);
  bag_->close();
  std::vector<std::string> outputs = {"analysis.bag", "estimates.csv", "model_comparison.csv"};
  for (const std::string& name : writeSmallCsvs(directory_, result, files_)) outputs.push_back(name);
  outputs.push_back("summary.yaml");
  writeSummary(files_.add(directory_ + "/summary.yaml"), input, config_, result, outputs);
  // On the disk and renamed when all are whole, summary.yaml last: a summary under its name means the run
  // completed.
  files_.commit();
}

}  // namespace die_cushion_ident
