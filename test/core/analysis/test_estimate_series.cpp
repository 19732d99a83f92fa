// The online estimate's series goes to a temporary file beyond kMemorySteps (issue 30: a day's recording
// must not hold 17 MB an hour in memory) and comes back bit for bit, to readers on threads of their own.
#include <gtest/gtest.h>

#include <cmath>
#include <future>
#include <limits>
#include <string>

#include "die_cushion_ident/core/analysis/estimate_series.h"

namespace die_cushion_ident {
namespace {

HydraulicEstimate stepAt(std::size_t k) {
  HydraulicEstimate e;
  e.t = 1e9 + 0.01 * static_cast<double>(k);  // a wall-clock stamp: needs its double
  for (int j = 0; j < 4; ++j) {
    e.parameters.push_back(
        {"p" + std::to_string(j), "", 1.0 + j + 1e-3 * static_cast<double>(k), 1e-4 * (j + 1)});
  }
  e.equation_error_rms = k % 1000 == 7 ? std::numeric_limits<double>::quiet_NaN() : 1e5 + k;
  return e;
}

// Every step read back as added; the number of steps read.
std::size_t readBack(const EstimateSeries& series) {
  EstimateSeries::Reader step(series);
  std::size_t k = 0;
  while (step.next()) {
    const HydraulicEstimate e = stepAt(k);
    if (step.t() != e.t) ADD_FAILURE() << "t of step " << k;
    for (int j = 0; j < 4; ++j) {
      if (step.value(j) != static_cast<float>(e.parameters[j].value))
        ADD_FAILURE() << "value " << j << " of " << k;
      if (step.std(j) != static_cast<float>(e.parameters[j].std)) ADD_FAILURE() << "std " << j << " of " << k;
    }
    const float error = step.equationError();
    if (!(error == static_cast<float>(e.equation_error_rms) || (std::isnan(error) && k % 1000 == 7)))
      ADD_FAILURE() << "equation error of " << k;
    ++k;
  }
  return k;
}

TEST(EstimateSeries, StepsBeyondMemoryComeBackFromTheFileBitForBit) {
  EstimateSeries series;
  const std::size_t steps = 2 * EstimateSeries::kMemorySteps + 12345;  // two blocks in the file, a part left
  for (std::size_t k = 0; k < steps; ++k) series.add(stepAt(k));
  EXPECT_EQ(series.size(), steps);
  EXPECT_EQ(series.parameters(), 4);
  // Two readers at once, as analyze_bag's CSV and bag writers read it.
  auto other = std::async(std::launch::async, [&series] { return readBack(series); });
  EXPECT_EQ(readBack(series), steps);
  EXPECT_EQ(other.get(), steps);
}

TEST(EstimateSeries, AShortSeriesStaysInMemoryAndAnEmptyOneReadsNothing) {
  EstimateSeries series;
  EstimateSeries::Reader none(series);
  EXPECT_FALSE(none.next());
  for (std::size_t k = 0; k < 100; ++k) series.add(stepAt(k));
  EXPECT_EQ(readBack(series), 100u);
}

}  // namespace
}  // namespace die_cushion_ident
