// Runs the built-in die-cushion simulator through the online identification pipeline and prints the
// identified parameters against the simulator's truth. No ROS needed; scripts/demo calls it.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "command_line.h"
#include "die_cushion_ident/core/die_cushion_simulator.h"
#include "die_cushion_ident/core/identification_pipeline.h"

using namespace die_cushion_ident;

namespace {

void usage() {
  std::cerr << "usage: simulate_and_identify [--cycles N] [--plant-effects a,b] [--effects a,b]\n"
               "                             [--form integral|derivative] [--seed S] [--forgetting L]\n"
               "                             [--noise-free] [--set KEY=VALUE]...\n"
               "                             [--bulk-modulus-step FACTOR --step-cycle K]\n";
}

void printTable(const DieCushionSimulator& plant, const HydraulicEstimate& e) {
  std::printf("  %-22s %14s %14s %12s %9s\n", "parameter", "true", "identified", "std", "error");
  for (const auto& p : e.parameters) {
    double truth = NAN;
    try {
      truth = plant.trueParameter(p.name);
    } catch (const std::exception&) {
      truth = 0.0;  // the effect is in the model but not in the plant: its truth is zero
    }
    const double error = truth != 0.0 ? 100.0 * (p.value - truth) / truth : NAN;
    std::printf("  %-22s %14.4g %14.4g %12.3g %8.2f%%  [%s]\n", p.name.c_str(), truth, p.value, p.std, error,
                p.unit.c_str());
  }
}
}  // namespace

int main(int argc, char** argv) {
  int cycles = 5;
  int step_cycle = -1;
  double step_factor = 1.0;
  SimulatorConfig plant_config;
  IdentificationConfig config;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        usage();
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "--help" || arg == "-h") {
      usage();
      return 0;
    } else if (arg == "--cycles") {
      cycles = std::atoi(next().c_str());
    } else if (arg == "--plant-effects") {
      plant_config.effects = splitList(next());
    } else if (arg == "--effects") {
      config.effects = splitList(next());
    } else if (arg == "--form") {
      if (!parseRegressionForm(next(), &config.regression_form)) {
        std::cerr << "--form must be integral or derivative\n";
        return 2;
      }
    } else if (arg == "--forgetting") {
      config.forgetting_factor = std::atof(next().c_str());
    } else if (arg == "--noise-free") {
      plant_config.sensors.pressure_noise = plant_config.sensors.position_noise = 0.0;
      plant_config.sensors.velocity_noise = plant_config.sensors.spool_noise = plant_config.sensors.jitter =
          0.0;
    } else if (arg == "--set") {
      const std::string kv = next();
      const auto eq = kv.find('=');
      if (eq == std::string::npos ||
          !setNumericConfigValue(config, kv.substr(0, eq), std::atof(kv.c_str() + eq + 1))) {
        std::cerr << "--set takes KEY=VALUE with a numeric configuration key\n";
        return 2;
      }
    } else if (arg == "--seed") {
      plant_config.seed = std::strtoull(next().c_str(), nullptr, 10);
    } else if (arg == "--bulk-modulus-step") {
      step_factor = std::atof(next().c_str());
    } else if (arg == "--step-cycle") {
      step_cycle = std::atoi(next().c_str());
    } else {
      usage();
      return 2;
    }
  }
  if (cycles < 1) {
    std::cerr << "--cycles must be at least 1\n";
    return 2;
  }
  try {
    config.geometry = plant_config.geometry;
    DieCushionSimulator plant(plant_config);
    IdentificationPipeline pipeline(config);
    std::vector<SimulatedMeasurement> messages;
    const double cycle = plant.program().cycleDuration();
    std::printf("die cushion simulator: %d press cycles of %.2f s, plant effects [", cycles, cycle);
    for (const auto& e : plant_config.effects) std::printf(" %s", e.c_str());
    std::printf(" ], model effects [");
    for (const auto& e : config.effects) std::printf(" %s", e.c_str());
    std::printf(" ], %s regression\n", regressionFormName(config.regression_form));
    for (int k = 0; k < cycles; ++k) {
      if (k == step_cycle) {
        const double stepped = plant.trueParameter("bulk_modulus") * step_factor;
        plant.setTrueParameter("bulk_modulus", stepped);
        std::printf("cycle %d: bulk modulus steps to %.4g Pa\n", k, stepped);
      }
      const double end = (k + 1) * cycle;
      while (plant.state().t < end - 1e-12) {
        messages.clear();
        plant.step(&messages);
        for (const auto& m : messages) pipeline.push(m.stream, m.sample);
      }
      const auto e = pipeline.identifier().estimate();
      std::printf("cycle %2d: K' = %.4g Pa, K_v = %.4g, V_dead = %.4g m^3, dp/dt error rms %.3g bar/s\n", k,
                  e.parameters[0].value, e.parameters[1].value, e.parameters[2].value,
                  e.equation_error_rms / 1e5);
    }
    pipeline.flush();
    const auto e = pipeline.identifier().estimate();
    std::printf(
        "\nidentified after %d cycles (%llu RLS updates, %llu steps skipped in the dead zone, %llu with "
        "unusable samples):\n",
        cycles, static_cast<unsigned long long>(e.updates),
        static_cast<unsigned long long>(e.skipped_unexcited),
        static_cast<unsigned long long>(e.skipped_invalid));
    printTable(plant, e);
  } catch (const std::exception& ex) {
    std::cerr << "error: " << ex.what() << "\n";
    return 1;
  }
  return 0;
}
