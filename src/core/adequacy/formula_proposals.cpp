#include "die_cushion_ident/core/adequacy/formula_proposals.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {

std::string inBar(double pa) { return formatted(FMT_STRING("{:.2g}"), pa * 1e-5); }

// A library step that only took part of this error may be superseded by the formula: kept only where
// it still lowers the held-out error of the model with the formula, as a missing effect would. Returns the
// superseded steps, taken out of the ranking's steps and recommended effects.
std::vector<std::string> supersededSteps(const std::vector<GridSample>& grid,
                                         const StrokeSegmentation& strokes,
                                         const IdentificationConfig& recommended,
                                         const std::vector<const FormulaProposal*>& add,
                                         EffectRankingResult* ranking,
                                         const EffectRankingOptions& ranking_options) {
  std::vector<std::string> superseded;
  if (ranking->steps.empty()) return superseded;
  IdentificationConfig full = recommended;
  for (const auto* p : add) full.custom_effects.push_back(p->spec());
  const int split = ranking_options.split(strokes.cycles);
  // Both sides' held-out free runs kept: the formulas' once here (its pass did not keep them), each step's
  // model's from the pass that measures it. The test's adjustment compares them, and ran both models again
  // for every step otherwise.
  HeldOutErrors with_all = add.back()->held_out;
  keepPredictions(grid, strokes, &with_all);
  for (const auto& step : ranking->steps) {
    IdentificationConfig without = full;
    without.effects.erase(std::find(without.effects.begin(), without.effects.end(), step.add));
    const HeldOutComparison keep =
        compareHeldOut(grid, strokes, heldOutErrorsKept(grid, strokes, without, split), with_all,
                       ranking_options.significance);
    if (keep.error_reduction >= ranking_options.missing_reduction && keep.significant) continue;
    superseded.push_back(step.add);
    for (auto& c : ranking->candidates) {
      if (c.effect != step.add) continue;
      c.verdict = Verdict::kNotNeeded;
      c.explanation += "; but with the proposed '" + add.front()->name +
                       "' it changes the held-out error by only " +
                       std::to_string(static_cast<int>(std::lround(100.0 * keep.error_reduction))) +
                       " %: the formula explains what it took part of";
    }
  }
  for (const auto& name : superseded) {
    ranking->steps.erase(std::remove_if(ranking->steps.begin(), ranking->steps.end(),
                                        [&](const EffectStep& s) { return s.add == name; }),
                         ranking->steps.end());
    auto& effects = ranking->recommended_effects;
    effects.erase(std::remove(effects.begin(), effects.end(), name), effects.end());
  }
  return superseded;
}

// The conclusion with the proposed terms: what to add and how far the held-out error falls.
std::string formulaConclusion(const std::vector<const FormulaProposal*>& add,
                              const std::vector<std::string>& superseded, const EffectRankingResult& ranking,
                              const EffectRankingOptions& options) {
  std::string terms, path = inBar(ranking.best_error_rms);
  for (std::size_t i = 0; i < add.size(); ++i) {
    terms += std::string(i == 0 ? "" : " together with ") + "'" + add[i]->spec() + "' (" +
             add[i]->explanation.substr(0, add[i]->explanation.find(';')) + ")";
    path += " -> " + inBar(add[i]->held_out_error_rms);
  }
  std::string library;
  for (const auto& step : ranking.steps) library += (library.empty() ? "'" : ", '") + step.add + "'";
  std::string dropped;
  for (const auto& name : superseded) dropped += (dropped.empty() ? "'" : ", '") + name + "'";
  return (library.empty() ? "The" : "Add the library effect(s) " + library + "; the") +
         " error no library effect explains has a formula: add " + terms +
         " as a custom effect (--custom-effect or ~set_effects); held-out error " + path +
         " bar rms, noise " + inBar(ranking.noise_rms) + " bar; with it " +
         errorLeftInWords(add.back()->held_out_error_rms, ranking.noise_rms, options) +
         (add.back()->held_out_error_rms > structuredErrorFloor(ranking.noise_rms, options)
              ? (add.size() < 2 ? ", and no second term proved itself on held-out cycles"
                                : ", and the search stops at two terms")
              : "") +
         "." +
         (dropped.empty()
              ? ""
              : " " + dropped + " is then not needed (the formula explains what it took part of).");
}

}  // namespace

void addFormulaProposals(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                         const IdentificationConfig& config, EffectRankingResult* ranking,
                         const EffectRankingOptions& ranking_options, const FormulaSearchOptions& options) {
  if (strokes.cycles < ranking_options.min_held_out_cycles ||
      ranking->recommended_held_out.cycle_rms.empty()) {
    return;
  }
  IdentificationConfig recommended = config;
  recommended.effects = ranking->recommended_effects;
  ranking->proposals =
      proposeFormulas(grid, strokes, recommended, ranking->recommended_held_out,
                      structuredErrorFloor(ranking->noise_rms, ranking_options), ranking_options, options);
  std::vector<const FormulaProposal*> add;
  for (const auto& p : ranking->proposals) {
    if (p.verdict == Verdict::kMissing && (add.empty() || p.together_with == add.back()->name))
      add.push_back(&p);
  }
  if (add.empty()) {
    if (ranking->residual_unexplained) {
      ranking->conclusion += " The formula search found no term that proves itself on held-out cycles.";
    }
    return;
  }
  for (auto& p : ranking->proposals) {
    if (p.verdict == Verdict::kMissing && &p != add.front() && p.together_with.empty()) {
      p.explanation += " (an alternative to '" + add.front()->name + "', which explains more)";
    }
  }
  const std::vector<std::string> superseded =
      supersededSteps(grid, strokes, recommended, add, ranking, ranking_options);
  ranking->conclusion = formulaConclusion(add, superseded, *ranking, ranking_options);
}

}  // namespace die_cushion_ident
