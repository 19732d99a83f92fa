// rosrun die_cushion_ident study_settings [--config FILE] [--from-summary SUMMARY] --out DIR
//   [--seeds N] [--cycles N] [--jobs N]
// The paper's filter-width and sampling-time study (§5.1, §5.2) on the simulator configured as the press:
// its identified parameters, effects and measured pressure noise from an analyze_bag summary, or the
// config's. Writes DIR/settings_study.csv, DIR/settings_{bias,std}_{derivative,integral}.svg (bias and
// std in % against the moving-average width, a line per derivative width, as in the paper's figures) and
// DIR/recommendation.txt, whole or not at all (OutputFiles; recommendation.txt last): exit 4 when they
// cannot be written.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "analysis_config.h"
#include "argument_parser.h"
#include "command_line.h"
#include "die_cushion_ident/core/settings/settings_study.h"
#include "die_cushion_ident/core/util/formatted.h"
#include "output/csv_file.h"
#include "output/output_files.h"

namespace die_cushion_ident {
namespace {

const char* kUsage =
    "usage: study_settings [--config FILE] [--from-summary SUMMARY] --out DIR [--seeds N] [--cycles N] "
    "[--jobs N]\n"
    "  The paper's study of the filter widths and the sampling time on the simulator configured as your "
    "press\n"
    "  (an analyze_bag summary.yaml gives its parameters, effects and pressure noise; else the config's).\n"
    "  Defaults: 64 seeds x 3 cycles per setting (every bias known to about 0.4 %), all cores.\n"
    "  Exit 0; 2 bad arguments or configuration; 3 the summary cannot be used; 4 the results cannot be "
    "written\n"
    "  (then none is left under its name: each is renamed from a temporary name when all are whole).\n";

[[noreturn]] void fail(int code, const std::string& message) {
  std::cerr << "study_settings: " << message << "\n";
  std::exit(code);
}

struct Series {
  std::string label;
  std::vector<std::pair<double, double>> points;
};

// A plain SVG line chart: no plotting library needed on the press's PC.
void writeChart(OutputFiles& files, const std::string& path, const std::string& title,
                const std::string& x_label, const std::string& y_label, const std::vector<Series>& series) {
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& s : series) {
    for (const auto& [x, y] : s.points) {
      x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    }
  }
  if (!(x1 > x0)) x1 = x0 + 1.0;
  if (!(y1 > y0)) y1 = y0 + 1.0;
  y0 = std::min(y0, 0.0);
  const double W = 520, H = 330, left = 70, right = 150, top = 40, bottom = 50;
  const auto X = [&](double x) { return left + (x - x0) / (x1 - x0) * (W - left - right); };
  const auto Y = [&](double y) { return H - bottom - (y - y0) / (y1 - y0) * (H - top - bottom); };
  static const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"};
  std::ofstream out(files.add(path));
  out << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H << "' font-family='sans-serif' "
      << "font-size='11'>\n<text x='" << left << "' y='20' font-size='13'>" << title << "</text>\n";
  out << "<line x1='" << left << "' y1='" << Y(0) << "' x2='" << W - right << "' y2='" << Y(0)
      << "' stroke='#999'/>\n<line x1='" << left << "' y1='" << top << "' x2='" << left << "' y2='" << H - bottom
      << "' stroke='black'/>\n";
  for (int i = 0; i <= 4; ++i) {
    const double y = y0 + (y1 - y0) * i / 4, x = x0 + (x1 - x0) * i / 4;
    out << "<text x='" << left - 6 << "' y='" << Y(y) + 4 << "' text-anchor='end'>" << formatted(FMT_STRING("{:.3g}"), y)
        << "</text>\n";
    out << "<text x='" << X(x) << "' y='" << H - bottom + 16 << "' text-anchor='middle'>"
        << formatted(FMT_STRING("{:.3g}"), x) << "</text>\n";
  }
  out << "<text x='" << (left + W - right) / 2 << "' y='" << H - 10 << "' text-anchor='middle'>" << x_label
      << "</text>\n<text x='14' y='" << (top + H - bottom) / 2 << "' transform='rotate(-90 14 " << (top + H - bottom) / 2
      << ")' text-anchor='middle'>" << y_label << "</text>\n";
  for (std::size_t k = 0; k < series.size(); ++k) {
    const char* colour = colours[k % 6];
    out << "<polyline fill='none' stroke='" << colour << "' stroke-width='2' points='";
    for (const auto& [x, y] : series[k].points) out << X(x) << "," << Y(y) << " ";
    out << "'/>\n<text x='" << W - right + 8 << "' y='" << top + 16 * k + 10 << "' fill='" << colour << "'>"
        << series[k].label << "</text>\n";
  }
  out << "</svg>\n";
  closeChecked(out, path);
}

// The press to study: the configuration's, or the one a summary identified (its noise included).
SimulatorConfig plantToStudy(const IdentificationConfig& base, const std::string& summary_path) {
  SimulatorConfig plant;
  plant.geometry = base.geometry;
  plant.effects = base.effects;
  plant.custom_effects = base.custom_effects;
  for (const auto& [name, value] : base.initial_parameters) plant.parameters[name] = value;
  if (summary_path.empty()) return plant;
  try {
    const YAML::Node summary = YAML::LoadFile(summary_path);
    plant.effects.clear();
    for (const auto& e : summary["model"]["effects"]) plant.effects.push_back(e.as<std::string>());
    for (const auto& p : summary["model"]["parameters"]) {
      plant.parameters[p["name"].as<std::string>()] = p["value"].as<double>();
    }
    if (summary["adequacy"] && summary["adequacy"]["noise_rms"]) {
      plant.sensors.pressure_noise = summary["adequacy"]["noise_rms"].as<double>();
    }
  } catch (const std::exception& e) {
    fail(3, "cannot use the summary '" + summary_path + "': " + e.what());
  }
  plant.custom_effects.clear();  // a summary's custom effects are named with their expressions in config
  return plant;
}

void writeCsv(OutputFiles& files, const std::string& out, const std::vector<SettingsStudyPoint>& points) {
  constexpr int kDigits = 6;  // the study's bias and std are Monte Carlo figures good to a few per cent
  CsvFile csv(files.add(out + "/settings_study.csv"));
  csv.header({"form", "moving_average_width", "derivative_width", "sample_period", "parameter", "bias", "std",
              "runs", "bias_standard_error"});
  for (const auto& p : points) {
    csv.text(regressionFormName(p.form)).integer(p.moving_average_width).integer(p.derivative_width);
    csv.number(p.sample_period, kDigits).text(p.parameter).number(p.bias, kDigits).number(p.std, kDigits);
    csv.integer(p.runs).number(p.biasStandardError(), kDigits).endLine();
  }
  csv.close();
}

// Bias and std against the moving-average width, one line per derivative width, for each form.
void writeCharts(OutputFiles& files, const std::string& out, const std::vector<SettingsStudyPoint>& points,
                 double sample_period) {
  for (RegressionForm form : {RegressionForm::kDerivative, RegressionForm::kIntegral}) {
    for (const bool bias : {true, false}) {
      std::vector<Series> series;
      for (const char* parameter : {"bulk_modulus", "dead_volume"}) {
        std::map<int, Series> by_width;
        for (const auto& p : points) {
          if (p.form != form || p.parameter != parameter || p.sample_period != sample_period) continue;
          Series& s = by_width[p.derivative_width];
          s.label = std::string(parameter == std::string("bulk_modulus") ? "K'" : "V0") + ", d = " +
                    std::to_string(p.derivative_width);
          s.points.emplace_back(p.moving_average_width, 100.0 * (bias ? p.bias : p.std));
        }
        for (auto& [width, s] : by_width) series.push_back(s);
      }
      const std::string name = std::string("settings_") + (bias ? "bias_" : "std_") + regressionFormName(form) + ".svg";
      writeChart(
          files, out + "/" + name,
          std::string(bias ? "bias" : "std") + " of the estimates, " + regressionFormName(form) + " form",
          "moving-average width b [samples]", bias ? "bias [%]" : "std [%]", series);
    }
  }
}

int run(int argc, char** argv) {
  std::string config_path, summary_path, out;
  SettingsStudyOptions options;
  options.jobs = std::max(1u, std::thread::hardware_concurrency());
  ArgumentParser arguments;
  arguments.option("--config", [&](const std::string& v) { config_path = v; })
      .option("--from-summary", [&](const std::string& v) { summary_path = v; })
      .option("--out", [&](const std::string& v) { out = v; })
      .wholeNumber("--seeds", 2, 1000, &options.seeds)
      .wholeNumber("--cycles", 1, 1000, &options.cycles)
      .wholeNumber("--jobs", 1, 1000, &options.jobs);
  arguments.parseOrExit(argc, argv, "study_settings", kUsage);
  if (out.empty()) fail(2, std::string("--out DIR is required\n") + kUsage);

  IdentificationConfig base;
  if (!config_path.empty()) {
    InputTopics topics;
    std::vector<std::string> keys;
    const auto problems = loadAnalysisConfig(config_path, &base, &topics, &keys);
    if (!problems.empty()) fail(2, "invalid configuration in " + config_path + ": " + problems.front());
  }
  const SimulatorConfig plant = plantToStudy(base, summary_path);
  base.effects = plant.effects;
  base.custom_effects = plant.custom_effects;
  if (!makeDirectory(out)) fail(4, "cannot create output directory '" + out + "'");

  std::cerr << "study_settings: the press simulated with pressure noise "
            << plant.sensors.pressure_noise * 1e-5 << " bar; " << options.seeds << " seeds x "
            << options.cycles << " cycles per setting on " << options.jobs << " threads\n";
  int last_percent = -1;
  const auto points = runSettingsStudy(plant, base, options, [&](int done, int total) {
    const int percent = 100 * done / total;
    if (percent / 10 != last_percent / 10)
      std::cerr << "study_settings: " << percent << " % (" << done << " of " << total << " runs)\n";
    last_percent = percent;
  });
  const std::string recommendation = recommendSettings(points, base);
  OutputFiles files;  // a failure (WriteError, to main) removes what was written under temporary names
  writeCsv(files, out, points);
  writeCharts(files, out, points, base.resampler.sample_period);
  {
    std::ofstream text(files.add(out + "/recommendation.txt"));
    text << recommendation << "\n";
    closeChecked(text, out + "/recommendation.txt");
  }
  files.commit();
  std::cout << recommendation << "\nresults in " << out << "\n";
  return 0;
}

}  // namespace
}  // namespace die_cushion_ident

int main(int argc, char** argv) {
  try {
    return die_cushion_ident::run(argc, argv);
  } catch (const die_cushion_ident::WriteError& e) {
    std::cerr << "study_settings: " << e.what() << "\n";
    return 4;
  } catch (const std::exception& e) {
    std::cerr << "study_settings: " << e.what() << "\n";
    return 1;
  }
}
