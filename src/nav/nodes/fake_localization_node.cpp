// fake_localization drop-in: map -> <odom_frame> from the simulator's ground truth, so that
// map -> base equals the true pose (map -> odom = ground truth · odometry⁻¹, paired by stamp).
// Also publishes amcl_pose and a one-pose particlecloud, and accepts initialpose (offset).
// Opt-in ~static_transform (default false, as stock): map -> odom goes to /tf_static, and only
// when it moved by more than a micrometre / microradian: with drift-free odometry it changes only
// at a reset, teleport or initialpose, and every tf listener of the graph would otherwise
// deserialise one /tf message per robot per odometry tick. A latched static for the same child
// frame replaces the old one. Not for drifting odometry: lookups at a past stamp then need the
// transform of that stamp, which only /tf keeps.
#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <cmath>
#include <deque>
#include <memory>

#include "marl_mrta/nav/ground_truth_localization.h"
#include "marl_mrta/nav/ros_conversions.h"

namespace {

using marl_mrta::nav::Pose2D;
using marl_mrta::nav::Transform2D;
namespace conv = marl_mrta::nav::ros_conversions;
namespace nav = marl_mrta::nav;

// Below these, a change of map -> odom is floating-point rounding of ground truth vs odometry.
constexpr double kStaticTolerance = 1e-6;  // [m] and [rad]
bool sameTransform(const Transform2D& a, const Transform2D& b) {
  const double yaw_change = std::remainder(a.yaw - b.yaw, 2.0 * M_PI);
  return std::abs(a.x - b.x) <= kStaticTolerance && std::abs(a.y - b.y) <= kStaticTolerance &&
         std::abs(yaw_change) <= kStaticTolerance;
}

class FakeLocalization {
 public:
  FakeLocalization(ros::NodeHandle& nh, ros::NodeHandle& pnh) {
    odom_frame_ = pnh.param<std::string>("odom_frame_id", "odom");
    global_frame_ = pnh.param<std::string>("global_frame_id", "map");
    transform_tolerance_ = pnh.param("transform_tolerance", 0.1);
    offset_ = {pnh.param("delta_x", 0.0), pnh.param("delta_y", 0.0), pnh.param("delta_yaw", 0.0)};
    if (pnh.param("static_transform", false)) {
      static_broadcaster_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
    } else {
      broadcaster_ = std::make_unique<tf2_ros::TransformBroadcaster>();
    }
    pose_pub_ = nh.advertise<geometry_msgs::PoseWithCovarianceStamped>("amcl_pose", 1);
    cloud_pub_ = nh.advertise<geometry_msgs::PoseArray>("particlecloud", 1);
    // No Nagle delay: in lock-step, move_base waits for the transform made from these.
    truth_sub_ = nh.subscribe("base_pose_ground_truth", 100, &FakeLocalization::onTruth, this,
                              ros::TransportHints().tcpNoDelay());
    odom_sub_ = nh.subscribe("odom", 100, &FakeLocalization::onOdom, this, ros::TransportHints().tcpNoDelay());
    initial_sub_ = nh.subscribe("initialpose", 1, &FakeLocalization::onInitialPose, this);
  }

 private:
  void onOdom(const nav_msgs::Odometry::ConstPtr& msg) {
    odoms_.push_back(msg);
    if (odoms_.size() > 50) odoms_.pop_front();
    tryPair();
  }
  void onTruth(const nav_msgs::Odometry::ConstPtr& msg) {
    truths_.push_back(msg);
    if (truths_.size() > 50) truths_.pop_front();
    last_truth_ = msg;
    tryPair();
  }
  void onInitialPose(const geometry_msgs::PoseWithCovarianceStamped::ConstPtr& msg) {
    if (!last_truth_) return;
    // Choose the offset that puts the current true pose at the requested one.
    const Transform2D truth = nav::asTransform(conv::toPose2D(last_truth_->pose.pose));
    offset_ = nav::compose(nav::asTransform(conv::toPose2D(msg->pose.pose)), nav::inverse(truth));
  }
  // Ground truth and odometry of the same instant give map -> odom.
  void tryPair() {
    while (!truths_.empty()) {
      const auto& truth = truths_.front();
      while (!odoms_.empty() && odoms_.front()->header.stamp < truth->header.stamp) odoms_.pop_front();
      if (odoms_.empty()) return;
      if (odoms_.front()->header.stamp == truth->header.stamp) publish(*truth, *odoms_.front());
      truths_.pop_front();
    }
  }
  void publish(const nav_msgs::Odometry& truth, const nav_msgs::Odometry& odom) {
    const Transform2D map_base = nav::mapToBase(conv::toPose2D(truth.pose.pose), offset_);
    const Transform2D map_odom = nav::mapToOdom(map_base, conv::toPose2D(odom.pose.pose));
    if (!static_broadcaster_ || !static_sent_ || !sameTransform(map_odom, static_map_odom_)) {
      geometry_msgs::TransformStamped tf;
      tf.header.stamp = truth.header.stamp + ros::Duration(transform_tolerance_);
      tf.header.frame_id = global_frame_;
      tf.child_frame_id = odom_frame_;
      tf.transform.translation.x = map_odom.x;
      tf.transform.translation.y = map_odom.y;
      tf.transform.rotation = conv::quaternionFromYaw(map_odom.yaw);
      if (static_broadcaster_) {
        static_broadcaster_->sendTransform(tf);
        static_map_odom_ = map_odom;
        static_sent_ = true;
      } else {
        broadcaster_->sendTransform(tf);
      }
    }
    geometry_msgs::PoseWithCovarianceStamped pose;
    pose.header.stamp = truth.header.stamp;
    pose.header.frame_id = global_frame_;
    pose.pose.pose.position.x = map_base.x;
    pose.pose.pose.position.y = map_base.y;
    pose.pose.pose.orientation = conv::quaternionFromYaw(map_base.yaw);
    if (pose_pub_.getNumSubscribers() > 0) pose_pub_.publish(pose);
    if (cloud_pub_.getNumSubscribers() > 0) {
      geometry_msgs::PoseArray cloud;
      cloud.header = pose.header;
      cloud.poses.push_back(pose.pose.pose);
      cloud_pub_.publish(cloud);
    }
  }

  std::string odom_frame_, global_frame_;
  double transform_tolerance_ = 0.1;
  Transform2D offset_;
  ros::Publisher pose_pub_, cloud_pub_;
  ros::Subscriber truth_sub_, odom_sub_, initial_sub_;
  // Exactly one of the two, after ~static_transform.
  std::unique_ptr<tf2_ros::TransformBroadcaster> broadcaster_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> static_broadcaster_;
  Transform2D static_map_odom_;  // the last map -> odom sent on /tf_static
  bool static_sent_ = false;
  std::deque<nav_msgs::Odometry::ConstPtr> odoms_, truths_;
  nav_msgs::Odometry::ConstPtr last_truth_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "fake_localization");
  ros::NodeHandle nh, pnh("~");
  FakeLocalization node(nh, pnh);
  ros::spin();
  return 0;
}
