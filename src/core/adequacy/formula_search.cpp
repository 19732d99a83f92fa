#include "die_cushion_ident/core/adequacy/formula_search.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <set>
#include <stdexcept>

#include "die_cushion_ident/core/fits/free_run_pressure.h"
#include "die_cushion_ident/core/model/hydraulic_model.h"
#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {

bool usable(const GridSample& s, const IdentificationConfig& config) {
  return s.complete && !s.discontinuity && std::isfinite(s.p) && std::isfinite(s.x) && std::isfinite(s.v) &&
         std::isfinite(s.y) && s.p >= config.min_pressure && std::abs(s.y) <= config.max_spool_opening;
}

// The screen's data: the volume balance integrated over short windows,
//   A (x_end - x_start) = sum_j c_j (int a_j dp + int g_j dt) + theta (int f dt  or  int c dp),
// the same balance the identifier fits, without its filters (a screen ranks terms, it does not report
// them). The model's own columns are free; a term is scored by how much it lowers the residual sum of
// squares, all breakpoints of a shape in one pass over the samples.
class BalanceScreen {
 public:
  /// On cycles [first_cycle, last_cycle] (all: INT_MIN, INT_MAX).
  BalanceScreen(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                const IdentificationConfig& config, const HydraulicModel& model, const ParameterVector& theta,
                const FormulaSearchOptions& options, int first_cycle = INT_MIN, int last_cycle = INT_MAX)
      : grid_(grid), window_(options.window), dt_(config.resampler.sample_period) {
    const auto [begin, end] = strokes.range(first_cycle, last_cycle);
    // Windows of window_+1 usable samples in a row, not overlapping.
    std::vector<std::size_t> starts;
    std::size_t run = 0;
    for (std::size_t i = begin; i < end && i < grid.size(); ++i) {
      run = usable(grid[i], config) ? run + 1 : 0;
      if (run == static_cast<std::size_t>(window_) + 1) {
        starts.push_back(i - window_);
        run = 1;  // the window's last sample starts the next one
      }
    }
    const std::size_t stride = std::max<std::size_t>(1, starts.size() / options.max_windows + 1);
    for (std::size_t w = 0; w < starts.size(); w += stride) starts_.push_back(starts[w]);

    k_ = model.parameterCount();
    const int n = static_cast<int>(starts_.size());
    X_.resize(n, k_);
    y_.resize(n);
    std::vector<double> a(k_), g(k_), a_prev(k_), g_prev(k_);
    for (int w = 0; w < n; ++w) {
      const std::size_t s0 = starts_[w];
      X_.row(w).setZero();
      for (int i = 0; i <= window_; ++i) {
        const GridSample& s = grid[s0 + i];
        HydraulicSignals signals;
        signals.t = s.t;
        signals.p = s.p;
        signals.x = s.x;
        signals.v = s.v;
        signals.u = s.u;
        signals.y = s.y;
        signals.T = s.T;
        signals.dp = i > 0 ? (s.p - grid[s0 + i - 1].p) / dt_ : 0.0;
        signals.V = model.chamberVolume(s.x, theta(HydraulicModel::kDeadVolume));
        model.regressionColumns(signals, theta, a.data(), g.data());
        if (i > 0) {
          const double dp = s.p - grid[s0 + i - 1].p;
          for (int j = 0; j < k_; ++j) X_(w, j) += 0.5 * (a[j] + a_prev[j]) * dp + 0.5 * (g[j] + g_prev[j]) * dt_;
        }
        std::swap(a, a_prev);
        std::swap(g, g_prev);
      }
      y_(w) = model.geometry().piston_area * (grid[s0 + window_].x - grid[s0].x);
    }
    // Columns scaled to unit norm: a conditioned Gram matrix whatever the units.
    scale_ = X_.colwise().norm().transpose();
    for (int j = 0; j < k_; ++j) {
      if (!(scale_(j) > 0.0)) scale_(j) = 1.0;
      X_.col(j) /= scale_(j);
    }
    gram_.compute(X_.transpose() * X_);
    const Eigen::VectorXd c = gram_.solve(X_.transpose() * y_);
    residual_ = y_ - X_ * c;
    base_rss_ = residual_.squaredNorm();
  }

