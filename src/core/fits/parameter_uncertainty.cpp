#include "die_cushion_ident/core/fits/parameter_uncertainty.h"

#include <algorithm>
#include <cmath>

namespace die_cushion_ident {

double ParameterUncertainty::equationError() const {
  // The equation-error fit's sandwich and its cycle jackknife estimate the same variance: pooled where the
  // jackknife ran.
  return cycles > 0.0 ? std::sqrt(0.5 * (regression * regression + cycles * cycles)) : regression;
}

double ParameterUncertainty::combined() const {
  // The free run's sandwich is the reported estimator's own. Where an input it is driven by has an error no
  // part carries (a configured valve model: both estimators biased alike, 3-45 of its stds on fast
  // presses), the equation error's pool bounds it as well; it is not pooled with the free run's (pooled, a
  // free run that scatters more than the equation error had its std diluted by the jackknife).
  const double statistical =
      free_run_inputs_known && free_run > 0.0 ? free_run : std::max(equationError(), free_run);
  return std::sqrt(statistical * statistical + misfit * misfit + method * method + valve_model * valve_model +
                   clock_offsets * clock_offsets);
}

std::vector<ParameterUncertainty> combineUncertainty(const HydraulicEstimate& equation_error,
                                                     const std::optional<OutputErrorFit>& refined,
                                                     const HydraulicEstimate* jackknife,
                                                     HydraulicEstimate* reported, bool free_run_inputs_known,
                                                     const EquationErrorBias* bias) {
  std::vector<ParameterUncertainty> parts(reported->parameters.size());
  const bool refined_used = refined && refined->improved;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    ParameterUncertainty& u = parts[k];
    u.regression =
        k < equation_error.parameters.size() ? equation_error.parameters[k].std : reported->parameters[k].std;
    if (refined_used && i < refined->std.size() && std::isfinite(refined->std(i)))
      u.free_run = refined->std(i);
    if (refined_used) {
      const auto part = [&](const char* input) {
        const auto found = refined->input_std.find(input);
        return found != refined->input_std.end() && i < found->second.size() &&
                       std::isfinite(found->second(i))
                   ? found->second(i)
                   : 0.0;
      };
      u.valve_model = part("valve_model");
      u.clock_offsets = part("clock_offsets");
      u.free_run_inputs_known = free_run_inputs_known;
    }
    if (jackknife && k < jackknife->parameters.size() && std::isfinite(jackknife->parameters[k].std)) {
      u.cycles = jackknife->parameters[k].std;
    }
    // The refinement not kept because the estimate's free run stays R times the pressure noise: the
    // equation-error stds, read from residuals the derivative form leaves, assume the model describes the
    // recording to the noise; scaled by R (Birge's ratio), u_stat^2 R^2 = u_stat^2 + misfit^2.
    if (refined && !refined->improved && refined->noise > 0.0 && refined->start_rms > refined->noise) {
      const double ratio = refined->start_rms / refined->noise;
      if (std::isfinite(ratio)) u.misfit = u.equationError() * std::sqrt(ratio * ratio - 1.0);
    }
    // Only the part of the two estimators' difference their scatter does not explain bounds a bias: where
    // the free run is the more efficient estimator of the two, var(eq - free run) = var(eq) - var(free run)
    // (Hausman 1978). The whole difference counted the equation error's own scatter, which the fast press's
    // 50 ms windows make several times the free run's, as a bias: its stds were about twice their errors
    // once the free run's inputs were right (doc/equations.md).
    // The equation error's own bias at the refined model (its filter windows against a fast press's
    // transients: 2-9 % of the bulk modulus on fast presses, 2-5 times the errors) is no disagreement
    // between the estimators: its fit to the model's own noise-free free run carries it, and d is taken
    // against that fit, both over the refinement's samples.
    if (refined_used && k < equation_error.parameters.size() && i < refined->theta.size()) {
      double difference = refined->theta(i) - equation_error.parameters[k].value, pool = u.equationError();
      if (bias && k < bias->measured.parameters.size() && k < bias->own_free_run.parameters.size()) {
        const IdentifiedParameter &measured = bias->measured.parameters[k],
                                  &own = bias->own_free_run.parameters[k];
        difference = own.value - measured.value;
        // Over fewer samples than the whole recording the window's fit scatters more: the pool scaled by it.
        const double ratio = measured.std / equation_error.parameters[k].std;
        if (std::isfinite(ratio) && ratio > 1.0) pool *= ratio;
      }
      const double scatter = std::max(0.0, pool * pool - u.free_run * u.free_run);
      if (std::isfinite(difference) && std::isfinite(scatter))
        u.method = std::sqrt(std::max(0.0, difference * difference - scatter)) / std::sqrt(3.0);
    }
    reported->parameters[k].std = u.combined();
  }
  return parts;
}

}  // namespace die_cushion_ident
