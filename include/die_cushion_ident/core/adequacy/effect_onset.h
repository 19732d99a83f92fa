#pragma once

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "die_cushion_ident/core/adequacy/model_assessment.h"
#include "die_cushion_ident/core/estimation/identification_config.h"

namespace die_cushion_ident {

/// Press cycles findEffectOnset needs at least (two each side of a step, and the scatter within them).
constexpr int kOnsetMinimumCycles = 6;

/// A library effect that starts, or steps, within one recording: a seal that starts leaking, air drawn in
/// after a pump was changed. A model with constant parameters averages over it ("bulk_modulus drifts
/// 1.71e9 -> 1.27e9"); this names the effect and the press cycle it starts in.
struct EffectOnset {
  std::string effect;     ///< the library effect
  std::string parameter;  ///< its parameter
  std::string unit;
  int cycle = 0;  ///< the first press cycle it acts in (StrokeSegmentation's index: 0 is the first impact)
  double time = 0.0;          ///< [s] that cycle's start (its impact), from the grid's first sample
  double cycle_period = 0.0;  ///< [s] the press cycles' median period, for reading `cycle` against a time
  double before = 0.0,
         before_std = 0.0;  ///< the parameter over the cycles before: mean of the cycles' own fits, its std
  double after = 0.0, after_std = 0.0;  ///< the same over the cycles from `cycle` on
  double t_statistic = 0.0;             ///< of the step, in units of the cycles' own scatter
  /// Two-sided, Bonferroni-corrected over every split and every effect tried.
  double p_value = 1.0;
  std::string explanation;
};

/// Each library effect (added to the configured model where it is not in it) fitted to every press cycle
/// alone, up to `max_groups` groups of cycles; in the series of its parameter over the cycles, the split
/// into "before" and "from cycle k on" whose two means differ most in units of the cycles' pooled scatter
/// (a two-sample t with G - 2 degrees of freedom, at least 2 groups each side). A step counts where its
/// corrected p-value is below `significance`, two means describe the series better than a straight line
/// through it (a gradual drift, the oil warming, is not an onset) and the parameter lies within its
/// physical range where the effect acts (another effect that starts pulls it out). Of several, one that
/// appears or grows before one that shrinks, and of those the one whose model, fitted to the cycles from
/// its step on, runs free closest to them. Nothing with fewer than 6 cycles. The fits on up to `jobs`
/// threads (0: one per core). On a grid of every `cycle_stride`-th cycle of a recording that began at
/// `recording_start` [s] (EvenlyThinnedCycles; NaN: at the grid's first sample) the onset is told in the
/// recording's cycles and time; a grid whose first cycle is the recording's `first_cycle`-th (the live
/// window, LiveChangePoint) tells it counted from there.
std::optional<EffectOnset> findEffectOnset(const std::vector<GridSample>& grid,
                                           const StrokeSegmentation& strokes,
                                           const IdentificationConfig& config, double significance = 1e-3,
                                           int jobs = 1, int max_groups = 60, int cycle_stride = 1,
                                           double recording_start = std::numeric_limits<double>::quiet_NaN(),
                                           int first_cycle = 0);

}  // namespace die_cushion_ident
