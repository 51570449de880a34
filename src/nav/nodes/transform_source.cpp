#include "transform_source.h"

#include <chrono>

namespace marl_mrta {
namespace nav {

TransformSource::TransformSource() {
  ros::NodeHandle nh;
  nh.setCallbackQueue(&queue_);
  listener_ = std::make_unique<tf2_ros::TransformListener>(buffer_, nh, false, ros::TransportHints().tcpNoDelay());
  // The drainer below fills the buffer while a caller waits, as the listener's own thread would:
  // lookups with a timeout (tf2_ros' transform()) are then allowed.
  buffer_.setUsingDedicatedThread(true);
  drainer_ = std::thread([this] {
    while (!stop_ && ros::ok()) {
      drain();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  });
}

TransformSource::~TransformSource() {
  stop_ = true;
  drainer_.join();
}

}  // namespace nav
}  // namespace marl_mrta
