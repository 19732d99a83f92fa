#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "die_cushion_ident/core/estimation/newey_west_covariance.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/estimation/identification_config.h"
#include "die_cushion_ident/core/estimation/recursive_least_squares.h"
#include "die_cushion_ident/core/estimation/volume_balance_regressor.h"
#include "die_cushion_ident/core/signal/white_noise_estimator.h"

namespace die_cushion_ident {

/// A physical parameter estimate with its one-sigma uncertainty.
struct IdentifiedParameter {
  std::string name;
  std::string unit;
  double value = 0.0;
  double std = 0.0;
};

/// Snapshot of the hydraulic identification.
struct HydraulicEstimate {
  double t = 0.0;  ///< time of the newest row used [s]
  std::vector<std::string> effects;
  std::vector<IdentifiedParameter> parameters;  ///< in HydraulicModel parameter order
  std::uint64_t updates = 0;                    ///< RLS updates so far
  std::uint64_t steps = 0;                      ///< identification steps (every identification_period)
  std::uint64_t skipped_invalid = 0;            ///< steps whose window held unusable samples
  std::uint64_t skipped_unexcited = 0;          ///< steps in the excitation dead zone
  double equation_error_rms = 0.0;              ///< recent a-priori error of dp/dt [Pa/s]

  /// The estimated values in model order, as the model takes them.
  ParameterVector values() const {
    ParameterVector v(static_cast<Eigen::Index>(parameters.size()));
    for (std::size_t i = 0; i < parameters.size(); ++i) v(static_cast<Eigen::Index>(i)) = parameters[i].value;
    return v;
  }
  /// Their standard deviations, same order.
  ParameterVector standardDeviations() const {
    ParameterVector v(static_cast<Eigen::Index>(parameters.size()));
    for (std::size_t i = 0; i < parameters.size(); ++i) v(static_cast<Eigen::Index>(i)) = parameters[i].std;
    return v;
  }
};

/// Online identification of the pressure build-up model (the paper's method, made unbiased):
/// uniform samples -> VolumeBalanceRegressor -> every identification_period one RLS step on the normalised
/// coefficients. Steps whose window touches an unusable sample are skipped (model invalid there), and so
/// are steps in the excitation dead zone (cushion at rest, pressure steady): forgetting then pauses instead
/// of winding up the covariance. Parameters are reported in physical units with standard deviations.
class HydraulicIdentifier {
 public:
  /// Throws std::invalid_argument listing every invalid configuration value.
  explicit HydraulicIdentifier(const IdentificationConfig& config);

  /// Feeds one uniform sample; returns true when an identification step was taken (updated or skipped).
  bool push(const GridSample& sample);
  /// Restarts estimator and filters from the initial values.
  void reset();
  /// The valve model the regressor uses near the port's kink (after a sweep identified the valve).
  void setValveModel(const ServoValveParameters& valve) { regressor_->setValveModel(valve); }

  HydraulicEstimate estimate() const;
  /// The estimate of one fit on this identifier's data and `other`'s together, combined from the two fits'
  /// information instead of fitted again: P^-1 and P^-1 theta add (each part's own share of the prior,
  /// lambda^n of it after n updates, taken out and the prior put in once), and so do the Newey-West score
  /// sums and the capacitive noise sums. The rows whose
  /// windows span the seam between the two parts, and the score lags across it, are in neither (about 1 %
  /// of the rows for 8 cycles split in halves). Both must share the configuration. Valve-shape effects keep each
  /// part's own linearisation (exact at each part's fixed point).
  HydraulicEstimate combinedEstimate(const HydraulicIdentifier& other) const;
  ParameterVector physicalParameters() const;
  const HydraulicModel& model() const { return model_; }
  const IdentificationConfig& config() const { return config_; }
  /// Whether the last identification step updated the estimator.
  bool lastStepUpdated() const { return last_step_updated_; }
  /// RLS updates since the last (re)start (cheap; estimate() also reports it).
  std::uint64_t updates() const { return rls_->updates(); }
  /// Predicted dp/dt [Pa/s] of the current model for a row (for comparison with row.pressure_rate).
  double capacitanceAt(const RegressionRow& row) const;
  /// Linearises valve-shape effects (and the chamber volume) at `physical` from now on instead of at the
  /// running estimate: a batch fit's second pass, whose rows must all share one linearisation point.
  void freezeLinearisationPoint(const ParameterVector& physical);

