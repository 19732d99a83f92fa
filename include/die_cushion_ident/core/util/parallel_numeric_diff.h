#pragma once

#include <ceres/dynamic_cost_function.h>
#include <ceres/numeric_diff_options.h>
#include <ceres/types.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numeric>
#include <vector>

#include "die_cushion_ident/core/util/parallel_for.h"

namespace die_cushion_ident {

/// Ceres's DynamicNumericDiffCostFunction (forward or central differences, the same steps and the same
/// arithmetic, so the same Jacobian to the last bit) with the Jacobian's columns evaluated on `jobs` threads.
/// Why: each residual evaluation here is a whole free run of the recording (milliseconds), and a Jacobian
/// is one to two of them per unknown, one after the other on one core while the other core idles.
/// `Functor` is bool(double const* const* parameters, double* residuals) const and must be safe to call from
/// several threads at once (no shared mutable state).
template <typename Functor, ceres::NumericDiffMethodType kMethod>
class ParallelNumericDiffCost final : public ceres::DynamicCostFunction {
  static_assert(kMethod == ceres::FORWARD || kMethod == ceres::CENTRAL, "forward or central differences");

 public:
  ParallelNumericDiffCost(Functor functor, const ceres::NumericDiffOptions& options, int jobs)
      : functor_(std::move(functor)), options_(options), jobs_(jobs) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    if (!functor_(parameters, residuals)) return false;
    if (jacobians == nullptr) return true;
    const std::vector<int32_t>& sizes = parameter_block_sizes();
    // One column per unknown of every block whose Jacobian is asked for.
    std::vector<std::pair<int, int>> columns;
    for (std::size_t block = 0; block < sizes.size(); ++block) {
      if (jacobians[block] == nullptr) continue;
      for (int j = 0; j < sizes[block]; ++j) columns.emplace_back(static_cast<int>(block), j);
    }
    const int n = num_residuals();
    const int total = std::accumulate(sizes.begin(), sizes.end(), 0);
    std::atomic<bool> ok{true};
    parallelFor(columns.size(), jobs_, [&](std::size_t c) {
      // Each column on its own copy of the parameters and its own residual buffers.
      std::vector<double> copy(static_cast<std::size_t>(total));
      std::vector<double*> blocks(sizes.size());
      for (std::size_t b = 0, offset = 0; b < sizes.size();
           offset += static_cast<std::size_t>(sizes[b]), ++b) {
        blocks[b] = copy.data() + offset;
        std::memcpy(blocks[b], parameters[b], sizeof(double) * static_cast<std::size_t>(sizes[b]));
      }
      const auto [block, j] = columns[c];
      const double x = parameters[block][j];
      // Ceres's step: relative to the unknown, never below sqrt(epsilon).
      const double delta = std::max(std::sqrt(std::numeric_limits<double>::epsilon()),
                                    std::abs(x) * options_.relative_step_size);
      std::vector<double> plus(static_cast<std::size_t>(n)), minus;
      blocks[block][j] = x + delta;
      if (!functor_(blocks.data(), plus.data())) {
        ok = false;
        return;
      }
      double one_over_delta = 1.0 / delta;
      if (kMethod == ceres::CENTRAL) {
        minus.resize(static_cast<std::size_t>(n));
        blocks[block][j] = x - delta;
        if (!functor_(blocks.data(), minus.data())) {
          ok = false;
          return;
        }
        one_over_delta /= 2;
      }
      const double* subtracted = kMethod == ceres::CENTRAL ? minus.data() : residuals;
      double* jacobian = jacobians[block];
      for (int r = 0; r < n; ++r) jacobian[r * sizes[block] + j] = (plus[r] - subtracted[r]) * one_over_delta;
    });
    return ok;
  }

 private:
  Functor functor_;
  ceres::NumericDiffOptions options_;
  int jobs_;
};

}  // namespace die_cushion_ident
