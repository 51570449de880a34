// tf input of the built-in move_base (move_base_ros.h).
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <memory>
#include <thread>

namespace marl_mrta {
namespace nav {

// A tf buffer and the listener that fills it, one per move_base. The listener's messages wait in
// a queue of their own, which move_base drains when it needs a transform: in a nodelet graph the
// simulator's /tf message of a tick is queued before the tick, so the transform is there without
// handing over to another thread. (A buffer shared by the move_base nodelets of a manager made
// them wait for each other's draining.) A thread drains the queue every 10 ms (wall) for
// whatever needs no lock-step.
class TransformSource {
 public:
  TransformSource();
  ~TransformSource();
  tf2_ros::Buffer& buffer() { return buffer_; }
  // Takes every tf message received so far into the buffer.
  void drain() { queue_.callAvailable(); }

 private:
  tf2_ros::Buffer buffer_;
  ros::CallbackQueue queue_;
  std::unique_ptr<tf2_ros::TransformListener> listener_;
  std::atomic<bool> stop_{false};
  std::thread drainer_;
};

}  // namespace nav
}  // namespace marl_mrta
