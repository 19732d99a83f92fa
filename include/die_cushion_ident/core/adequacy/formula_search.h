#pragma once

#include <string>
#include <vector>

#include "die_cushion_ident/core/adequacy/effect_ranking.h"
#include "die_cushion_ident/core/adequacy/held_out_test.h"
#include "die_cushion_ident/core/model/formula_term.h"

namespace die_cushion_ident {

struct FormulaSearchOptions {
  int breakpoints = 24;      ///< coarse breakpoint grid per shape (quantiles of the signal)
  int refinement = 16;       ///< fine grid between the best coarse point's neighbours
  int refinement_cycles = 12;  ///< cycles of the golden-section search on the free-run error ...
  int refinement_steps = 10;   ///< ... and its steps (the bracket shrinks to 0.8 %)
  int verified = 3;          ///< shapes proven on held-out cycles per term, at most ...
  double prove_fraction = 0.25;  ///< ... of those the screen rates at least this fraction of the best
  int max_terms = 2;         ///< one or two terms
  int window = 10;           ///< samples per integrated volume balance of the screen (20 ms)
  std::size_t max_windows = 50000;  ///< more: every k-th window (an hour of data has 180 000)
  double tie = 0.1;          ///< held-out errors within this fraction explain "the same": the simpler wins
};

/// Searches the typed space of FormulaTerm for the term that the model `model` misses, in two stages:
/// a screen over every shape and breakpoint by the least-squares reduction of the integrated volume
/// balance (cheap, all breakpoints in one pass over the data), then the best few shapes proven like the
/// library candidates: fitted on one half of the cycles, run free on the other, paired across cycles
/// against `base` (the held-out errors of `model`). A term whose theta comes out negative is discarded.
/// A second term is searched on top of a first one that is missing while structured error is left.
/// Most explanatory first; `ranking` gives the verdict thresholds.
std::vector<FormulaProposal> proposeFormulas(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                             const IdentificationConfig& model, const HeldOutErrors& base,
                                             double structured_floor, const EffectRankingOptions& ranking = {},
                                             const FormulaSearchOptions& options = {});

}  // namespace die_cushion_ident
