// die_cushion_ident/IdentificationNodelet: the identification inside a nodelet manager (zero-copy inputs).
#include <nodelet/nodelet.h>
#include <ros/callback_queue.h>

#include <atomic>
#include <memory>
#include <pluginlib/class_list_macros.hpp>
#include <thread>

#include "batched_spin.h"
#include "identification_node.h"

namespace die_cushion_ident {

class IdentificationNodelet : public nodelet::Nodelet {
 public:
  ~IdentificationNodelet() override {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    node_.reset();  // aborts a running sweep and sends the offset
  }

 private:
  void onInit() override {
    // Our own queue, taken in batches by our own thread (spinBatched): the manager's worker threads would
    // otherwise wake up for every one of the 3000 messages per second.
    ros::NodeHandle nh = getNodeHandle(), pnh = getPrivateNodeHandle();
    nh.setCallbackQueue(&queue_);
    pnh.setCallbackQueue(&queue_);
    try {
      node_ = std::make_unique<IdentificationNode>(nh, pnh, pnh.getNamespace());  // its resolved name
    } catch (const std::exception& e) {
      // A manager hosts other nodelets: stay inert instead of taking it down; the message says what to fix.
      NODELET_FATAL("die_cushion_ident not started: %s", e.what());
      return;
    }
    thread_ = std::thread([this] { spinBatched(queue_, [this] { return node_->valveExperimentRunning(); }, stop_); });
  }

  ros::CallbackQueue queue_;
  std::unique_ptr<IdentificationNode> node_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace die_cushion_ident

PLUGINLIB_EXPORT_CLASS(die_cushion_ident::IdentificationNodelet, nodelet::Nodelet)
