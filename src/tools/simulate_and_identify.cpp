// Runs the built-in die-cushion simulator through the online identification pipeline and prints the
// identified parameters against the simulator's truth. No ROS needed; scripts/demo calls it.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "argument_parser.h"
#include "command_line.h"
#include "die_cushion_ident/core/simulation/die_cushion_simulator.h"
#include "die_cushion_ident/core/estimation/identification_pipeline.h"
#include "die_cushion_ident/core/control/pressure_feed_forward.h"

using namespace die_cushion_ident;

namespace {

const char* const kUsage =
    "usage: simulate_and_identify [--cycles N] [--plant-effects a,b] [--effects a,b]\n"
    "                             [--form integral|derivative] [--seed S] [--forgetting L]\n"
    "                             [--noise-free] [--set KEY=VALUE]...\n"
    "                             [--bulk-modulus-step FACTOR --step-cycle K] [--feed-forward]\n"
    "  --feed-forward: afterwards, the drawing pressure error of the press's PI controller alone, with\n"
    "  its nominal velocity feed-forward, and with the identified model's feed-forward (paper, Fig. 19)\n";

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

struct Options {
  int cycles = 5;
  int step_cycle = -1;
  double step_factor = 1.0;
  bool feed_forward = false;
  SimulatorConfig plant_config;
  IdentificationConfig config;
};

void addOptions(ArgumentParser& arguments, Options& o) {
  arguments.wholeNumber("--cycles", 1, 100000, &o.cycles)
      .option("--plant-effects", [&o](const std::string& v) { o.plant_config.effects = splitList(v); })
      .option("--effects", [&o](const std::string& v) { o.config.effects = splitList(v); })
      .option("--form",
              [&o](const std::string& v) {
                if (!parseRegressionForm(v, &o.config.regression_form)) {
                  throw std::invalid_argument("--form must be integral or derivative, got '" + v + "'");
                }
              })
      .number("--forgetting", 0.0, 1.0, &o.config.forgetting_factor)
      .flag("--noise-free",
            [&o] {
              SensorConfig& s = o.plant_config.sensors;
              s.pressure_noise = s.position_noise = s.velocity_noise = s.spool_noise = s.jitter = 0.0;
            })
      .option("--set",
              [&o](const std::string& kv) {
                const auto eq = kv.find('=');
                const auto value = eq == std::string::npos ? std::nullopt : numberIn(kv.substr(eq + 1), -1e300, 1e300);
                if (!value || !setNumericConfigValue(o.config, kv.substr(0, eq), *value)) {
                  throw std::invalid_argument("--set takes KEY=VALUE with a numeric configuration key, got '" + kv + "'");
                }
              })
      .flag("--feed-forward", [&o] { o.feed_forward = true; })
      .option("--seed",
              [&o](const std::string& v) {
                const auto seed = wholeNumberIn(v, 0, std::numeric_limits<long>::max());
                if (!seed) throw std::invalid_argument("--seed needs a whole number >= 0, got '" + v + "'");
                o.plant_config.seed = static_cast<std::uint64_t>(*seed);
              })
      .number("--bulk-modulus-step", 1e-3, 1e3, &o.step_factor)
      .wholeNumber("--step-cycle", 0, 100000, &o.step_cycle);
}

// The press cycles through the pipeline, with the estimate after each.
void identifyCycles(const Options& o, DieCushionSimulator& plant, IdentificationPipeline& pipeline) {
  std::vector<SimulatedMeasurement> messages;
  const double cycle = plant.program().cycleDuration();
  std::printf("die cushion simulator: %d press cycles of %.2f s, plant effects [", o.cycles, cycle);
  for (const auto& e : o.plant_config.effects) std::printf(" %s", e.c_str());
  std::printf(" ], model effects [");
  for (const auto& e : o.config.effects) std::printf(" %s", e.c_str());
  std::printf(" ], %s regression\n", regressionFormName(o.config.regression_form));
  for (int k = 0; k < o.cycles; ++k) {
    if (k == o.step_cycle) {
      const double stepped = plant.trueParameter("bulk_modulus") * o.step_factor;
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
}

// The valve model as a sweep identifies it (its parameters within 1 %); the hydraulics as identified.
void compareFeedForwards(const Options& o, const IdentificationPipeline& pipeline) {
  const HydraulicModel& model = pipeline.identifier().model();
  const auto identified = std::make_shared<const PressureFeedForward>(
      model, pipeline.identifier().physicalParameters(), o.plant_config.valve,
      o.plant_config.controller.max_voltage);
  const double pi = drawingPressureErrorRms(o.plant_config, nullptr, false, 3);
  const double nominal = drawingPressureErrorRms(o.plant_config, nullptr, true, 3);
  const double with_model = drawingPressureErrorRms(o.plant_config, identified, false, 3);
  std::printf(
      "\ndrawing pressure error rms over 3 press cycles (paper, Fig. 19):\n"
      "  PI alone                                        %6.2f bar\n"
      "  PI + the press's nominal velocity feed-forward  %6.2f bar\n"
      "  PI + the identified model's feed-forward        %6.2f bar (%.0f times better than PI alone)\n",
      pi * 1e-5, nominal * 1e-5, with_model * 1e-5, pi / with_model);
}

int run(int argc, char** argv) {
  Options o;
  ArgumentParser arguments;
  addOptions(arguments, o);
  arguments.parseOrExit(argc, argv, "simulate_and_identify", kUsage);
  try {
    o.config.geometry = o.plant_config.geometry;
    DieCushionSimulator plant(o.plant_config);
    IdentificationPipeline pipeline(o.config);
    identifyCycles(o, plant, pipeline);
    pipeline.flush();
    const auto e = pipeline.identifier().estimate();
    std::printf(
        "\nidentified after %d cycles (%llu RLS updates, %llu steps skipped in the dead zone, %llu with "
        "unusable samples):\n",
        o.cycles, static_cast<unsigned long long>(e.updates),
        static_cast<unsigned long long>(e.skipped_unexcited),
        static_cast<unsigned long long>(e.skipped_invalid));
    printTable(plant, e);
    if (o.feed_forward) compareFeedForwards(o, pipeline);
  } catch (const std::exception& ex) {
    std::cerr << "error: " << ex.what() << "\n";
    return 1;
  }
  return 0;
}

int main(int argc, char** argv) { return run(argc, argv); }
