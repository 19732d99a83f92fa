#include "live_thresholds.h"

#include <ros/console.h>

#include <utility>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

namespace {

std::string describe(const NodeSettings& s) {
  return formatted(FMT_STRING("model adequacy warns above {:.2f} bar, errs above {:.2f} bar"),
                   s.adequacy_warn_error * 1e-5, s.adequacy_error_error * 1e-5) +
         formatted(FMT_STRING("; effect ranking every {:g} s over the last {:g} s"), s.effect_ranking_period,
                   s.effect_ranking_window);
}

bool sameThresholds(const NodeSettings& a, const NodeSettings& b) {
  return a.adequacy_warn_error == b.adequacy_warn_error && a.adequacy_error_error == b.adequacy_error_error &&
         a.effect_ranking_window == b.effect_ranking_window &&
         a.effect_ranking_period == b.effect_ranking_period;
}

}  // namespace

std::vector<std::string> applyLiveThresholds(LiveThresholdsConfig* config, NodeSettings* settings) {
  NodeSettings requested = *settings;
  requested.adequacy_warn_error = config->adequacy_warn_error;
  requested.adequacy_error_error = config->adequacy_error_error;
  requested.effect_ranking_window = config->effect_ranking_window;
  requested.effect_ranking_period = config->effect_ranking_period;
  std::vector<std::string> problems = liveThresholdProblems(requested);
  if (problems.empty()) *settings = requested;
  config->adequacy_warn_error = settings->adequacy_warn_error;
  config->adequacy_error_error = settings->adequacy_error_error;
  config->effect_ranking_window = settings->effect_ranking_window;
  config->effect_ranking_period = settings->effect_ranking_period;
  return problems;
}

LiveThresholds::LiveThresholds(const ros::NodeHandle& pnh, std::mutex& mutex, NodeSettings* settings,
                               std::function<void()> changed)
    : server_(pnh) {
  // Called at once with the parameters the node started from, then on every request.
  server_.setCallback(
      [&mutex, settings, changed = std::move(changed)](LiveThresholdsConfig& config, uint32_t) {
        std::lock_guard<std::mutex> lock(mutex);
        const NodeSettings before = *settings;
        const std::vector<std::string> problems = applyLiveThresholds(&config, settings);
        if (!problems.empty()) {
          ROS_WARN("die_cushion_ident: live thresholds kept (%s): %s", describe(before).c_str(),
                   joined(problems, "; ").c_str());
        } else if (!sameThresholds(before, *settings)) {
          ROS_INFO("die_cushion_ident: live thresholds now: %s", describe(*settings).c_str());
          changed();
        }
      });
}

}  // namespace die_cushion_ident
