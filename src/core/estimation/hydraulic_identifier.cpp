#include "die_cushion_ident/core/estimation/hydraulic_identifier.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace die_cushion_ident {

namespace {
IdentificationConfig checked(const IdentificationConfig& config) {
  const auto errors = config.validate();
  if (!errors.empty()) {
    std::string all = "invalid identification configuration:";
    for (const auto& e : errors) all += "\n  " + e;
    throw std::invalid_argument(all);
  }
  return config;
}
}  // namespace

HydraulicIdentifier::HydraulicIdentifier(const IdentificationConfig& config)
    : config_(checked(config)),
      model_(HydraulicModel::fromNames(config.geometry, config.effects, config.custom_effects, config.oil)) {
  const int n = model_.parameterCount();
  ParameterVector initial = model_.nominalParameters();
  for (const auto& [name, value] : config_.initial_parameters) {
    for (int i = 0; i < n; ++i) {
      if (model_.parameterInfos()[i].name == name) initial(i) = value;
    }
  }
  // Scale each coefficient by its initial value so that every normalised parameter starts at 1 (the paper's
  // start) and the regression is well conditioned; a zero start falls back to the nominal magnitude.
  const ParameterVector c0 = model_.coefficientsFromPhysical(initial);
  const ParameterVector c_nominal = model_.coefficientsFromPhysical(model_.nominalParameters());
  scale_.resize(n);
  ParameterVector theta0(n);
  for (int j = 0; j < n; ++j) {
    scale_(j) = std::abs(c0(j)) > 0.0 ? std::abs(c0(j)) : std::abs(c_nominal(j));
    if (!(scale_(j) > 0.0)) scale_(j) = 1.0;
    theta0(j) = c0(j) / scale_(j);
  }
  flow_scale_ = config_.geometry.piston_area * 0.1;  // the flow of a 0.1 m/s stroke
  const CovarianceMatrix P0 = CovarianceMatrix::Identity(n, n) * config_.initial_covariance;
  RecursiveLeastSquares::Options options;
  options.forgetting_factor = config_.forgetting_factor;
  rls_ = std::make_unique<RecursiveLeastSquares>(theta0, P0, options);
  regressor_ = std::make_unique<VolumeBalanceRegressor>(model_, config_);
  // Successive rows share (b + d - 1) samples, so errors of rows up to that many identification steps apart
  // are correlated. The RLS covariance assumes independent errors; the stds use the Newey-West long-run
  // covariance of the scores instead, over twice that span (doc/equations.md, "Uncertainty").
  const int overlapping_steps = static_cast<int>(
      std::ceil(static_cast<double>(config_.moving_average_width + config_.derivative_width - 1) /
                config_.decimation()));
  scores_ = NeweyWestCovariance(n, 2 * overlapping_steps, config_.forgetting_factor);
  // A row's pressure enters as MA_b[p(t) - p(t - (d-1) dt)] / ((d-1) dt): white noise of variance s^2 gives it
  // the variance 2 s^2 min(d-1, b) / b^2 / ((d-1) dt)^2. The paper's derivative form is left as published.
  if (config_.regression_form == RegressionForm::kIntegral) {
    const double b = config_.moving_average_width, span = config_.derivative_width - 1.0;
    const double window = span * config_.resampler.sample_period;
    row_noise_per_variance_ = 2.0 * std::min(span, b) / (b * b) / (window * window);
  }
  column_noise_ = CovarianceMatrix::Zero(n, n);
  running_correction_ = CovarianceMatrix::Identity(n, n);
  refreshLinearisationPoint();
}

void HydraulicIdentifier::reset() {
  rls_->reset();
  regressor_->clear();
  scores_.reset();
  column_noise_.setZero();
  running_correction_.setIdentity();
  running_correction_updates_ = 0;
  pressure_noise_ = WhiteNoiseEstimator(32);
  recent_pressures_ = 0;
  rows_ = steps_ = skipped_invalid_ = skipped_unexcited_ = 0;
  error_mean_square_ = error_weight_ = 0.0;
  last_step_updated_ = false;
  refreshLinearisationPoint();
}

