// die_cushion_ident/IdentificationNodelet: the identification inside a nodelet manager (zero-copy inputs).
#include <nodelet/nodelet.h>

#include <memory>
#include <pluginlib/class_list_macros.hpp>

#include "identification_node.h"

namespace die_cushion_ident {

class IdentificationNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    try {
      node_ = std::make_unique<IdentificationNode>(getMTNodeHandle(), getMTPrivateNodeHandle());
    } catch (const std::exception& e) {
      // A manager hosts other nodelets: stay inert instead of taking it down; the message says what to fix.
      NODELET_FATAL("die_cushion_ident not started: %s", e.what());
    }
  }

  std::unique_ptr<IdentificationNode> node_;
};

}  // namespace die_cushion_ident

PLUGINLIB_EXPORT_CLASS(die_cushion_ident::IdentificationNodelet, nodelet::Nodelet)
