#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "die_cushion_ident/core/estimation/identification_config.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/signal/uniform_resampler.h"
#include "die_cushion_ident/core/valve/servo_valve.h"

namespace die_cushion_ident {

/// One standard uncertainty of a reconstructed input of the free run, as the change it makes to the grid's
/// first samples: `spool` is added to the spool that drives the free run (FreeRunPressure::spoolOf),
/// `pressure` to the measured pressure; either may be empty (no change). refineByOutputError carries it into
/// the parameters through its Jacobian (OutputErrorOptions::inputs): the measured pressure cannot tell a
/// parameter's change from the input's error the same pressure change comes from, so the input's
/// uncertainty is the parameters' too (doc/equations.md, "The reconstructed inputs' part").
struct InputPerturbation {
  std::string input;  ///< which input's uncertainty: the parts of one input add in quadrature
  std::vector<float> spool;
  std::vector<float> pressure;  ///< [Pa] added to the measured pressure
};

/// The grid's first `n` samples with `perturbation` added `sign` (+1 or -1) times.
std::vector<GridSample> perturbed(const std::vector<GridSample>& grid, std::size_t n,
                                  const InputPerturbation& perturbation, double sign);

/// The valve model's uncertainty as spool changes ("valve_model"), one per principal axis of `covariance`
/// (natural_frequency [Hz], damping, gain [1/V], dead_time [s]; ValveOperationFit::covariance): the
/// model's spool for the grid's commands at the parameters moved one std along the axis, less the one moved
/// back, halved (one-sided where the dead time would go below 0). Where the grid's spool is not the model's
/// (y_model NaN) the change is 0. Empty unless the covariance is finite with every variance positive.
std::vector<InputPerturbation> valveModelPerturbations(const std::vector<GridSample>& grid, std::size_t n,
                                                       const ServoValveParameters& valve,
                                                       const Eigen::Matrix4d& covariance);

/// The topics' common clock offset against the pressure, known to `std` [s], as a pressure change
/// ("clock_offsets"): the pressure read `std` later less read `std` earlier, halved (timingShifted). Reading
/// the pressure later is reading every input earlier.
InputPerturbation commonOffsetPerturbation(const std::vector<GridSample>& grid, std::size_t n, double std);

/// What drives the free run on the grid's first `n` samples beside the measurements, as perturbations: the
/// spool of `grid_valve` (the model that made the grid's y_model) where it was fitted to the recording
/// (`config.valve_covariance`), and the topics' estimated common clock offset (`config.common_delay_std`);
/// those that change nothing left out. A velocity derived from the position is none of them: the free run
/// reads the position's own slope there (FreeRunPressure).
std::vector<InputPerturbation> freeRunInputUncertainties(const std::vector<GridSample>& grid, std::size_t n,
                                                         const IdentificationConfig& config,
                                                         const ServoValveParameters& grid_valve);

/// Where the free run's inputs came from, beside the grid's own samples.
struct FreeRunInputSources {
  bool spool_predicted = false;  ///< a configured valve model stood in for a spool the topic does not carry
};

/// Whether every input of the free run over the grid's first `n` samples is measured or carries its
/// uncertainty (freeRunInputUncertainties): the measured spool or a valve model fitted to it (the position
/// is measured, and a velocity derived from it is the position's own slope in the free run). A configured
/// valve model's spool (predicted, or y_model without a covariance) or the oil's temperature (where `model`
/// follows it) is not: its error is in neither std (ParameterUncertainty::free_run_inputs_known).
bool freeRunInputsKnown(const std::vector<GridSample>& grid, std::size_t n,
                        const IdentificationConfig& config, const HydraulicModel& model,
                        const FreeRunInputSources& sources);

}  // namespace die_cushion_ident