namespace {
// The errors-in-variables correction (I - B)^-1 is applied only while B's spectral radius stays below this:
// beyond it the correction would amplify the estimate by more than 2 (1 / (1 - 0.5)).
constexpr double kLargestNoiseCorrection = 0.5;
}  // namespace

CovarianceMatrix HydraulicIdentifier::noiseCorrection(const CovarianceMatrix& P, const CovarianceMatrix& column_noise,
                                                      std::uint64_t updates) const {
  const int n = model_.parameterCount();
  const CovarianceMatrix identity = CovarianceMatrix::Identity(n, n);
  const double variance = pressure_noise_.sigma() * pressure_noise_.sigma();
  if (!(row_noise_per_variance_ > 0.0) || !std::isfinite(variance) || updates == 0) return identity;
  const CovarianceMatrix bias = variance * (P * column_noise);
  if (!bias.allFinite()) return identity;
  // A correction as large as the information itself means the noise is not what the estimator measured
  // (or the data barely excite the model): then none, rather than an amplified one. Judged on the spectral
  // radius of B (what (I - B)^-1 amplifies by, 1 / (1 - rho)), not on its largest entry, which a scaled
  // column can make large or small without changing the amplification.
  const double radius = Eigen::EigenSolver<CovarianceMatrix>(bias, false).eigenvalues().cwiseAbs().maxCoeff();
  if (!(radius <= kLargestNoiseCorrection)) return identity;
  const CovarianceMatrix correction = (identity - bias).inverse();
  return correction.allFinite() ? correction : identity;
}

ParameterVector HydraulicIdentifier::physicalParameters() const {
  return model_.physicalFromCoefficients(coefficients().cwiseProduct(scale_));
}

ParameterVector HydraulicIdentifier::runningPhysicalParameters() const {
  return model_.physicalFromCoefficients((running_correction_ * rls_->parameters()).cwiseProduct(scale_));
}

void HydraulicIdentifier::addPressureForNoise(const GridSample& s, bool usable) {
  if (!usable || s.discontinuity) {
    recent_pressures_ = 0;
    if (!usable) return;
  }
  recent_pressure_[0] = recent_pressure_[1];
  recent_pressure_[1] = recent_pressure_[2];
  recent_pressure_[2] = s.p;
  if (++recent_pressures_ >= 3) pressure_noise_.add(recent_pressure_[0], recent_pressure_[1], recent_pressure_[2]);
}

void HydraulicIdentifier::freezeLinearisationPoint(const ParameterVector& physical) {
  linearisation_frozen_ = false;
  refreshLinearisationPoint(physical);
  linearisation_frozen_ = true;
}

void HydraulicIdentifier::refreshLinearisationPoint() { refreshLinearisationPoint(runningPhysicalParameters()); }

void HydraulicIdentifier::refreshLinearisationPoint(ParameterVector physical) {
  if (linearisation_frozen_) return;
  // Early estimates can be unphysical; the linearisation stays inside the plausible ranges.
  const auto& infos = model_.parameterInfos();
  const ParameterVector nominal = model_.nominalParameters();
  for (int i = 0; i < physical.size(); ++i) {
    if (!std::isfinite(physical(i))) physical(i) = nominal(i);
    physical(i) = std::clamp(physical(i), infos[i].lower_bound, infos[i].upper_bound);
  }
  if (physical(HydraulicModel::kBulkModulus) <= 0.0) physical(HydraulicModel::kBulkModulus) = nominal(0);
  linearisation_point_ = physical;
}

HydraulicSignals HydraulicIdentifier::signalsAt(const RegressionRow& row) const {
  HydraulicSignals s;
  s.t = row.t;
  s.p = row.p;
  s.x = row.x;
  s.u = row.u;
  s.y = row.y;
  s.T = row.T;
  s.V = model_.chamberVolume(row.x, linearisation_point_(HydraulicModel::kDeadVolume));
  return s;
}

