// Base of the project's nodelets: their callbacks go to a queue of their own, which the nodelet
// serves with a thread of its own (as a node's ros::spin() does), not through the manager's
// worker pool, which hands every callback over twice.
#pragma once

#include <nodelet/nodelet.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>

namespace marl_mrta {

class OwnQueueNodelet : public nodelet::Nodelet {
 protected:
  // The nodelet's public and private node handles, with their callbacks on queue().
  ros::NodeHandle publicHandle() { return onQueue(getNodeHandle()); }
  ros::NodeHandle privateHandle() { return onQueue(getPrivateNodeHandle()); }
  ros::CallbackQueue& queue() { return queue_; }

 private:
  ros::NodeHandle onQueue(ros::NodeHandle nh) {
    nh.setCallbackQueue(&queue_);
    return nh;
  }

  ros::CallbackQueue queue_;
};

}  // namespace marl_mrta
