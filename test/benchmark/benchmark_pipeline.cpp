// Speed of the per-message identification path (resample, filters, regressors, RLS) and of its kernels.
// Run: .build_ws/devel/lib/die_cushion_ident/benchmark_pipeline   (figures go to README.md)
#include <benchmark/benchmark.h>

#include <map>
#include <random>
#include <vector>

#include "die_cushion_ident/core/estimation/identification_pipeline.h"
#include "die_cushion_ident/core/estimation/recursive_least_squares.h"
#include "die_cushion_ident/core/signal/signal_filters.h"
#include "simulation_fixtures.h"

using namespace die_cushion_ident;

namespace {
// Ten press cycles of simulated messages (3 topics at 1 kHz), generated once.
const std::vector<SimulatedMeasurement>& recordedMessages(const std::vector<std::string>& effects) {
  static std::map<std::vector<std::string>, std::vector<SimulatedMeasurement>> cache;
  auto& messages = cache[effects];
  if (messages.empty()) {
    SimulatorConfig config = testing::randomPlant(1, effects);
    DieCushionSimulator plant(config);
    plant.run(10 * plant.program().cycleDuration(), &messages);
  }
  return messages;
}

void runPipeline(benchmark::State& state, const std::vector<std::string>& effects, RegressionForm form) {
  const auto& messages = recordedMessages(effects);
  IdentificationConfig config = testing::configFor(testing::randomPlant(1, effects), effects);
  config.regression_form = form;
  for (auto _ : state) {
    IdentificationPipeline pipeline(config);
    for (const auto& m : messages) pipeline.push(m.stream, m.sample);
    benchmark::DoNotOptimize(pipeline.identifier().estimate());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(messages.size()));
}
}  // namespace

static void BM_PipelineBaseModel(benchmark::State& s) { runPipeline(s, {}, RegressionForm::kIntegral); }
static void BM_PipelineAllEffects(benchmark::State& s) {
  runPipeline(s, {"leakage", "entrained_air", "valve_overlap", "tank_pressure"}, RegressionForm::kIntegral);
}
static void BM_PipelinePaperForm(benchmark::State& s) { runPipeline(s, {}, RegressionForm::kDerivative); }
BENCHMARK(BM_PipelineBaseModel)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PipelineAllEffects)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PipelinePaperForm)->Unit(benchmark::kMillisecond);

static void BM_RlsUpdate(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  RecursiveLeastSquares rls(ParameterVector::Ones(n), CovarianceMatrix::Identity(n, n) * 100, {});
  std::mt19937_64 rng(1);
  std::normal_distribution<double> normal;
  std::vector<ParameterVector> rows(1024, ParameterVector(n));
  for (auto& r : rows) {
    for (int i = 0; i < n; ++i) r(i) = normal(rng);
  }
  std::size_t k = 0;
  for (auto _ : state) {
    const auto& phi = rows[k++ & 1023];
    rls.update(phi, phi.sum());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RlsUpdate)->Arg(3)->Arg(4)->Arg(8);

// The floor RecursiveLeastSquares::update is measured against: a bare rank-one update of the same types,
// without the Joseph form, the checks, the symmetrisation and the covariance bound.
static void BM_PlainRankOneUpdate(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  ParameterVector theta = ParameterVector::Ones(n);
  CovarianceMatrix P = CovarianceMatrix::Identity(n, n) * 100;
  std::mt19937_64 rng(1);
  std::normal_distribution<double> normal;
  std::vector<ParameterVector> rows(1024, ParameterVector(n));
  for (auto& r : rows) {
    for (int i = 0; i < n; ++i) r(i) = normal(rng);
  }
  const double lambda = 0.998;
  std::size_t k = 0;
  for (auto _ : state) {
    const auto& phi = rows[k++ & 1023];
    const ParameterVector u = P * phi;
    const double s = lambda + phi.dot(u);
    theta.noalias() += u * ((phi.sum() - phi.dot(theta)) / s);
    P.noalias() -= u * u.transpose() / s;
    P /= lambda;
    benchmark::DoNotOptimize(theta.data());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PlainRankOneUpdate)->Arg(3)->Arg(4)->Arg(8);

static void BM_MovingAverageAndDerivative(benchmark::State& state) {
  MovingAverageFilter average(31, 1);
  SymmetricDerivative derivative(25, 1, 0.002);
  double x = 0.0;
  for (auto _ : state) {
    x += 1.0;
    if (average.push(x)) derivative.push(average.output().data());
    benchmark::DoNotOptimize(derivative.output(0));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_MovingAverageAndDerivative);

BENCHMARK_MAIN();
