#include "die_cushion_ident/core/fits/input_perturbation.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

#include "die_cushion_ident/core/fits/output_error_refinement.h"

namespace die_cushion_ident {

namespace {

bool changesNothing(const InputPerturbation& p) {
  const auto zero = [](const std::vector<float>& v) {
    return std::all_of(v.begin(), v.end(), [](float x) { return x == 0.0f; });
  };
  return zero(p.spool) && zero(p.pressure);
}

// A covariance the valve model's part can be made from: finite, every parameter's variance positive.
bool usableCovariance(const Eigen::Matrix4d& covariance) {
  return covariance.allFinite() && (covariance.diagonal().array() > 0.0).all();
}

}  // namespace

std::vector<GridSample> perturbed(const std::vector<GridSample>& grid, std::size_t n,
                                  const InputPerturbation& perturbation, double sign) {
  n = std::min(n, grid.size());
  std::vector<GridSample> out(grid.begin(), grid.begin() + static_cast<std::ptrdiff_t>(n));
  for (std::size_t i = 0; i < n; ++i) {
    GridSample& g = out[i];
    if (i < perturbation.spool.size() && std::isfinite(g.y_model)) {
      g.y_model = static_cast<float>(g.y_model + sign * perturbation.spool[i]);
      // The interval's mean moves with it (the free run keeps the mean between samples): by the trapezoid.
      if (std::isfinite(g.y_model_mean)) {
        const float before = i > 0 ? perturbation.spool[i - 1] : perturbation.spool[i];
        g.y_model_mean = static_cast<float>(g.y_model_mean + sign * 0.5 * (before + perturbation.spool[i]));
      }
    }
    if (i < perturbation.pressure.size()) {
      g.p = static_cast<float>(g.p + sign * perturbation.pressure[i]);
    }
  }
  return out;
}

namespace {

// The model's spool for the grid's commands (each interval's mean command held over it, as the amplifier
// holds its commands), restarted at the grid's spool after a restart of the grid or where the spool is not
// the model's.
std::vector<double> modelSpool(const std::vector<GridSample>& grid, std::size_t n,
                               const ServoValveParameters& valve) {
  std::vector<double> y(n, std::numeric_limits<double>::quiet_NaN());
  ServoValve model = ServoValve::exact(valve);
  bool running = false;
  for (std::size_t i = 0; i < n; ++i) {
    const GridSample& g = grid[i];
    const double command = std::isfinite(g.u_mean) ? g.u_mean : g.u;
    if (!std::isfinite(g.y_model) || !std::isfinite(command)) {
      running = false;
      continue;
    }
    if (!running || g.discontinuity || !(g.t > grid[i - 1].t)) {
      model.reset(g.y_model);
      running = true;
      y[i] = g.y_model;
      continue;
    }
    y[i] = model.advance(g.t - grid[i - 1].t, command);
  }
  return y;
}

ServoValveParameters moved(ServoValveParameters valve, const Eigen::Vector4d& by) {
  valve.natural_frequency = std::max(valve.natural_frequency + by(0), 1e-3 * valve.natural_frequency);
  valve.damping = std::max(valve.damping + by(1), 1e-3 * valve.damping);
  valve.gain += by(2);
  valve.dead_time = std::max(valve.dead_time + by(3), 0.0);
  return valve;
}

}  // namespace

std::vector<InputPerturbation> valveModelPerturbations(const std::vector<GridSample>& grid, std::size_t n,
                                                       const ServoValveParameters& valve,
                                                       const Eigen::Matrix4d& covariance) {
  std::vector<InputPerturbation> perturbations;
  n = std::min(n, grid.size());
  if (n < 2 || !usableCovariance(covariance)) return perturbations;
  const Eigen::Vector4d stds = covariance.diagonal().cwiseSqrt();
  // The principal axes of the correlation matrix (the parameters' units differ by nine decades), each
  // scaled back to the parameters' units: independent directions whose variances add up.
  const Eigen::Matrix4d correlation =
      stds.cwiseInverse().asDiagonal() * covariance * stds.cwiseInverse().asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> axes(correlation);
  if (axes.info() != Eigen::Success) return perturbations;
  for (int j = 0; j < 4; ++j) {
    const double variance = axes.eigenvalues()(j);
    if (!(variance > 1e-12)) continue;
    // The axis's direction of rising dead time (an axis's sign drops out of its part).
    Eigen::Vector4d up = stds.asDiagonal() * axes.eigenvectors().col(j) * std::sqrt(variance);
    if (up(3) < 0.0) up = -up;
    // Where the step back would put the dead time below 0 (a fit at its bound), one-sided from the model.
    const bool one_sided = valve.dead_time < up(3);
    const std::vector<double> plus = modelSpool(grid, n, moved(valve, up));
    const std::vector<double> minus = modelSpool(grid, n, one_sided ? valve : moved(valve, -up));
    InputPerturbation perturbation;
    perturbation.input = "valve_model";
    perturbation.spool.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const double change = (one_sided ? 1.0 : 0.5) * (plus[i] - minus[i]);
      perturbation.spool[i] = std::isfinite(change) ? static_cast<float>(change) : 0.0f;
    }
    perturbations.push_back(std::move(perturbation));
  }
  return perturbations;
}

InputPerturbation commonOffsetPerturbation(const std::vector<GridSample>& grid, std::size_t n, double std) {
  n = std::min(n, grid.size());
  InputPerturbation change{"clock_offsets", {}, {}};
  if (!(std > 0.0) || !std::isfinite(std) || n == 0) return change;
  const std::vector<GridSample> later = timingShifted(grid, n, 0.0, std);
  const std::vector<GridSample> earlier = timingShifted(grid, n, 0.0, -std);
  change.pressure.assign(n, 0.0f);
  for (std::size_t i = 0; i < n; ++i) {
    const double dp = 0.5 * (static_cast<double>(later[i].p) - earlier[i].p);
    change.pressure[i] = std::isfinite(dp) ? static_cast<float>(dp) : 0.0f;
  }
  return change;
}

std::vector<InputPerturbation> freeRunInputUncertainties(const std::vector<GridSample>& grid, std::size_t n,
                                                         const IdentificationConfig& config,
                                                         const ServoValveParameters& grid_valve) {
  n = std::min(n, grid.size());
  std::vector<InputPerturbation> inputs =
      valveModelPerturbations(grid, n, grid_valve, config.valve_covariance);
  if (config.common_delay_std > 0.0)
    inputs.push_back(commonOffsetPerturbation(grid, n, config.common_delay_std));
  // Each costs two free runs: none for a change of nothing (no model spool on the grid).
  inputs.erase(std::remove_if(inputs.begin(), inputs.end(), changesNothing), inputs.end());
  return inputs;
}

bool freeRunInputsKnown(const std::vector<GridSample>& grid, std::size_t n,
                        const IdentificationConfig& config, const HydraulicModel& model,
                        const FreeRunInputSources& sources) {
  // The oil's temperature, where the model follows it, is read in the tank or the return line a few times a
  // second, not in the chamber: an input whose error no part carries (a slow press whose oil warmed 20 K had
  // its bulk modulus at 40 degC 4.6 of the free run's stds off, 1.2 %).
  if (model.oilStateParameter() >= 0) return false;
  const bool fitted_model = usableCovariance(config.valve_covariance);
  n = std::min(n, grid.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (std::isfinite(grid[i].y_model)) return fitted_model;  // the valve model's spool drives the free run
  }
  return !sources.spool_predicted;  // the topic's spool, unless a configured model stood in for it
}

}  // namespace die_cushion_ident