double HydraulicIdentifier::capacitanceAt(const RegressionRow& row) const {
  return model_.capacitance(signalsAt(row), linearisation_point_);
}

bool HydraulicIdentifier::push(const GridSample& s) {
  // An unmeasured spool arrives already predicted (IdentificationPipeline, per valve message); a NaN spool
  // here means the valve stream itself is missing, and the sample is unusable.
  const bool usable = s.complete && std::isfinite(s.p) && std::isfinite(s.x) && std::isfinite(s.u) &&
                      std::isfinite(s.y) && s.p >= config_.min_pressure &&
                      std::abs(s.y) <= config_.max_spool_opening;
  if (row_noise_per_variance_ > 0.0) addPressureForNoise(s, usable);
  if (!regressor_->push(s, usable, linearisation_point_, &row_)) return false;
  if (++rows_ % static_cast<std::uint64_t>(config_.decimation()) != 0) return false;
  last_step_updated_ = identificationStep();
  return true;
}

bool HydraulicIdentifier::identificationStep() {
  ++steps_;
  if (!row_.valid) {
    ++skipped_invalid_;
    scores_.skip();
    return false;
  }
  const bool excited = std::abs(row_.velocity) >= config_.min_velocity ||
                       std::abs(row_.pressure_rate) >= config_.min_pressure_rate;
  if (!excited) {
    ++skipped_unexcited_;
    scores_.skip();
    return false;
  }
  const int n = model_.parameterCount();
  ParameterVector phi(n);
  // A custom term can still explode off the probed range; such a row would poison the covariance for good.
  constexpr double kLargestColumn = 1e100;
  bool usable = std::isfinite(row_.z);
  for (int j = 0; j < n; ++j) {
    phi(j) = row_.phi[j] * scale_(j) / flow_scale_;
    usable = usable && std::abs(phi(j)) <= kLargestColumn;  // false for NaN too
  }
  if (!usable) {
    ++skipped_invalid_;
    scores_.skip();
    return false;
  }
  const auto status = rls_->update(phi, row_.z / flow_scale_);
  if (status != RecursiveLeastSquares::UpdateStatus::kUpdated) {
    scores_.skip();
    return false;
  }
  // The score with the a-posteriori residual: the a-priori one carries the start-up transient.
  scores_.add(phi * (row_.z / flow_scale_ - phi.dot(rls_->parameters())));
  if (row_noise_per_variance_ > 0.0) {
    double a[kMaxParameters], g[kMaxParameters];
    model_.regressionColumns(signalsAt(row_), linearisation_point_, a, g);
    ParameterVector capacitive(n);
    for (int j = 0; j < n; ++j) capacitive(j) = a[j] * scale_(j) / flow_scale_;
    column_noise_ = config_.forgetting_factor * column_noise_ +
                    row_noise_per_variance_ * capacitive * capacitive.transpose();
    if (rls_->updates() >= running_correction_updates_ + kCorrectionRefresh) {
      running_correction_ = noiseCorrection();
      running_correction_updates_ = rls_->updates();
    }
  }

  // Equation error in the user's units: flow error over capacitance = error of dp/dt.
  const double capacitance = capacitanceAt(row_);
  if (capacitance > 0.0 && std::isfinite(capacitance)) {
    const double rate_error = rls_->lastPriorError() * flow_scale_ / capacitance;
    const double lambda = config_.forgetting_factor;
    error_weight_ = lambda * error_weight_ + 1.0;
    error_mean_square_ += (rate_error * rate_error - error_mean_square_) / error_weight_;
  }
  refreshLinearisationPoint();
  return true;
}

HydraulicEstimate HydraulicIdentifier::estimate() const {
  HydraulicEstimate e;
  e.t = row_.t;
  e.effects = model_.effectNames();
  e.updates = rls_->updates();
  e.steps = steps_;
  e.skipped_invalid = skipped_invalid_;
  e.skipped_unexcited = skipped_unexcited_;
  e.equation_error_rms = std::sqrt(error_mean_square_);
  fillParameters(rls_->parameters(), rls_->covariance(), scores_.scoreCovariance(), column_noise_, e.updates, &e);
  return e;
}