  int windows() const { return static_cast<int>(starts_.size()); }
  double baseRss() const { return base_rss_; }
  double windowSeconds() const { return window_ * dt_; }

  /// Per window, the integral of the term (flow: int f dt; compliance: int c dp).
  void termColumn(const FormulaTerm& term, Eigen::VectorXd* column) const { termColumns({term}, column, 1); }

  /// Columns of several terms at once (same shape, different breakpoints), column-major n x terms.
  void termColumns(const std::vector<FormulaTerm>& terms, Eigen::VectorXd* columns, int count) const {
    const int n = windows();
    columns->setZero(static_cast<Eigen::Index>(n) * count);
    std::vector<double> previous(count), current(count);
    for (int w = 0; w < n; ++w) {
      const std::size_t s0 = starts_[w];
      for (int i = 0; i <= window_; ++i) {
        const GridSample& s = grid_[s0 + i];
        for (int b = 0; b < count; ++b) current[b] = terms[b].value(s.p, s.x, s.v, s.y);
        if (i > 0) {
          const double step = terms[0].isCompliance() ? s.p - grid_[s0 + i - 1].p : dt_;
          for (int b = 0; b < count; ++b) (*columns)(static_cast<Eigen::Index>(b) * n + w) += 0.5 * (current[b] + previous[b]) * step;
        }
        std::swap(current, previous);
      }
    }
  }

  struct Score {
    double reduction = 0.0;    ///< of the residual sum of squares
    double coefficient = 0.0;  ///< theta in the column's unit
  };

  /// How much a column lowers the residual with the model's columns refitted alongside.
  Score score(const Eigen::Ref<const Eigen::VectorXd>& z) const {
    Score s;
    const double zz = z.squaredNorm();
    if (!(zz > 0.0) || !std::isfinite(zz)) return s;
    const Eigen::VectorXd Xz = X_.transpose() * z;
    const double denominator = zz - Xz.dot(gram_.solve(Xz));
    if (!(denominator > 1e-9 * zz)) return s;  // the model's columns already span it
    const double zr = z.dot(residual_);
    s.reduction = zr * zr / denominator;
    s.coefficient = zr / denominator;
    return s;
  }

  /// The residual (without the term) and the fitted term per window [m^3/s], binned over the term's
  /// signal at the window centre.
  void binned(const FormulaTerm& term, std::vector<double>* centres, std::vector<double>* residual,
              std::vector<double>* fitted) const {
    Eigen::VectorXd z;
    termColumn(term, &z);
    const Score s = score(z);
    const int n = windows();
    std::vector<double> at(n);
    for (int w = 0; w < n; ++w) at[w] = signalOf(term.signal(), grid_[starts_[w] + window_ / 2]);
    std::vector<double> sorted = at;
    std::sort(sorted.begin(), sorted.end());
    if (sorted.empty()) return;
    const double lo = sorted[sorted.size() / 100], hi = sorted[sorted.size() - 1 - sorted.size() / 100];
    constexpr int kBins = 30;
    if (!(hi > lo)) return;
    std::vector<double> sum_r(kBins, 0.0), sum_f(kBins, 0.0), sum_s(kBins, 0.0);
    std::vector<int> count(kBins, 0);
    for (int w = 0; w < n; ++w) {
      const int b = static_cast<int>((at[w] - lo) / (hi - lo) * kBins);
      if (b < 0 || b >= kBins) continue;
      sum_r[b] += residual_(w) / windowSeconds();
      sum_f[b] += s.coefficient * z(w) / windowSeconds();
      sum_s[b] += at[w];
      ++count[b];
    }
    for (int b = 0; b < kBins; ++b) {
      if (count[b] < 5) continue;
      centres->push_back(sum_s[b] / count[b]);
      residual->push_back(sum_r[b] / count[b]);
      fitted->push_back(sum_f[b] / count[b]);
    }
  }

