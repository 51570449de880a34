// The built-in move_base as a nodelet (marl_mrta/MoveBase): the same MoveBaseRos as the node,
// served by one thread of its own, as ros::spin() serves the node.
#include <pluginlib/class_list_macros.hpp>

#include <memory>
#include <stdexcept>

#include "marl_mrta/nav/param_tree.h"
#include "marl_mrta/own_queue_nodelet.h"
#include "move_base_ros.h"

namespace marl_mrta {
namespace nav {

class MoveBaseNodelet : public OwnQueueNodelet {
 public:
  ~MoveBaseNodelet() override {
    if (spinner_) spinner_->stop();
  }

 private:
  void onInit() override {
    ros::NodeHandle nh = publicHandle(), private_nh = privateHandle();
    try {
      move_base_ = std::make_unique<MoveBaseRos>(nh, private_nh);
    } catch (const ParamError& error) {
      NODELET_FATAL("move_base: %s", error.what());
      throw std::runtime_error(error.what());
    }
    spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue());
    spinner_->start();
  }

  // Destroyed in reverse: the spinner stops before the node it serves goes (the queue, in the
  // base, goes last).
  std::unique_ptr<MoveBaseRos> move_base_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
};

}  // namespace nav
}  // namespace marl_mrta

PLUGINLIB_EXPORT_CLASS(marl_mrta::nav::MoveBaseNodelet, nodelet::Nodelet)