HydraulicEstimate HydraulicIdentifier::combinedEstimate(const HydraulicIdentifier& other) const {
  const int n = model_.parameterCount();
  if (other.model_.parameterCount() != n) throw std::invalid_argument("combinedEstimate: different models");
  if (other.rls_->updates() == 0) return estimate();
  if (rls_->updates() == 0) return other.estimate();
  // Both started from the same prior (theta0, P0). With forgetting, each update scales the information by
  // lambda before adding phi phi', so after n updates a part holds lambda^n of the prior: each part's own
  // share is taken out and the prior put in once, as a run over both would hold it (lambda^(n_a + n_b)).
  // (lambda = 1: the prior once, as before. Exact while the covariance bound, if on, did not act.)
  const double lambda = config_.forgetting_factor;
  const double n_a = static_cast<double>(rls_->updates()), n_b = static_cast<double>(other.rls_->updates());
  const CovarianceMatrix prior_information = CovarianceMatrix::Identity(n, n) / config_.initial_covariance;
  const double prior_share = std::pow(lambda, n_a + n_b) - std::pow(lambda, n_a) - std::pow(lambda, n_b);
  const CovarianceMatrix information_a = rls_->covariance().inverse();
  const CovarianceMatrix information_b = other.rls_->covariance().inverse();
  const CovarianceMatrix information = information_a + information_b + prior_share * prior_information;
  const ParameterVector information_vector = information_a * rls_->parameters() +
                                             information_b * other.rls_->parameters() +
                                             prior_share * (prior_information * rls_->initialParameters());
  const Eigen::LDLT<CovarianceMatrix> solver(information);
  HydraulicEstimate e;
  e.t = std::max(row_.t, other.row_.t);
  e.effects = model_.effectNames();
  e.updates = rls_->updates() + other.rls_->updates();
  e.steps = steps_ + other.steps_;
  e.skipped_invalid = skipped_invalid_ + other.skipped_invalid_;
  e.skipped_unexcited = skipped_unexcited_ + other.skipped_unexcited_;
  const double weight = error_weight_ + other.error_weight_;
  e.equation_error_rms =
      weight > 0.0 ? std::sqrt((error_mean_square_ * error_weight_ + other.error_mean_square_ * other.error_weight_) /
                               weight)
                   : 0.0;
  CovarianceMatrix P = solver.solve(CovarianceMatrix::Identity(n, n));
  P = 0.5 * (P + P.transpose());
  fillParameters(solver.solve(information_vector), P, scores_.scoreCovariance() + other.scores_.scoreCovariance(),
                 column_noise_ + other.column_noise_, e.updates, &e);
  return e;
}

void HydraulicIdentifier::fillParameters(const ParameterVector& theta, const CovarianceMatrix& P,
                                         const CovarianceMatrix& S, const CovarianceMatrix& column_noise,
                                         std::uint64_t updates, HydraulicEstimate* e) const {
  const int n = model_.parameterCount();
  // The corrected coefficients are M theta, M = (I - B)^-1: their covariance is M (P S P) M'.
  const CovarianceMatrix correction = noiseCorrection(P, column_noise, updates);
  const ParameterVector c = (correction * theta).cwiseProduct(scale_);
  CovarianceMatrix J;
  const ParameterVector physical = model_.physicalFromCoefficients(c, &J);
  const CovarianceMatrix coefficient_covariance =
      scale_.asDiagonal() * (correction * (P * S * P) * correction.transpose()) * scale_.asDiagonal();
  const CovarianceMatrix physical_covariance = J * coefficient_covariance * J.transpose();
  for (int i = 0; i < n; ++i) {
    const auto& info = model_.parameterInfos()[i];
    e->parameters.push_back(
        {info.name, info.unit, physical(i), std::sqrt(std::max(physical_covariance(i, i), 0.0))});
  }
}

}  // namespace die_cushion_ident
