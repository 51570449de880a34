#include "marl_mrta/sim/sim_messages_ros.h"

#include <cmath>

#include "marl_mrta/nav/ground_truth_localization.h"
#include "marl_mrta/nav/ros_conversions.h"

namespace marl_mrta {
namespace sim {

RobotMessages robotMessages(const std::string& ns, const LidarSpec& lidar, double scan_rate) {
  RobotMessages msgs;
  msgs.odom.header.frame_id = ns + "/odom";
  msgs.odom.child_frame_id = ns + "/base_footprint";
  msgs.ground_truth.header.frame_id = "map";
  msgs.ground_truth.child_frame_id = ns + "/base_footprint";
  msgs.odom_tf.header.frame_id = msgs.odom.header.frame_id;
  msgs.odom_tf.child_frame_id = msgs.odom.child_frame_id;
  msgs.map_odom_tf.header.frame_id = msgs.ground_truth.header.frame_id;
  msgs.map_odom_tf.child_frame_id = msgs.odom.header.frame_id;
  msgs.scan.header.frame_id = ns + "/base_scan";
  msgs.scan.angle_min = lidar.angle_min;
  msgs.scan.angle_increment = lidar.angleIncrement();
  msgs.scan.angle_max = lidar.angle_min + (lidar.beams - 1) * lidar.angleIncrement();
  msgs.scan.scan_time = scan_rate > 0.0 ? 1.0 / scan_rate : 0.0;
  msgs.scan.time_increment = 0.0;  // every reading of a scan is taken at the same instant
  msgs.scan.range_min = lidar.range_min;
  msgs.scan.range_max = lidar.range_max;
  return msgs;
}

geometry_msgs::Quaternion yawQuaternion(double yaw) {
  geometry_msgs::Quaternion q;
  q.z = std::sin(0.5 * yaw);
  q.w = std::cos(0.5 * yaw);
  return q;
}

void fillOdometry(nav_msgs::Odometry& msg, const ros::Time& stamp, const Pose2D& pose, const Twist2D& velocity) {
  msg.header.stamp = stamp;
  msg.pose.pose.position.x = pose.x;
  msg.pose.pose.position.y = pose.y;
  msg.pose.pose.orientation = yawQuaternion(pose.yaw);
  msg.twist.twist.linear.x = velocity.linear;
  msg.twist.twist.angular.z = velocity.angular;
}

void fillTransform(geometry_msgs::TransformStamped& msg, const ros::Time& stamp, const Pose2D& pose) {
  msg.header.stamp = stamp;
  msg.transform.translation.x = pose.x;
  msg.transform.translation.y = pose.y;
  msg.transform.rotation = yawQuaternion(pose.yaw);
}

void fillLocalization(RobotMessages& msgs) {
  namespace conv = nav::ros_conversions;
  const nav::Transform2D map_base = nav::mapToBase(conv::toPose2D(msgs.ground_truth.pose.pose), nav::Transform2D{});
  const nav::Transform2D map_odom = nav::mapToOdom(map_base, conv::toPose2D(msgs.odom.pose.pose));
  msgs.map_odom_tf.header.stamp = msgs.ground_truth.header.stamp;
  msgs.map_odom_tf.transform.translation.x = map_odom.x;
  msgs.map_odom_tf.transform.translation.y = map_odom.y;
  msgs.map_odom_tf.transform.rotation = conv::quaternionFromYaw(map_odom.yaw);
}

}  // namespace sim
}  // namespace marl_mrta