  /// Quantiles of a signal over the screen's samples (breakpoint candidates), from q_lo to q_hi.
  std::vector<double> quantiles(char signal, int count, double q_lo, double q_hi) const {
    std::vector<double> values;
    values.reserve(starts_.size());
    for (std::size_t s0 : starts_) values.push_back(signalOf(signal, grid_[s0 + window_ / 2]));
    std::sort(values.begin(), values.end());
    std::vector<double> q;
    if (values.empty()) return q;
    for (int i = 0; i < count; ++i) {
      const double f = q_lo + (q_hi - q_lo) * i / std::max(count - 1, 1);
      q.push_back(values[static_cast<std::size_t>(f * (values.size() - 1))]);
    }
    q.erase(std::unique(q.begin(), q.end()), q.end());
    return q;
  }

 private:
  static double signalOf(char signal, const GridSample& s) {
    return signal == 'p' ? s.p : signal == 'x' ? s.x : signal == 'v' ? s.v : s.y;
  }

  const std::vector<GridSample>& grid_;
  int window_;
  double dt_;
  int k_ = 0;
  std::vector<std::size_t> starts_;
  Eigen::MatrixXd X_;
  Eigen::VectorXd y_, scale_, residual_;
  Eigen::LDLT<Eigen::MatrixXd> gram_;
  double base_rss_ = 0.0;
};

struct Screened {
  FormulaTerm term;
  double reduction = 0.0;
  double lo = 0.0, hi = 0.0;  ///< the breakpoint's bracket: the coarse grid's neighbours of the best
};

// The term of one shape with its best breakpoint: a coarse grid over the signal's quantiles, then a fine
// grid between the best point's neighbours. A negative theta turns a two-way flow into an inflow and
// disqualifies the rest.
Screened bestOfShape(const BalanceScreen& screen, const FormulaTerm& shape, const FormulaSearchOptions& options) {
  Screened best{shape, 0.0, 0.0, 0.0};
  const auto judge = [&](const std::vector<FormulaTerm>& terms) {
    // Eight breakpoints per pass over the data: an hour's columns for all 24 at once would take 35 MB.
    constexpr int kChunk = 8;
    Eigen::VectorXd columns;
    const int n = screen.windows();
    int best_index = -1;
    for (std::size_t b = 0; b < terms.size(); ++b) {
      if (b % kChunk == 0) {
        const std::vector<FormulaTerm> chunk(terms.begin() + b, terms.begin() + std::min(b + kChunk, terms.size()));
        screen.termColumns(chunk, &columns, static_cast<int>(chunk.size()));
      }
      const auto s = screen.score(columns.segment(static_cast<Eigen::Index>(b % kChunk) * n, n));
      const bool physical = s.coefficient > 0.0 || (s.coefficient < 0.0 && terms[b].mayBeInflow());
      if (!physical || !(s.reduction > best.reduction)) continue;
      best.term = terms[b].withSign(s.coefficient > 0.0 ? +1 : -1);
      best.reduction = s.reduction;
      best_index = static_cast<int>(b);
    }
    return best_index;
  };
  if (!shape.hasBreakpoint()) {
    judge({shape});
    return best;
  }
  const bool pressure_compliance = shape.isCompliance() && shape.signal() == 'p';
  const std::vector<double> coarse =
      screen.quantiles(shape.signal(), options.breakpoints, pressure_compliance ? 0.05 : 0.02, 0.98);
  if (coarse.size() < 2) return best;
  std::vector<FormulaTerm> terms;
  for (double b : coarse) terms.push_back(shape.withBreakpoint(b));
  const int at = judge(terms);
  if (at < 0) return best;
  const double lo = coarse[std::max(at - 1, 0)];
  const double hi = coarse[std::min<int>(at + 1, static_cast<int>(coarse.size()) - 1)];
  best.lo = lo;
  best.hi = hi;
  terms.clear();
  for (int i = 0; i < options.refinement; ++i) {
    terms.push_back(shape.withBreakpoint(lo + (hi - lo) * (i + 0.5) / options.refinement));
  }
  judge(terms);
  return best;
}

std::vector<Screened> screenAll(const BalanceScreen& screen, double supply_pressure,
                                const FormulaSearchOptions& options) {
  std::vector<Screened> all;
  for (const auto& shape : FormulaTerm::searchSpace(supply_pressure)) {
    Screened s = bestOfShape(screen, shape, options);
    if (s.reduction > 0.0) all.push_back(s);
  }
  std::sort(all.begin(), all.end(), [](const Screened& a, const Screened& b) { return a.reduction > b.reduction; });
  return all;
}

