#include "live_publishers.h"

#include <visualization_msgs/MarkerArray.h>

#include <algorithm>

#include "cushion_markers.h"
#include "die_cushion_ident/EffectRanking.h"
#include "die_cushion_ident/ModelComparison.h"
#include "die_cushion_ident/ParameterEstimate.h"
#include "message_conversions.h"

namespace die_cushion_ident {

LivePublishers::LivePublishers(ros::NodeHandle pnh) {
  estimate_pub_ = pnh.advertise<ParameterEstimate>("estimate", 10);
  comparison_pub_ = pnh.advertise<ModelComparison>("model_comparison", 10);
  markers_pub_ = pnh.advertise<visualization_msgs::MarkerArray>("markers", 2);
  ranking_pub_ = pnh.advertise<die_cushion_ident::EffectRanking>("effect_ranking", 1, true);
  pnh.param("frame_id", frame_id_, frame_id_);
}

void LivePublishers::identificationStep(const LiveIdentification& live,
                                        const HydraulicIdentifier& identifier) {
  // rviz needs no more than 10 Hz.
  const bool markers = markers_pub_.getNumSubscribers() > 0 &&
                       ++steps_since_markers_ * live.config().identification_period >= 0.1;
  const bool estimate = estimate_pub_.getNumSubscribers() > 0;
  const bool comparison = comparison_pub_.getNumSubscribers() > 0;
  if (!markers && !estimate && !comparison) return;  // the estimate costs allocations: only when wanted
  const HydraulicEstimate e = live.estimate();
  const ros::Time stamp(std::max(e.t, 0.0));
  if (estimate) {
    const ParameterVector values = e.values(), stds = e.standardDeviations();
    ParameterEstimate msg =
        toParameterEstimateMsg(identifier.model(), {values.data(), values.data() + values.size()},
                               {stds.data(), stds.data() + stds.size()}, stamp);
    msg.equation_error_rms = e.equation_error_rms;
    msg.updates = e.updates;
    msg.skipped_unexcited = e.skipped_unexcited;
    msg.skipped_invalid = e.skipped_invalid;
    estimate_pub_.publish(msg);
  }
  const LiveModelMonitor& monitor = live.monitor();
  if (markers) {
    steps_since_markers_ = 0;
    CushionView view;
    view.position = monitor.lastSample().x;
    view.pressure = monitor.lastSample().p;
    view.simulation_error = monitor.simulationErrorRms();
    view.phase = monitor.phase();
    markers_pub_.publish(cushionMarkers(live.config().geometry, view, e, frame_id_, stamp));
  }
  if (comparison) {
    const GridSample& g = monitor.lastSample();
    const ModelComparison msg =
        toModelComparisonMsg(g, monitor.modelledPressure(), monitor.phase(), monitor.simulationErrorRms(),
                             e.equation_error_rms, ros::Time(std::max(g.t, 0.0)));
    // Only what was computed: while the model cannot run, the adequacy diagnostic says why instead.
    if (isComputed(msg)) comparison_pub_.publish(msg);
  }
}

void LivePublishers::ranking(const LiveRanking& ranking, double stamp) {
  ROS_DEBUG("die_cushion_ident: effect ranking took %.3f s on its own thread", ranking.seconds);
  const EffectRankingResult& result = ranking.result;
  die_cushion_ident::EffectRanking msg;
  msg.header.stamp = ros::Time(std::max(stamp, 0.0));
  msg.cycles = ranking.cycles;
  for (const auto& c : result.candidates) {
    msg.effects.push_back(c.effect);
    msg.error_reduction.push_back(c.error_reduction);
    msg.verdicts.push_back(verdictName(c.verdict));
    msg.explanations.push_back(c.explanation);
  }
  msg.held_out_error_rms = result.base_error_rms;
  msg.best_error_rms = result.best_error_rms;
  msg.noise_rms = result.noise_rms;
  msg.residual_unexplained = result.residual_unexplained;
  for (const auto& step : result.steps) {
    msg.steps.push_back(step.add);
    msg.step_error_rms.push_back(step.held_out_error_rms);
  }
  for (const auto& p : result.proposals) {
    msg.proposals.push_back(p.spec());
    msg.proposal_error_reduction.push_back(p.error_reduction);
    msg.proposal_verdicts.push_back(verdictName(p.verdict));
    msg.proposal_explanations.push_back(p.explanation);
  }
  msg.conclusion = result.conclusion;
  if (ranking.onset) {
    const EffectOnset& onset = ranking.onset->onset;
    msg.onset_effect = onset.effect;
    msg.onset_parameter = onset.parameter;
    msg.onset_cycle = onset.cycle;
    msg.onset_stamp = ros::Time(std::max(ranking.onset->stamp, 0.0));
    msg.onset_before = onset.before;
    msg.onset_after = onset.after;
    msg.onset_unit = onset.unit;
    msg.onset_explanation = onset.explanation;
  }
  ranking_pub_.publish(msg);
}

}  // namespace die_cushion_ident