 private:
  void refreshLinearisationPoint();
  void refreshLinearisationPoint(ParameterVector physical);
  bool identificationStep();
  /// The model's signals at a row (its measured p, x, u, y; the chamber volume at the linearisation point).
  HydraulicSignals signalsAt(const RegressionRow& row) const;
  /// The normalised RLS coefficients with the pressure noise's bias removed: the noise in the capacitive
  /// columns (errors in variables) adds its covariance to the normal equations, so the least-squares solution
  /// is (I - sigma_p^2 P C)^-1 times the RLS one (doc/equations.md, "Pressure noise in the capacitive columns").
  ParameterVector coefficients() const { return noiseCorrection() * rls_->parameters(); }
  /// (I - sigma_p^2 P C)^-1, or the identity where it does not apply.
  CovarianceMatrix noiseCorrection() const {
    return noiseCorrection(rls_->covariance(), column_noise_, rls_->updates());
  }
  CovarianceMatrix noiseCorrection(const CovarianceMatrix& P, const CovarianceMatrix& column_noise,
                                   std::uint64_t updates) const;
  /// The physical parameters and their stds from normalised RLS coefficients, their covariance P and the
  /// score sum S (sandwich P S P), with the noise correction.
  void fillParameters(const ParameterVector& theta, const CovarianceMatrix& P, const CovarianceMatrix& S,
                      const CovarianceMatrix& column_noise, std::uint64_t updates, HydraulicEstimate* e) const;
  /// The physical parameters the valve shape and chamber volume are linearised at in each step: with the
  /// correction as of at most kCorrectionRefresh updates ago (an LU per step cost 6 % of analyze_bag).
  ParameterVector runningPhysicalParameters() const;
  static constexpr std::uint64_t kCorrectionRefresh = 64;
  void addPressureForNoise(const GridSample& s, bool usable);

  IdentificationConfig config_;
  HydraulicModel model_;
  std::unique_ptr<VolumeBalanceRegressor> regressor_;
  std::unique_ptr<RecursiveLeastSquares> rls_;
  ParameterVector scale_;  // coefficient = normalised parameter * scale
  double flow_scale_;      // [m^3/s] divides both sides of the equation
  NeweyWestCovariance scores_{1, 0, 1.0};  // long-run covariance of the normalised scores
  // The grid pressure's white noise, and per unit of its variance the forgetting-weighted sum of the noise
  // covariances of the normalised rows' capacitive columns: sum lambda^(N-t) f a_t a_t^T, with f the variance
  // of a row's window-difference of pressure per unit noise variance.
  WhiteNoiseEstimator pressure_noise_{32};  // one second difference in 32: it sets a small correction
  CovarianceMatrix running_correction_;
  std::uint64_t running_correction_updates_ = 0;
  double recent_pressure_[3] = {0.0, 0.0, 0.0};
  int recent_pressures_ = 0;
  double row_noise_per_variance_ = 0.0;
  CovarianceMatrix column_noise_;
  ParameterVector linearisation_point_;
  bool linearisation_frozen_ = false;
  RegressionRow row_;
  std::uint64_t rows_ = 0;
  std::uint64_t steps_ = 0, skipped_invalid_ = 0, skipped_unexcited_ = 0;
  double error_mean_square_ = 0.0, error_weight_ = 0.0;
  bool last_step_updated_ = false;
};

}  // namespace die_cushion_ident
