// Core state -> ROS messages for the simulator node (frame ids per docs/design.md).
#pragma once

#include <ros/time.h>

#include <string>

#include <geometry_msgs/Quaternion.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/LaserScan.h>

#include "marl_mrta/sim/geometry.h"
#include "marl_mrta/sim/robot_model.h"

namespace marl_mrta {
namespace sim {

// The per-robot messages with everything but the changing fields filled once.
struct RobotMessages {
  nav_msgs::Odometry odom;           // <ns>/odom -> <ns>/base_footprint
  nav_msgs::Odometry ground_truth;   // map -> <ns>/base_footprint
  sensor_msgs::LaserScan scan;       // <ns>/base_scan
  geometry_msgs::TransformStamped odom_tf;      // <ns>/odom -> <ns>/base_footprint
  geometry_msgs::TransformStamped map_odom_tf;  // map -> <ns>/odom (publish_localization)
};

RobotMessages robotMessages(const std::string& ns, const LidarSpec& lidar, double scan_rate);

geometry_msgs::Quaternion yawQuaternion(double yaw);

// Pose and body velocity into an Odometry; the frames stay as they are.
void fillOdometry(nav_msgs::Odometry& msg, const ros::Time& stamp, const Pose2D& pose, const Twist2D& velocity);
void fillTransform(geometry_msgs::TransformStamped& msg, const ros::Time& stamp, const Pose2D& pose);
// map -> odom from the filled ground truth and odometry, computed from those messages exactly as
// the fake_localization node computes it (nav/ground_truth_localization.h): the same bits.
void fillLocalization(RobotMessages& msgs);

}  // namespace sim
}  // namespace marl_mrta
