#include "die_cushion_ident/core/valve/valve_message_spool.h"

#include <cmath>

namespace die_cushion_ident {

ValveMessageSpool::ValveMessageSpool(const ServoValveParameters& valve, double max_gap, bool drives_free_run)
    : model_(ServoValve::exact(valve)), max_gap_(max_gap), drives_free_run_(drives_free_run) {}

void ValveMessageSpool::reset() {
  model_.reset();
  last_stamp_ = -std::numeric_limits<double>::infinity();
  last_voltage_ = last_measured_ = 0.0;
  running_ = false;
}

void ValveMessageSpool::setValve(const ServoValveParameters& valve) {
  model_ = ServoValve::exact(valve);
  running_ = false;  // restart from the next measured (or the last measured) spool
}

void ValveMessageSpool::process(StreamSample* valve) {
  if (!std::isfinite(valve->stamp) || !std::isfinite(valve->first)) return;
  const double dt = valve->stamp - last_stamp_;
  const bool measured = std::isfinite(valve->second);
  double modelled = 0.0;
  double mean = std::numeric_limits<double>::quiet_NaN();  // over the stretch since the last message
  if (running_ && dt <= 0.0 && dt >= -max_gap_) {
    modelled = model_.position();  // a duplicate or slightly late message: the resampler rejects it
  } else if (!running_ || !(dt > 0.0 && dt <= max_gap_)) {
    // Start (or restart after a gap or a backward jump) from the measured spool, else from where the model
    // was or the last measured one.
    model_.reset(measured ? valve->second : running_ ? model_.position() : last_measured_);
    running_ = true;
    modelled = model_.position();
  } else {
    const double integral = model_.integral();
    modelled = model_.advance(dt, last_voltage_);  // the previous voltage was in force until now
    mean = (model_.integral() - integral) / dt;
  }
  if (measured) {
    last_measured_ = valve->second;
  } else {
    valve->second = modelled;
    ++predicted_;
  }
  if (drives_free_run_) {
    valve->third = modelled;
    valve->third_mean = mean;
  }
  if (dt > 0.0 || dt < -max_gap_) {
    last_stamp_ = valve->stamp;
    last_voltage_ = valve->first;
  }
}

}  // namespace die_cushion_ident