// Free-run error [Pa] of `config` fitted on cycles [first, last] and run free on them.
double freeRunRms(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                  const IdentificationConfig& config, int first, int last) {
  const HydraulicModel model =
      HydraulicModel::fromNames(config.geometry, config.effects, config.custom_effects, config.oil);
  const HydraulicEstimate e = fitOnCycles(grid, strokes, config, first, last);
  const auto [begin, end] = strokes.range(first, last);
  const SquaredErrors errors = freeRunSquaredErrors(grid, begin, end, model, e.values(), config.min_pressure);
  return errors.samples > 0 ? std::sqrt(errors.sum / errors.samples)
                            : std::numeric_limits<double>::infinity();
}

// The screen ranks shapes by the equation error, which weighs fast transients by their noise; the
// breakpoint a user adds is the one that makes the model run best. A golden-section search on the
// free-run error over the screen's bracket, on at most a dozen of cycles [first, last], settles it (0.8 % of
// the bracket).
FormulaTerm refineBreakpoint(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                             const IdentificationConfig& model, const Screened& screened,
                             const FormulaSearchOptions& options, int first = 0, int last = INT_MAX) {
  if (!screened.term.hasBreakpoint() || !(screened.hi > screened.lo)) return screened.term;
  last = std::min({last, strokes.cycles - 1, first + options.refinement_cycles - 1});
  const auto error = [&](double b) {
    IdentificationConfig extended = model;
    extended.custom_effects.push_back(screened.term.name() + "=" + screened.term.withBreakpoint(b).expression());
    try {
      return freeRunRms(grid, strokes, extended, first, last);
    } catch (const std::invalid_argument&) {
      return std::numeric_limits<double>::infinity();
    }
  };
  constexpr double kGolden = 0.6180339887498949;
  double a = screened.lo, b = screened.hi;
  double c = b - kGolden * (b - a), d = a + kGolden * (b - a);
  double fc = error(c), fd = error(d);
  for (int i = 0; i < options.refinement_steps; ++i) {
    if (fc < fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - kGolden * (b - a);
      fc = error(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + kGolden * (b - a);
      fd = error(d);
    }
  }
  const double at_screen = error(screened.term.breakpoint());
  const double best = fc < fd ? c : d;
  return std::min(fc, fd) < at_screen ? screened.term.withBreakpoint(best) : screened.term;
}

std::string uniqueName(const std::string& wanted, const IdentificationConfig& model) {
  std::set<std::string> taken(model.effects.begin(), model.effects.end());
  for (const auto& spec : model.custom_effects) taken.insert(spec.substr(0, spec.find('=')));
  std::string name = wanted;
  for (int i = 2; taken.count(name) > 0; ++i) name = wanted + "_" + std::to_string(i);
  return name;
}

// The screen over cycles [first, last] (all: INT_MIN, INT_MAX), the model's own columns at its fit to them
// (its nominal values where that fails); none where too few windows hold all inputs.
std::optional<BalanceScreen> screenOnCycles(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                            const IdentificationConfig& model, const HydraulicModel& hydraulic,
                                            const FormulaSearchOptions& options, int first, int last) {
  ParameterVector theta = fitOnCycles(grid, strokes, model, first, last).values();
  if (!theta.allFinite()) theta = hydraulic.nominalParameters();
  std::optional<BalanceScreen> screen(std::in_place, grid, strokes, model, hydraulic, theta, options, first, last);
  if (screen->windows() < 10 * hydraulic.parameterCount()) return std::nullopt;
  return screen;
}

// The held-out errors of a term whose breakpoint each fold chooses on its own training cycles (the screen
// and the free-run refinement, as on all cycles): the cycles a fold is tested on never took part in
// choosing what is tested on them. Empty where a fold's screen finds no physical breakpoint for the shape.
std::optional<HeldOutErrors> heldOutErrorsNested(const std::vector<GridSample>& grid,
                                                 const StrokeSegmentation& strokes,
                                                 const IdentificationConfig& model, const FormulaTerm& term,
                                                 const FormulaProposal& proposal, const HeldOutErrors& base,
                                                 const EffectRankingOptions& ranking,
                                                 const FormulaSearchOptions& options) {
  const int split = ranking.split(strokes.cycles);
  std::array<IdentificationConfig, 2> folds = {model, model};
  const HydraulicModel hydraulic =
      HydraulicModel::fromNames(model.geometry, model.effects, model.custom_effects, model.oil);
  for (int which = 0; which < 2; ++which) {
    FormulaTerm chosen = term;
    if (term.hasBreakpoint()) {
      const int first = which == 0 ? 0 : split, last = which == 0 ? split - 1 : strokes.cycles - 1;
      const std::optional<BalanceScreen> screen = screenOnCycles(grid, strokes, model, hydraulic, options, first, last);
      if (!screen) return std::nullopt;
      const Screened screened = bestOfShape(*screen, term, options);
      if (!(screened.reduction > 0.0)) return std::nullopt;
      try {
        chosen = refineBreakpoint(grid, strokes, model, screened, options, first, last);
      } catch (const std::invalid_argument&) {
        return std::nullopt;
      }
    }
    folds[which].custom_effects.push_back(proposal.name + "=" + chosen.expression());
  }
  try {
    return heldOutErrors(grid, strokes, folds, split, false, &base);
  } catch (const std::invalid_argument&) {
    return std::nullopt;  // a fold's breakpoint leaves a term that is zero where the effect is probed
  }
}

// Proves one screened term like a library candidate, its breakpoint chosen within each fold.
FormulaProposal prove(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                      const IdentificationConfig& model, const HeldOutErrors& base, const FormulaTerm& term,
                      const BalanceScreen& screen, const EffectRankingOptions& ranking,
                      const FormulaSearchOptions& options) {
  FormulaProposal proposal;
  proposal.name = uniqueName(term.name(), model);
  proposal.expression = term.expression();
  proposal.signal = term.signal();
  proposal.compliance = term.isCompliance();
  if (term.hasBreakpoint()) proposal.breakpoint = term.breakpoint();
  IdentificationConfig extended = model;
  extended.custom_effects.push_back(proposal.spec());
  const HydraulicEstimate all = fitOnCycles(grid, strokes, extended, INT_MIN, INT_MAX);
  double theta = 0.0;
  for (auto p : all.parameters) {
    if (p.name != proposal.name + "_theta") continue;
    p.unit = term.unit();
    theta = p.value;
    proposal.parameters.push_back(p);
  }
  const std::optional<HeldOutErrors> nested =
      heldOutErrorsNested(grid, strokes, model, term, proposal, base, ranking, options);
  if (!nested) {
    proposal.verdict = Verdict::kInconclusive;
    proposal.explanation = term.explanation() + "; on one half of the cycles alone the screen finds no physical "
                                                "breakpoint for it, so it could not be tested on the other half";
    return proposal;
  }
  const HeldOutErrors& with = *nested;
  const HeldOutComparison test = compareHeldOut(grid, strokes, base, with, ranking.significance);
  proposal.held_out = with;
  proposal.error_reduction = test.error_reduction;
  proposal.held_out_error_rms = with.rms;
  proposal.held_out_cycles = test.cycles;
  proposal.t_statistic = test.t_statistic;
  proposal.p_value = test.p_value;
  const std::string implausible =
      theta > 0.0 ? std::string()
                  : std::string("; fitted on all the data its coefficient comes out ") +
                        (theta < 0.0 ? "negative" : "zero") + ", which is not physical";
  const HeldOutVerdict verdict = judgeHeldOut(test, implausible, ranking);
  proposal.verdict = verdict.verdict;
  proposal.explanation = term.explanation() + verdict.reason;
  screen.binned(term, &proposal.bin_signal, &proposal.bin_residual, &proposal.bin_term);
  return proposal;
}

// Most explanatory first; where two explain the same, the simpler formula.
void orderProposals(std::vector<std::pair<FormulaProposal, int>>& proposals, double tie) {
  std::sort(proposals.begin(), proposals.end(), [&](const auto& a, const auto& b) {
    const bool a_missing = a.first.verdict == Verdict::kMissing, b_missing = b.first.verdict == Verdict::kMissing;
    if (a_missing != b_missing) return a_missing;
    const double ea = a.first.held_out_error_rms, eb = b.first.held_out_error_rms;
    if (std::abs(ea - eb) <= tie * std::min(ea, eb) && a.second != b.second) return a.second < b.second;
    return a.first.error_reduction > b.first.error_reduction;
  });
}

// One term on top of `model`: screen, then prove the best few shapes.
std::vector<FormulaProposal> searchOneTerm(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                           const IdentificationConfig& model, const HeldOutErrors& base,
                                           const EffectRankingOptions& ranking, const FormulaSearchOptions& options) {
  const HydraulicModel hydraulic =
      HydraulicModel::fromNames(model.geometry, model.effects, model.custom_effects, model.oil);
  const std::optional<BalanceScreen> screen =
      screenOnCycles(grid, strokes, model, hydraulic, options, INT_MIN, INT_MAX);
  if (!screen) return {};
  const std::vector<Screened> screened = screenAll(*screen, model.geometry.supply_pressure, options);

  std::vector<std::pair<FormulaProposal, int>> proven;
  for (const auto& candidate : screened) {
    if (static_cast<int>(proven.size()) >= options.verified) break;
    // Proving costs two fits and a free run over the recording: only shapes the screen rates close to
    // the best are worth it.
    if (candidate.reduction < options.prove_fraction * screened.front().reduction) break;
    try {
      const FormulaTerm term = refineBreakpoint(grid, strokes, model, candidate, options);
      proven.emplace_back(prove(grid, strokes, model, base, term, *screen, ranking, options), term.complexity());
    } catch (const std::invalid_argument&) {
      // A breakpoint at the edge of the data can leave a term that is zero over the operating range the
      // custom effect is probed on: not a formula a user could add; the next shape is tried instead.
    }
  }
  // Holm's correction over every shape the screen rated, not only those proven: the screen chose which to
  // prove on all cycles, the held-out ones included, so each shape it could have chosen counts as a test
  // (an unproven one with p = 1). Each proven shape's own breakpoint is chosen within the folds.
  std::vector<double> p_values(std::max(proven.size(), screened.size()), 1.0);
  for (std::size_t i = 0; i < proven.size(); ++i) p_values[i] = proven[i].first.p_value;
  const std::vector<bool> rejected = holmRejected(p_values, ranking.significance);
  for (std::size_t i = 0; i < proven.size(); ++i) {
    FormulaProposal& p = proven[i].first;
    if (p.verdict != Verdict::kMissing) continue;
    const std::string demoted = holmDemotion(p.error_reduction, p.p_value, rejected[i], p_values.size(), "shapes");
    if (demoted.empty()) continue;
    p.verdict = Verdict::kInconclusive;
    p.explanation = p.explanation.substr(0, p.explanation.find(';')) + demoted;
  }
  orderProposals(proven, options.tie);
  std::vector<FormulaProposal> result;
  for (auto& p : proven) result.push_back(std::move(p.first));
  return result;
}

}  // namespace

std::vector<FormulaProposal> proposeFormulas(const std::vector<GridSample>& grid, const StrokeSegmentation& strokes,
                                             const IdentificationConfig& model, const HeldOutErrors& base,
                                             double structured_floor, const EffectRankingOptions& ranking,
                                             const FormulaSearchOptions& options) {
  std::vector<FormulaProposal> proposals = searchOneTerm(grid, strokes, model, base, ranking, options);
  if (options.max_terms < 2 || proposals.empty() || proposals.front().verdict != Verdict::kMissing) return proposals;
  const FormulaProposal& first = proposals.front();
  if (first.held_out.rms <= structured_floor) return proposals;
  // Structured error left after the first term: a second one, proven against the model with the first.
  IdentificationConfig extended = model;
  extended.custom_effects.push_back(first.spec());
  std::vector<FormulaProposal> second =
      searchOneTerm(grid, strokes, extended, first.held_out, ranking, options);
  if (!second.empty() && second.front().verdict == Verdict::kMissing) {
    second.front().together_with = first.name;
    second.front().explanation += " (together with '" + first.name + "')";
    proposals.insert(proposals.begin() + 1, std::move(second.front()));
  }
  return proposals;
}

}  // namespace die_cushion_ident
