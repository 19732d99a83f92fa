#pragma once

#include <vector>

#include "die_cushion_ident/core/adequacy/effect_ranking.h"
#include "die_cushion_ident/core/adequacy/formula_search.h"

namespace die_cushion_ident {

/// Runs proposeFormulas on top of the ranking's recommended model (the configured one plus its steps) and
/// says in the ranking's conclusion which formula to add. Library effects keep priority: the search
/// starts from the model with every missing library effect added.
void addFormulaProposals(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                         const IdentificationConfig& config, EffectRankingResult* ranking,
                         const EffectRankingOptions& ranking_options = {},
                         const FormulaSearchOptions& options = {});

}  // namespace die_cushion_ident
