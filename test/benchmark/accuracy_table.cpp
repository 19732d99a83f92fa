// Prints README's accuracy table: median / worst relative error of the online identification over 10 random
// simulated plants (seeds 1-10) per model, 4 press cycles, acceptance noise.
// Run: .build_ws/devel/lib/die_cushion_ident/accuracy_table
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "simulation_fixtures.h"

using namespace die_cushion_ident;

namespace {
std::string medianAndWorst(std::vector<double> errors) {
  if (errors.empty()) return "";
  std::sort(errors.begin(), errors.end());
  const std::size_t n = errors.size();
  const double median = n % 2 ? errors[n / 2] : 0.5 * (errors[n / 2 - 1] + errors[n / 2]);
  char text[64];
  std::snprintf(text, sizeof(text), "%.2f %% / %.2f %%", median, errors.back());
  return text;
}
}  // namespace

int main() {
  std::printf("| data and model | bulk_modulus | valve_flow_gain | dead_volume | effect parameter |\n");
  std::printf("| --- | --- | --- | --- | --- |\n");
  for (const std::vector<std::string>& effects :
       std::vector<std::vector<std::string>>{{}, {"leakage"}, {"entrained_air"}, {"valve_overlap"}, {"tank_pressure"}}) {
    std::vector<double> bulk, gain, dead, effect;
    for (int seed = 1; seed <= 10; ++seed) {
      const SimulatorConfig config = testing::randomPlant(seed, effects);
      DieCushionSimulator plant(config);
      IdentificationPipeline pipeline(testing::configFor(config, effects));
      testing::feed(plant, pipeline, 4 * plant.program().cycleDuration());
      const HydraulicEstimate e = pipeline.identifier().estimate();
      const auto error = [&](const std::string& name) {
        return 100.0 * std::abs(testing::estimateOf(e, name) / plant.trueParameter(name) - 1.0);
      };
      bulk.push_back(error("bulk_modulus"));
      gain.push_back(error("valve_flow_gain"));
      dead.push_back(error("dead_volume"));
      if (!effects.empty()) effect.push_back(error(e.parameters[HydraulicModel::kFirstEffect].name));
    }
    std::printf("| %s | %s | %s | %s | %s |\n", effects.empty() ? "base" : ("+ " + effects[0]).c_str(),
                medianAndWorst(bulk).c_str(), medianAndWorst(gain).c_str(), medianAndWorst(dead).c_str(),
                medianAndWorst(effect).c_str());
  }
}
